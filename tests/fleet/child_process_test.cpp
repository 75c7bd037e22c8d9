// The launcher's children as real processes (/bin/sh): exit codes, their log, stopping with
// SIGINT and, past the grace period, SIGKILL, and sampling /proc.
#include "child_process.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

namespace esfleet::fleet {
namespace {

namespace fs = std::filesystem;
using std::chrono::seconds;

class ChildProcessTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("esfleet-child-process-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override {
    stop_all({&c_}, seconds(1));  // nothing left behind whatever failed
    fs::remove_all(dir_);
  }
  /// Starts /bin/sh -c `script` as c_.
  void run_sh(const std::string& script) {
    c_.name = "sh";
    c_.log = (dir_ / "sh.log").string();
    start(c_, {"/bin/sh", "-c", script});
    ASSERT_TRUE(c_.started());
  }
  /// Reaps c_ until it exited (at most 10 s).
  void wait_exit() {
    for (int i = 0; i < 500 && !c_.exited; ++i) {
      reap(c_);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
  std::string log_text() const {
    std::ifstream in(c_.log);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  }
  fs::path dir_;
  ChildProcess c_;
};

TEST_F(ChildProcessTest, ReapsTheExitCodeAndWritesTheLog) {
  run_sh("echo to-stdout; echo to-stderr >&2; exit 3");
  wait_exit();
  ASSERT_TRUE(c_.exited);
  EXPECT_EQ(c_.exit_code, 3);
  const std::string log = log_text();
  EXPECT_NE(log.find("to-stdout"), std::string::npos) << log;
  EXPECT_NE(log.find("to-stderr"), std::string::npos) << log;
}

TEST_F(ChildProcessTest, AProgramThatCannotRunExits127) {
  c_.name = "missing";
  c_.log = (dir_ / "missing.log").string();
  start(c_, {(dir_ / "no-such-program").string()});
  wait_exit();
  ASSERT_TRUE(c_.exited);
  EXPECT_EQ(c_.exit_code, 127);
  EXPECT_NE(log_text().find("cannot run"), std::string::npos) << log_text();
}

TEST_F(ChildProcessTest, StopAllSendsSigint) {
  run_sh("exec sleep 30");
  const auto t0 = std::chrono::steady_clock::now();
  stop_all({&c_}, seconds(10));
  EXPECT_TRUE(c_.exited);
  EXPECT_EQ(c_.exit_code, 128 + SIGINT);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, seconds(5));
}

TEST_F(ChildProcessTest, StopAllKillsAChildThatIgnoresSigintAfterTheGrace) {
  run_sh("trap '' INT; exec sleep 30");
  std::this_thread::sleep_for(std::chrono::milliseconds(200));  // the trap is set
  const auto t0 = std::chrono::steady_clock::now();
  stop_all({&c_}, seconds(1));
  EXPECT_TRUE(c_.exited);
  EXPECT_EQ(c_.exit_code, 128 + SIGKILL);
  EXPECT_GE(std::chrono::steady_clock::now() - t0, seconds(1));
}

TEST_F(ChildProcessTest, StopAllSkipsChildrenNeverStarted) {
  ChildProcess never;
  never.name = "never";
  stop_all({&never}, seconds(1));  // must not kill(-1, ...): this test process would die
  EXPECT_FALSE(never.exited);
  EXPECT_FALSE(never.started());
}

TEST_F(ChildProcessTest, SampleReadsMemoryAndZeroesCpuOnceExited) {
  run_sh("exec sleep 30");
  sample(c_, 0.0);
  EXPECT_GT(c_.rss_kb, 0u);
  EXPECT_GE(c_.rss_kb_max, c_.rss_kb);
  stop_all({&c_}, seconds(5));
  c_.cpu_percent = 50.0;
  const std::uint64_t rss_max = c_.rss_kb_max;
  sample(c_, 1.0);
  EXPECT_EQ(c_.cpu_percent, 0.0);
  EXPECT_EQ(c_.rss_kb_max, rss_max);
}

TEST_F(ChildProcessTest, RestartStartsADeadChildAgainKeepingItsLogAndCountingIt) {
  run_sh("echo first-run; kill -9 $$");
  EXPECT_THROW(restart(c_, {"/bin/sh", "-c", "true"}), std::logic_error);  // still running
  wait_exit();
  ASSERT_TRUE(c_.exited);
  EXPECT_EQ(c_.exit_code, 128 + SIGKILL);
  const pid_t first = c_.pid;
  restart(c_, {"/bin/sh", "-c", "echo second-run; exit 4"});
  EXPECT_NE(c_.pid, first);
  EXPECT_FALSE(c_.exited);
  EXPECT_EQ(c_.restarts, 1);
  ASSERT_EQ(c_.deaths, std::vector<int>{128 + SIGKILL});
  wait_exit();
  EXPECT_EQ(c_.exit_code, 4);
  EXPECT_EQ(log_text(), "second-run\n");
  std::ifstream old(c_.log + ".1");
  std::string line;
  std::getline(old, line);
  EXPECT_EQ(line, "first-run");
}

}  // namespace
}  // namespace esfleet::fleet
