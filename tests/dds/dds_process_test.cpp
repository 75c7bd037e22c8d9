// Real-process tests of the esfleet DDS layer: spawns dds_roundtrip_peer publishers and
// subscribers (fork/exec) and checks what a late joiner receives, over shared memory, over
// loopback UDP and through a discovery server, plus a clean failure for a missing profile.
//
// Every test has its own domain id (and discovery server port), so CTest may run them in
// parallel. Children are bounded: each wait has a deadline, children still running at the end
// get SIGTERM, then SIGKILL, and die with the test process (PR_SET_PDEATHSIG). The shared-memory
// files each child reported, or had open when it was told to stop, must be gone once all
// children have exited; the files of children killed by a signal are removed.

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

const std::string kPeer = ESFLEET_DDS_PEER;
const std::string kProfiles = ESFLEET_FASTDDS_PROFILE_DIR;

/// /dev/shm/fastrtps* files process `pid` has mapped or open (read from /proc).
std::set<std::string> shm_files_of(pid_t pid) {
  std::set<std::string> files;
  auto consider = [&](std::string path) {
    if (path.rfind("/dev/shm/", 0) == 0 && path.find("fastrtps") != std::string::npos) {
      files.insert(path.substr(0, path.find(" (deleted)")));
    }
  };
  const std::string proc = "/proc/" + std::to_string(pid);
  std::ifstream maps(proc + "/maps");
  for (std::string line; std::getline(maps, line);) {
    if (auto slash = line.find('/'); slash != std::string::npos) consider(line.substr(slash));
  }
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(proc + "/fd", ec)) {
    std::error_code link_ec;
    const fs::path target = fs::read_symlink(entry.path(), link_ec);
    if (!link_ec) consider(target.string());
  }
  return files;
}

std::vector<std::string> tagged(const std::string& output, const std::string& prefix);

/// Adds the named-semaphore file Fast DDS keeps next to each shared-memory port
/// (/dev/shm/fastrtps_port7411 -> /dev/shm/sem.fastrtps_port7411_mutex).
void add_port_mutexes(std::set<std::string>& files) {
  const std::string port_prefix = "/dev/shm/fastrtps_port";
  std::set<std::string> mutexes;
  for (const auto& f : files) {
    if (f.rfind(port_prefix, 0) == 0 && f.find('_', port_prefix.size()) == std::string::npos) {
      mutexes.insert("/dev/shm/sem." + f.substr(9) + "_mutex");
    }
  }
  files.insert(mutexes.begin(), mutexes.end());
}

/// /dev/shm/fastrtps* files some live process uses (ports are shared by all participants of a
/// domain on the host, so another program on the same domain may legitimately hold them).
std::set<std::string> shm_files_in_use() {
  std::set<std::string> files;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator("/proc", ec)) {
    const std::string name = entry.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    const auto f = shm_files_of(static_cast<pid_t>(std::stol(name)));
    files.insert(f.begin(), f.end());
  }
  add_port_mutexes(files);
  return files;
}

/// Removes those of `files` that still exist and no live process uses; returns them.
std::vector<std::string> remove_leftovers(std::set<std::string> files) {
  add_port_mutexes(files);
  const std::set<std::string> in_use = shm_files_in_use();
  std::vector<std::string> left;
  for (const auto& f : files) {
    if (fs::exists(f) && !in_use.count(f)) left.push_back(f);
  }
  for (const auto& f : left) {
    std::error_code ec;
    fs::remove(f, ec);
  }
  return left;
}

/// A child process with stdout and stderr captured together through a pipe.
class Child {
 public:
  explicit Child(const std::vector<std::string>& argv) {
    int fds[2];
    if (pipe2(fds, O_CLOEXEC) != 0) throw std::runtime_error("pipe2 failed");
    const pid_t parent = getpid();
    pid_ = fork();
    if (pid_ < 0) throw std::runtime_error("fork failed");
    if (pid_ == 0) {
      // Child: die with the test (SIGTERM lets a peer tear down cleanly).
      prctl(PR_SET_PDEATHSIG, SIGTERM);
      if (getppid() != parent) _exit(127);
      dup2(fds[1], STDOUT_FILENO);
      dup2(fds[1], STDERR_FILENO);
      std::vector<char*> args;
      for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
      args.push_back(nullptr);
      execv(args[0], args.data());
      _exit(127);
    }
    close(fds[1]);
    fd_ = fds[0];
  }
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;

  ~Child() {
    if (running()) stop(milliseconds(3000));
    if (fd_ >= 0) close(fd_);
    if (killed_) remove_leftovers(tracked_files_);  // a killed child cannot remove its files
  }

  pid_t pid() const { return pid_; }
  bool running() const { return pid_ > 0 && !exit_code_; }
  const std::string& output() const { return output_; }
  /// Files this child reported with "SHM <path>" or had open when stop() signalled it.
  std::set<std::string> shm_files() const;

  /// Reads output until a line starting with `prefix` arrives; returns it, or nullopt when the
  /// deadline passes or the child closes its output.
  std::optional<std::string> wait_line(const std::string& prefix, milliseconds timeout) {
    const auto deadline = Clock::now() + timeout;
    std::size_t scanned = 0;
    while (true) {
      for (std::size_t eol; (eol = output_.find('\n', scanned)) != std::string::npos;) {
        std::string line = output_.substr(scanned, eol - scanned);
        scanned = eol + 1;
        if (line.rfind(prefix, 0) == 0) return line;
      }
      if (!read_some(deadline)) return std::nullopt;
    }
  }

  /// Waits for the child to exit and returns its exit code (128 + signal if killed by one);
  /// nullopt if it is still running at the deadline.
  std::optional<int> wait_exit(milliseconds timeout) {
    const auto deadline = Clock::now() + timeout;
    while (!exit_code_) {
      int status = 0;
      const pid_t r = waitpid(pid_, &status, WNOHANG);
      if (r == pid_) {
        exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
        killed_ = killed_ || WIFSIGNALED(status);
        break;
      }
      if (Clock::now() >= deadline) return std::nullopt;
      read_some(std::min(deadline, Clock::now() + milliseconds(20)));
    }
    while (read_some(Clock::now() + milliseconds(50))) {
    }
    return exit_code_;
  }

  /// Sends `signal` (SIGTERM by default; fast-discovery-server only shuts down cleanly on
  /// SIGINT), then SIGKILL if the child has not exited within `grace`.
  std::optional<int> stop(milliseconds grace, int signal = SIGTERM) {
    if (!running()) return exit_code_;
    const auto files = shm_files_of(pid_);
    tracked_files_.insert(files.begin(), files.end());
    kill(pid_, signal);
    if (auto code = wait_exit(grace)) return code;
    killed_ = true;
    kill(pid_, SIGKILL);
    return wait_exit(milliseconds(2000));
  }

 private:
  /// Appends what the child wrote before `deadline`; false on EOF or timeout.
  bool read_some(Clock::time_point deadline) {
    if (fd_ < 0) return false;
    const auto left = std::chrono::duration_cast<milliseconds>(deadline - Clock::now()).count();
    pollfd p{fd_, POLLIN, 0};
    if (poll(&p, 1, static_cast<int>(std::max<long long>(0, left))) <= 0) return false;
    char buf[4096];
    const ssize_t n = read(fd_, buf, sizeof buf);
    if (n <= 0) {
      close(fd_);
      fd_ = -1;
      return false;
    }
    output_.append(buf, static_cast<std::size_t>(n));
    return true;
  }

  pid_t pid_ = -1;
  int fd_ = -1;
  std::string output_;
  std::optional<int> exit_code_;
  std::set<std::string> tracked_files_;
  bool killed_ = false;
};

std::set<std::string> Child::shm_files() const {
  std::set<std::string> files = tracked_files_;
  for (auto& f : tagged(output_, "SHM ")) files.insert(f);
  return files;
}

/// "key=value" fields of a RESULT/READY line.
std::map<std::string, std::string> fields(const std::string& line) {
  std::map<std::string, std::string> out;
  static const std::regex kField(R"((\w+)=(\S+))");
  for (std::sregex_iterator it(line.begin(), line.end(), kField), end; it != end; ++it) {
    out[(*it)[1]] = (*it)[2];
  }
  return out;
}

/// Checks that none of the children's shared-memory files survived them (files that another
/// live process uses do not count), then removes any that did so a failing test does not
/// litter /dev/shm.
void expect_shm_released(const std::vector<const Child*>& children) {
  std::set<std::string> files;
  for (const Child* c : children) {
    ASSERT_FALSE(c->running()) << "check /dev/shm only after every child exited";
    const auto f = c->shm_files();
    files.insert(f.begin(), f.end());
  }
  const std::vector<std::string> left = remove_leftovers(files);
  EXPECT_TRUE(left.empty()) << left.size() << " of " << files.size()
                            << " shared-memory files left behind, e.g. " << left.front();
}

std::vector<std::string> peer(const std::string& role, int domain, const std::string& profile,
                              std::vector<std::string> extra = {}) {
  std::vector<std::string> argv{kPeer, "--role", role, "--domain", std::to_string(domain)};
  if (!profile.empty()) {
    argv.insert(argv.end(), {"--profile", profile});
  }
  argv.insert(argv.end(), extra.begin(), extra.end());
  return argv;
}

/// Lines of `output` that start with `prefix`, without it.
std::vector<std::string> tagged(const std::string& output, const std::string& prefix) {
  std::vector<std::string> out;
  std::istringstream in(output);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind(prefix, 0) == 0) out.push_back(line.substr(prefix.size()));
  }
  return out;
}

enum class Transport { kSharedMemory, kLoopbackUdp };

/// Checks that a peer used exactly the transport its profile asks for (so the profile was
/// really applied, not silently replaced by Fast DDS's defaults).
void expect_transport(const Child& c, Transport t) {
  const auto udp = tagged(c.output(), "UDP ");
  const auto shm = tagged(c.output(), "SHM ");
  if (t == Transport::kSharedMemory) {
    EXPECT_TRUE(udp.empty()) << "shared-memory profile but UDP socket " << udp.front();
    EXPECT_FALSE(shm.empty()) << "shared-memory profile but no /dev/shm file in use";
  } else {
    EXPECT_TRUE(shm.empty()) << "UDP profile but shared memory in use: " << shm.front();
    EXPECT_FALSE(udp.empty()) << "UDP profile but no UDP socket";
    for (const auto& s : udp) EXPECT_EQ(s.rfind("127.0.0.1:", 0), 0u) << "socket on " << s;
  }
}

/// (a)/(b): the publisher writes 50 tiles x 3 versions and waits; a subscriber started only
/// then must receive exactly 50 samples, all at version 3.
void late_joiner(int domain, const std::string& profile, Transport transport) {
  const std::vector<std::string> common{"--count", "50", "--versions", "3"};
  Child pub(peer("pub", domain, profile, common));
  const auto ready = pub.wait_line("READY", milliseconds(8000));
  ASSERT_TRUE(ready) << "publisher never got ready:\n" << pub.output();
  const auto wrote = fields(*ready);
  EXPECT_EQ(wrote.at("written"), "150");
  EXPECT_EQ(wrote.at("failures"), "0");

  const auto t0 = Clock::now();
  Child sub(peer("sub", domain, profile, common));
  const auto result = sub.wait_line("RESULT", milliseconds(12000));
  const auto sub_code = sub.wait_exit(milliseconds(3000));
  const double late_join_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  ASSERT_TRUE(result) << "subscriber printed no result:\n" << sub.output();
  const auto got = fields(*result);
  EXPECT_EQ(got.at("received"), "50") << *result;
  EXPECT_EQ(got.at("distinct"), "50") << *result;
  EXPECT_EQ(got.at("newest"), "50") << *result;
  EXPECT_EQ(got.at("payload_ok"), "1") << *result;
  EXPECT_EQ(sub_code, std::optional<int>(0)) << sub.output();

  EXPECT_EQ(pub.stop(milliseconds(5000)), std::optional<int>(0)) << pub.output();
  ::testing::Test::RecordProperty("late_join_ms", static_cast<int>(late_join_ms));
  expect_transport(pub, transport);
  expect_transport(sub, transport);
  std::cout << "[ measured ] " << *ready << "\n[ measured ] " << *result
            << "\n[ measured ] subscriber process start to exit: " << late_join_ms << " ms\n";
  expect_shm_released({&pub, &sub});
}

TEST(DdsProcessTest, LateJoinerGetsNewestVersionOfEveryTileOverSharedMemory) {
  late_joiner(101, ESFLEET_SHM_TEST_PROFILE, Transport::kSharedMemory);
}

TEST(DdsProcessTest, LateJoinerGetsNewestVersionOfEveryTileOverLoopbackUdp) {
  late_joiner(102, kProfiles + "/localhost-udp.xml", Transport::kLoopbackUdp);
}

TEST(DdsProcessTest, MissingProfileFileIsAClearErrorNotACrash) {
  const std::string missing = "/nonexistent/esfleet-no-such-profile.xml";
  Child sub(peer("sub", 103, missing, {"--timeout-ms", "2000"}));
  const auto code = sub.wait_exit(milliseconds(5000));
  EXPECT_EQ(code, std::optional<int>(2)) << sub.output();
  EXPECT_NE(sub.output().find(missing), std::string::npos) << sub.output();
  EXPECT_NE(sub.output().find("does not exist"), std::string::npos) << sub.output();
  expect_shm_released({&sub});
}

/// Discovery through fast-discovery-server with deploy/fastdds/discovery-client.xml (its port
/// rewritten to this test's own: domain ids do not isolate clients of one server).
TEST(DdsProcessTest, LateJoinerThroughDiscoveryServer) {
  const std::string server = ESFLEET_FAST_DISCOVERY_SERVER;
  if (server.empty() || !fs::exists(server)) GTEST_SKIP() << "fast-discovery-server not found";
  const int port = 21104;
  std::ifstream in(kProfiles + "/discovery-client.xml");
  std::stringstream xml;
  xml << in.rdbuf();
  std::string text = std::regex_replace(xml.str(), std::regex("<port>11811</port>"),
                                        "<port>" + std::to_string(port) + "</port>");
  ASSERT_NE(text, xml.str()) << "discovery-client.xml no longer holds <port>11811</port>";
  const fs::path profile =
      fs::temp_directory_path() / ("esfleet-discovery-client-" + std::to_string(getpid()) + ".xml");
  std::ofstream(profile) << text;

  Child srv({server, "-i", "0", "-l", "127.0.0.1", "-p", std::to_string(port)});
  std::this_thread::sleep_for(milliseconds(300));
  ASSERT_TRUE(srv.running()) << srv.output();
  {
    const std::vector<std::string> common{"--count", "20", "--versions", "2"};
    Child pub(peer("pub", 104, profile.string(), common));
    ASSERT_TRUE(pub.wait_line("READY", milliseconds(8000))) << pub.output();
    Child sub(peer("sub", 104, profile.string(), common));
    const auto result = sub.wait_line("RESULT", milliseconds(12000));
    ASSERT_TRUE(result) << sub.output();
    const auto got = fields(*result);
    EXPECT_EQ(got.at("received"), "20") << *result;
    EXPECT_EQ(got.at("newest"), "20") << *result;
    EXPECT_EQ(sub.wait_exit(milliseconds(3000)), std::optional<int>(0)) << sub.output();
    EXPECT_EQ(pub.stop(milliseconds(5000)), std::optional<int>(0)) << pub.output();
    std::cout << "[ measured ] discovery server: " << *result << "\n";
    for (const Child* c : {&pub, &sub}) {  // the profile is UDP only (docs/faults.md)
      EXPECT_TRUE(tagged(c->output(), "SHM ").empty()) << c->output();
      EXPECT_FALSE(tagged(c->output(), "UDP ").empty()) << c->output();
    }
    EXPECT_EQ(srv.stop(milliseconds(3000), SIGINT), std::optional<int>(0)) << srv.output();
    expect_shm_released({&pub, &sub, &srv});
  }
  fs::remove(profile);
}

}  // namespace
