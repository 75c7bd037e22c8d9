// ReplayApp: a bad log or --first-scan fails the constructor naming it; a run publishes every
// scan from --first-scan on, in order, numbered from 0, to a reader in this process (DDS
// domains 186 and 187, shared memory), and a stop before the run sends nothing and ends 130.
#include "replay_app.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "app/program.hpp"
#include "esfleet/dds/reader.hpp"

namespace esfleet::sim {
namespace {

const std::string kLog = std::string(ESFLEET_TEST_DATA_DIR) + "/carmen/mit-csail-excerpt.clf";
const std::string kShm = std::string(ESFLEET_FASTDDS_PROFILE_DIR) + "/localhost-shm.xml";

ReplayOptions options(int domain) {
  ReplayOptions o;
  o.log = kLog;
  o.robot_id = "r1";
  o.rate = 0.0;
  o.domain = domain;
  o.profile = kShm;
  o.wait_subscribers = 0;
  return o;
}

std::string construction_error(const ReplayOptions& o) {
  std::atomic<bool> stop{false};
  try {
    ReplayApp app(o, stop);
  } catch (const app::UsageError& e) {
    return e.what();
  }
  return "";
}

TEST(ReplayApp, AMissingLogIsAUsageErrorNamingTheFile) {
  ReplayOptions o = options(186);
  o.log = "/nonexistent/esfleet.log";
  EXPECT_EQ(construction_error(o).rfind("/nonexistent/esfleet.log: cannot open", 0), 0u)
      << construction_error(o);
}

TEST(ReplayApp, FirstScanPastTheEndNamesTheFlag) {
  ReplayOptions o = options(186);
  o.first_scan = 5;  // the excerpt has 5 scans
  EXPECT_EQ(construction_error(o), "--first-scan 5: " + kLog + " has only 5 scans");
  o.max_scans = 3;
  o.first_scan = 3;
  EXPECT_EQ(construction_error(o),
            "--first-scan 3: " + kLog + " has only 3 scans (with --max-scans)");
}

TEST(ReplayApp, PublishesEveryScanFromFirstScanInOrder) {
  dds::Node node({186, kShm, "replay_app_test"});
  std::mutex mutex;
  std::vector<msg::LaserScanMsg> got;
  dds::ScanReader reader(
      node,
      [&](const msg::LaserScanMsg& m, const dds::SampleMeta&) {
        std::lock_guard lock(mutex);
        got.push_back(m);
      },
      "r1");
  ReplayOptions o = options(186);
  o.first_scan = 2;
  o.odometry = false;
  o.wait_subscribers = 1;
  o.wait_timeout = 10.0;
  std::atomic<bool> stop{false};
  ReplayApp app(o, stop);
  ASSERT_EQ(app.scans().size(), 3u);
  EXPECT_EQ(app.run(), app::kExitOk);
  for (int i = 0; i < 100; ++i) {  // acknowledged means received; a margin for the callback
    {
      std::lock_guard lock(mutex);
      if (got.size() >= 3) break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  std::lock_guard lock(mutex);
  ASSERT_EQ(got.size(), 3u);
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].seq(), i);
    EXPECT_EQ(got[i].stamp(), app.scans()[i].stamp);
    EXPECT_EQ(got[i].robot_id().to_string(), "r1");
    EXPECT_FALSE(got[i].has_odometry());  // --odometry off
  }
}

TEST(ReplayApp, StoppedBeforeTheRunSendsNothingAndEndsWith130) {
  std::atomic<bool> stop{false};
  ReplayApp app(options(187), stop);
  stop = true;
  EXPECT_EQ(app.run(), app::kExitInterrupted);
}

}  // namespace
}  // namespace esfleet::sim
