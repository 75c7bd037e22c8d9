#pragma once
// The programs the fleet launcher starts, as processes: start (fork + exec, output to a log
// file), reap without blocking, sample CPU and memory from /proc, and stop in order (SIGINT,
// a grace period for the programs to save, then SIGKILL). POSIX only; no DDS.

#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

namespace esfleet::fleet {

/// One program the launcher started (or will start: pid -1 until then).
struct ChildProcess {
  std::string name;              ///< "leader", "sim", "robot-k"
  pid_t pid = -1;                ///< -1: not started
  std::string log;               ///< its stdout and stderr
  bool exited = false;           ///< reaped
  int exit_code = 0;             ///< exit status, or 128 + signal
  std::uint64_t ticks = 0;       ///< utime + stime at the last sample
  std::uint64_t rss_kb = 0;      ///< at the last sample
  std::uint64_t rss_kb_max = 0;  ///< over all samples
  double cpu_percent = 0.0;      ///< over the last sampling interval
  double cpu_s_at_window = 0.0;  ///< CPU seconds when the measuring window started
  int restarts = 0;              ///< times restart() started it again after it died
  std::vector<int> deaths;       ///< exit_code of each run that restart() replaced

  bool started() const { return pid > 0; }
  /// CPU seconds (user + system) at the last sample.
  double cpu_s() const;
};

/// fork + exec of argv[0] (a path) with stdout and stderr to the file `log` (truncated), in its
/// own process group so that the terminal's Ctrl-C reaches only the launcher, which then stops
/// the children in order. Throws std::runtime_error if fork fails; a failing exec makes the
/// child exit 127 with the reason in `log`.
pid_t spawn(const std::vector<std::string>& argv, const std::string& log);

/// Starts `c` with `argv` (spawn into c.log) and records its pid.
void start(ChildProcess& c, const std::vector<std::string>& argv);

/// Starts `c` again after it exited (c.exited): its log so far is kept as LOG.N (N = the
/// restart's number, from 1), the exit code goes to c.deaths, c.restarts grows by one and the
/// new process writes a fresh c.log. CPU figures start again from 0 (cpu_s() is the new
/// process's), rss_kb_max keeps the maximum over all runs. Throws std::logic_error if `c` has not
/// exited, std::runtime_error if fork fails.
void restart(ChildProcess& c, const std::vector<std::string>& argv);

/// Collects the exit status if `c` has exited; never blocks. No-op if not started or reaped.
void reap(ChildProcess& c);

/// SIGINT to every started child still running, then up to `grace` (for all together) for a
/// clean exit (the programs save on SIGINT), then SIGKILL (exit_code 128 + 9). Children not
/// started are skipped (never kill(-1 or 0, ...)). On return every started child is reaped.
void stop_all(std::vector<ChildProcess*> children, std::chrono::seconds grace);

/// Reaps `c`, then reads its CPU ticks and RSS from /proc/<pid>/stat and /status: cpu_percent
/// over the last `dt_s` seconds (0 when dt_s is 0 or there was no earlier sample), rss_kb and
/// rss_kb_max. An exited child gets cpu_percent 0 and keeps its last figures.
void sample(ChildProcess& c, double dt_s);

}  // namespace esfleet::fleet
