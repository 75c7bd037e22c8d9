#include "replay_options.hpp"

#include "app/dds_flags.hpp"
#include "app/program.hpp"
#include "esfleet/dds/topics.hpp"

namespace esfleet::sim {

using app::UsageError;

void ReplayOptions::validate() const {
  if (robot_id.empty()) throw UsageError("--robot-id must not be empty");
  if (robot_id.size() > 64) throw UsageError("--robot-id: at most 64 characters");
  if (!(rate >= 0.0) || rate > 1e6) throw UsageError("--rate must be in [0, 1e6]");
  if (domain < 0 || domain > dds::kMaxDomain) throw UsageError("--domain must be in [0, 232]");
  if (wait_subscribers < 0) throw UsageError("--wait-subscribers must be >= 0");
  if (!(wait_timeout >= 0.0)) throw UsageError("--wait-timeout must be >= 0");
}

void add_replay_flags(CLI::App& cli, ReplayOptions& o) {
  cli.add_option("--log", o.log, "CARMEN log to publish")->required();
  cli.add_option("--robot-id", o.robot_id, "robot id the scans are published under")->required();
  cli.add_option("--rate", o.rate,
                 "speed: 1 = as recorded, 2 = twice as fast, 0 = as fast as the readers "
                 "acknowledge")
      ->capture_default_str();
  app::add_dds_flags(cli, o.domain, o.profile, o.secure);
  cli.add_option("--first-scan", o.first_scan,
                 "start at this scan of the log (counted from 0, before --max-scans applies)")
      ->capture_default_str();
  cli.add_option("--max-scans", o.max_scans, "publish only the first N scans (0 = all)")
      ->capture_default_str();
  cli.add_option("--wait-subscribers", o.wait_subscribers,
                 "before the first scan, wait until N scan readers are matched (0 = start at "
                 "once)")
      ->capture_default_str();
  cli.add_option("--wait-timeout", o.wait_timeout,
                 "wait at most S seconds for them, then start anyway")
      ->capture_default_str();
  // on|off on the command line, a bool in the options.
  cli.add_option_function<std::string>(
         "--odometry", [&o](const std::string& v) { o.odometry = v == "on"; },
         "send the log's odometry with each scan")
      ->check(CLI::IsMember({"on", "off"}))
      ->default_str(o.odometry ? "on" : "off");
}

}  // namespace esfleet::sim
