// SimApp without DDS (--offline): the run writes one log line pair per robot and tick, returns
// 0 after --duration and 130 when stopped; a bad world or log directory fails the constructor
// naming the flag.
#include "sim_app.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <string>

#include "app/program.hpp"

namespace esfleet::sim {
namespace {

namespace fs = std::filesystem;

class SimAppTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("esfleet-sim-app-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    o_.world = std::string(ESFLEET_DATA_DIR) + "/worlds/mit-csail/map.yaml";
    o_.fleet.robots = 2;
    o_.start_stamp = 1000.0;
    o_.offline = true;
    o_.out_log = dir_.string();
    o_.duration = 2.0;  // 10 ticks at 5 Hz
  }
  void TearDown() override { fs::remove_all(dir_); }
  /// The constructor's UsageError message, or "" if it built.
  std::string construction_error() {
    try {
      SimApp app(o_, stop_);
    } catch (const app::UsageError& e) {
      return e.what();
    }
    return "";
  }
  /// The lines of `file` after its '#' header.
  std::vector<std::string> lines(const fs::path& file) const {
    std::ifstream in(file);
    std::vector<std::string> out;
    for (std::string l; std::getline(in, l);) {
      if (!l.starts_with("#")) out.push_back(l);
    }
    return out;
  }
  fs::path dir_;
  SimOptions o_;
  std::atomic<bool> stop_{false};
};

TEST_F(SimAppTest, OfflineRunWritesEveryTickAndEndsWith0) {
  ASSERT_NO_THROW(o_.validate());
  SimApp app(o_, stop_);
  EXPECT_EQ(app.run(), app::kExitOk);
  EXPECT_EQ(app.fleet().ticks(), 10u);
  for (const char* id : {"robot-1", "robot-2"}) {
    const auto truth = lines(dir_ / (std::string(id) + ".truth"));
    ASSERT_EQ(truth.size(), 10u) << id;
    EXPECT_EQ(truth.front().rfind("1000.200000 ", 0), 0u) << truth.front();  // tick 1 at 0.2 s
    EXPECT_EQ(truth.back().rfind("1002.000000 ", 0), 0u) << truth.back();
    EXPECT_EQ(lines(dir_ / (std::string(id) + ".log")).size(), 20u);  // ODOM + FLASER per tick
  }
}

TEST_F(SimAppTest, StoppedBeforeTheFirstTickEndsWith130) {
  SimApp app(o_, stop_);
  stop_ = true;
  EXPECT_EQ(app.run(), app::kExitInterrupted);
  EXPECT_EQ(app.fleet().ticks(), 0u);
  EXPECT_TRUE(fs::exists(dir_ / "robot-1.log"));
}

TEST_F(SimAppTest, AMissingWorldNamesTheFlagAndTheFile) {
  o_.world = (dir_ / "nope.yaml").string();
  EXPECT_EQ(construction_error().rfind("--world " + o_.world + ": ", 0), 0u)
      << construction_error();
}

TEST_F(SimAppTest, ALogDirectoryThatCannotBeMadeNamesTheFlag) {
  o_.out_log = "/proc/esfleet-no-such-dir";
  EXPECT_EQ(construction_error().rfind("--out-log /proc/esfleet-no-such-dir", 0), 0u)
      << construction_error();
}

}  // namespace
}  // namespace esfleet::sim
