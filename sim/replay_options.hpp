#pragma once
// esfleet-replay's command line: what to publish and how fast (ReplayOptions), its checks
// (validate) and the flags that set it (add_replay_flags), apart from main() so that a test can
// parse an argv into it.

#include <CLI/CLI.hpp>
#include <cstddef>
#include <string>

namespace esfleet::sim {

struct ReplayOptions {
  std::string log;             ///< CARMEN log to publish (required)
  std::string robot_id;        ///< key of the scans on the topic (required), at most 64 chars
  double rate = 1.0;           ///< 1 = recorded speed, 2 = twice as fast, 0 = as fast as possible
  int domain = 0;              ///< DDS domain id
  std::string profile;         ///< Fast DDS XML profile; empty = Fast DDS defaults
  std::string secure;          ///< DDS Security directory (docs/security.md); empty = off
  std::size_t max_scans = 0;   ///< publish only the first N scans; 0 = all
  std::size_t first_scan = 0;  ///< skip the scans before this one
  int wait_subscribers = 1;    ///< before the first scan, wait for this many scan readers
  double wait_timeout = 30.0;  ///< ... at most this many seconds (then start anyway)
  bool odometry = true;        ///< send the log's odometry with each scan (--odometry on|off)

  /// Throws app::UsageError naming the flag. (Whether --first-scan lies inside the log is
  /// known only once it is read: ReplayApp checks that.)
  void validate() const;
};

/// Registers esfleet-replay's flags on `cli`, bound to `o` (its values are the defaults shown).
void add_replay_flags(CLI::App& cli, ReplayOptions& o);

}  // namespace esfleet::sim
