#include "child_process.hpp"

#include <fcntl.h>
#include <spdlog/spdlog.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "fleet_monitor.hpp"

namespace esfleet::fleet {

namespace {

using Clock = std::chrono::steady_clock;

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

double clock_ticks_per_second() {
  static const double hz = static_cast<double>(sysconf(_SC_CLK_TCK));
  return hz;
}

}  // namespace

double ChildProcess::cpu_s() const { return static_cast<double>(ticks) / clock_ticks_per_second(); }

pid_t spawn(const std::vector<std::string>& argv, const std::string& log) {
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error("fork failed starting " + argv[0]);
  if (pid == 0) {
    setpgid(0, 0);
    const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      dup2(fd, STDOUT_FILENO);
      dup2(fd, STDERR_FILENO);
      close(fd);
    }
    execv(args[0], args.data());
    std::fprintf(stderr, "esfleet-fleet: cannot run %s: %s\n", args[0], std::strerror(errno));
    _exit(127);
  }
  return pid;
}

void start(ChildProcess& c, const std::vector<std::string>& argv) { c.pid = spawn(argv, c.log); }

void restart(ChildProcess& c, const std::vector<std::string>& argv) {
  if (!c.exited) throw std::logic_error("restart of " + c.name + ", which has not exited");
  std::error_code ignored;  // a log that cannot be kept is no reason not to restart
  std::filesystem::rename(c.log, c.log + "." + std::to_string(c.restarts + 1), ignored);
  c.deaths.push_back(c.exit_code);
  ++c.restarts;
  c.exited = false;
  c.exit_code = 0;
  c.ticks = 0;
  c.rss_kb = 0;
  c.cpu_percent = 0.0;
  c.cpu_s_at_window = 0.0;
  c.pid = -1;
  start(c, argv);
}

void reap(ChildProcess& c) {
  if (c.exited || c.pid <= 0) return;
  int status = 0;
  if (waitpid(c.pid, &status, WNOHANG) == c.pid) {
    c.exited = true;
    c.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }
}

void stop_all(std::vector<ChildProcess*> children, std::chrono::seconds grace) {
  // Never kill(-1 or 0, ...): a child that was not started has pid -1.
  std::erase_if(children, [](const ChildProcess* c) { return c->pid <= 0; });
  for (ChildProcess* c : children) {
    reap(*c);
    if (!c->exited) kill(c->pid, SIGINT);
  }
  const auto deadline = Clock::now() + grace;
  for (ChildProcess* c : children) {
    while (!c->exited && Clock::now() < deadline) {
      reap(*c);
      if (!c->exited) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    if (!c->exited) {
      spdlog::warn("{} did not stop within {} s: killing it", c->name, grace.count());
      kill(c->pid, SIGKILL);
      int status = 0;
      waitpid(c->pid, &status, 0);
      c->exited = true;
      c->exit_code = 128 + SIGKILL;
    }
  }
}

void sample(ChildProcess& c, double dt_s) {
  reap(c);
  if (c.exited) {
    c.cpu_percent = 0.0;
    return;
  }
  const std::string proc = "/proc/" + std::to_string(c.pid);
  const auto ticks = parse_proc_stat_ticks(read_text(proc + "/stat"));
  const auto rss = parse_proc_status_rss_kb(read_text(proc + "/status"));
  if (ticks) {
    if (dt_s > 0 && c.ticks > 0) {
      c.cpu_percent =
          100.0 * static_cast<double>(*ticks - c.ticks) / clock_ticks_per_second() / dt_s;
    }
    c.ticks = *ticks;
  }
  if (rss) {
    c.rss_kb = *rss;
    c.rss_kb_max = std::max(c.rss_kb_max, *rss);
  }
}

}  // namespace esfleet::fleet
