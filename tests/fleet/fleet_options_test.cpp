// esfleet-fleet's command line: flags parsed from an argv into FleetOptions, and validate()
// naming the flag whose value or file is wrong.
#include "fleet_options.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "app/program.hpp"

namespace esfleet::fleet {
namespace {

namespace fs = std::filesystem;

std::optional<int> parse(FleetOptions& o, std::vector<std::string> args) {
  app::Program p("esfleet-fleet", "fleet", "test");
  add_fleet_flags(p.cli(), o);
  args.insert(args.begin(), "esfleet-fleet");
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  return p.parse(static_cast<int>(argv.size()), argv.data());
}

/// validate()'s message, or "" when it passes.
std::string usage_error(const FleetOptions& o) {
  try {
    o.validate();
  } catch (const app::UsageError& e) {
    return e.what();
  }
  return "";
}

/// A directory with the files a valid FleetOptions points at: world, log, profile and a bin
/// directory with the three programs (empty executables).
class FleetOptionsFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("esfleet-fleet-options-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_ / "bin");
    for (const char* f : {"map.yaml", "log.clf", "profile.xml"}) std::ofstream(dir_ / f) << "x\n";
    for (const char* p : {"esfleet-leader", "esfleet-follower", "esfleet-sim"}) {
      std::ofstream(dir_ / "bin" / p) << "#!/bin/sh\n";
      fs::permissions(dir_ / "bin" / p, fs::perms::owner_all);
    }
    o_.world = (dir_ / "map.yaml").string();
    o_.log = (dir_ / "log.clf").string();
    o_.profile = (dir_ / "profile.xml").string();
    o_.bin_dir = (dir_ / "bin").string();
    o_.robots = 2;
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
  FleetOptions o_;
};

TEST(FleetFlags, ParseIntoTheOptions) {
  FleetOptions o;
  ASSERT_EQ(parse(o, {"--robots", "3", "--domain", "9", "--leader-args", "--odometry off --mu 50",
                      "--wait-map", "--live", "false", "--rate", "2.5", "--netns", "s1",
                      "--max-leader-restarts", "7"}),
            std::nullopt);
  EXPECT_EQ(o.netns, "s1");
  EXPECT_EQ(o.max_leader_restarts, 7);
  EXPECT_EQ(o.robots, 3);
  EXPECT_EQ(o.domain, 9);
  EXPECT_EQ(o.leader_args, "--odometry off --mu 50");
  EXPECT_TRUE(o.wait_map);
  EXPECT_FALSE(o.live);
  EXPECT_DOUBLE_EQ(o.rate, 2.5);
  // Untouched flags keep their defaults.
  EXPECT_EQ(o.max_restarts, 5);
  EXPECT_EQ(o.follower_args, "--odometry on");
  EXPECT_EQ(o.out, "out/fleet");
  EXPECT_EQ(o.summary_path(), "out/fleet/summary.json");
}

TEST(FleetFlags, OutOfRangeValuesAreUsageErrors) {
  FleetOptions a;
  EXPECT_EQ(parse(a, {"--robots", "65"}), std::optional<int>(app::kExitUsage));
  FleetOptions b;
  EXPECT_EQ(parse(b, {"--rate", "0"}), std::optional<int>(app::kExitUsage));
  FleetOptions c;
  EXPECT_EQ(parse(c, {"--domain", "233"}), std::optional<int>(app::kExitUsage));
}

TEST_F(FleetOptionsFiles, ValidOptionsPass) { EXPECT_EQ(usage_error(o_), ""); }

TEST_F(FleetOptionsFiles, MissingFilesNameTheirFlag) {
  FleetOptions o = o_;
  o.world = (dir_ / "nope.yaml").string();
  EXPECT_EQ(usage_error(o), "--world " + o.world + ": no such file");
  o = o_;
  o.log = (dir_ / "nope.clf").string();
  EXPECT_EQ(usage_error(o), "--log " + o.log + ": no such file");
  o = o_;
  o.profile = dir_.string();  // a directory is not a profile
  EXPECT_EQ(usage_error(o), "--profile " + o.profile + ": no such file");
}

TEST_F(FleetOptionsFiles, BinDirWithoutAProgramNamesIt) {
  fs::remove(dir_ / "bin" / "esfleet-sim");
  EXPECT_EQ(usage_error(o_), "--bin-dir " + o_.bin_dir + ": no executable esfleet-sim");
}

TEST_F(FleetOptionsFiles, SecureNeedsADirectoryPerIdentity) {
  o_.secure = (dir_ / "certs").string();
  for (const char* id : {"leader", "sim", "monitor", "robot-1"}) {
    fs::create_directories(dir_ / "certs" / id);
  }
  // robot-2 is missing (--robots 2).
  const std::string e = usage_error(o_);
  EXPECT_NE(e.find("--secure " + o_.secure + ": no directory " + o_.secure + "/robot-2"),
            std::string::npos)
      << e;
  fs::create_directories(dir_ / "certs" / "robot-2");
  EXPECT_EQ(usage_error(o_), "");
}

TEST_F(FleetOptionsFiles, ViewNeedsItsProgramAndItsIdentity) {
  o_.view_port = 8080;
  EXPECT_EQ(usage_error(o_), "--bin-dir " + o_.bin_dir + ": no executable esfleet-view");
  o_.view_port = -1;  // no view: esfleet-view not needed
  EXPECT_EQ(usage_error(o_), "");
  o_.view_port = 70000;
  EXPECT_NE(usage_error(o_).find("--view"), std::string::npos);
  o_.view_port = 0;
  const std::vector<std::string> ids = o_.identities();
  EXPECT_NE(std::find(ids.begin(), ids.end(), "view"), ids.end());
}

TEST_F(FleetOptionsFiles, NetnsNeedsATestbedWithAHostPerProgram) {
  o_.netns = "no_such_run_x";  // --robots 2: hosts 1 .. 4
  EXPECT_EQ(usage_error(o_),
            "--netns no_such_run_x: no network namespace esf-no_such_run_x-4 (4 hosts needed: "
            "deploy/netns/testbed.sh up no_such_run_x 4)");
  o_.netns = "a-b";
  EXPECT_EQ(usage_error(o_), "--netns a-b: a testbed RUN name is letters, digits and _");
  o_.netns.clear();
  o_.max_leader_restarts = -1;
  EXPECT_EQ(usage_error(o_), "--max-leader-restarts must be >= 0");
}

TEST(FleetFlags, ViewTakesAPort) {
  FleetOptions o;
  ASSERT_EQ(parse(o, {"--view", "8081", "--view-args", "--bind 127.0.0.1"}), std::nullopt);
  EXPECT_EQ(o.view_port, 8081);
  EXPECT_EQ(o.view_args, "--bind 127.0.0.1");
  FleetOptions d;
  ASSERT_EQ(parse(d, {}), std::nullopt);
  EXPECT_EQ(d.view_port, -1);
  FleetOptions bad;
  EXPECT_EQ(parse(bad, {"--view", "65536"}), std::optional<int>(app::kExitUsage));
}

TEST_F(FleetOptionsFiles, ValuesOutOfRangeNameTheirFlag) {
  FleetOptions o = o_;
  o.robots = 0;
  EXPECT_NE(usage_error(o).find("--robots"), std::string::npos);
  o = o_;
  o.rate = -1.0;
  EXPECT_NE(usage_error(o).find("--rate"), std::string::npos);
  o = o_;
  o.window = -2.0;
  EXPECT_NE(usage_error(o).find("--window"), std::string::npos);
}

}  // namespace
}  // namespace esfleet::fleet
