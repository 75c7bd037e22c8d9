#include "leader_options.hpp"

#include <cctype>
#include <cmath>
#include <map>
#include <set>
#include <stdexcept>

#include "app/dds_flags.hpp"
#include "app/program.hpp"
#include "app/slam_params.hpp"
#include "checkpoint.hpp"

namespace esfleet::leader {

void LeaderOptions::validate() const {
  slam.validate();
  if (!std::isfinite(reader.no_return_range) || !(reader.no_return_range > 0.0f)) {
    throw std::invalid_argument("--no-return-range must be finite and > 0");
  }
  if (!(rate >= 0.0)) throw std::invalid_argument("--rate must be >= 0");
  if (!(publish_period > 0.0)) throw std::invalid_argument("--publish-period must be > 0");
  if (!(full_period > 0.0)) throw std::invalid_argument("--full-period must be > 0");
  if (serving_map()) {
    std::string given;
    for (const auto& [flag, set] : {std::pair{"--log", !log.empty()},
                                    {"--scan-topic", !scan_robot.empty()},
                                    {"--ros-scan", !ros.scan_topic.empty()},
                                    {"--resume", !resume_dir.empty()},
                                    {"--offline", offline}}) {
      if (set) given += std::string(given.empty() ? "" : ", ") + flag;
    }
    if (!given.empty()) {
      throw std::invalid_argument(
          "--map serves a saved map without mapping: it excludes --log, --scan-topic, "
          "--ros-scan, --resume and --offline (given: " +
          given + ")");
    }
  }
  const int inputs =
      !log.empty() + !scan_robot.empty() + !ros.scan_topic.empty() + (serving_map() ? 1 : 0);
  if (inputs != 1) {
    throw std::invalid_argument(
        "give exactly one of --log FILE, --scan-topic ROBOT_ID, --ros-scan TOPIC and --map "
        "PATH");
  }
  if (log.empty() && offline) {
    throw std::invalid_argument(
        "--offline maps a --log only (--scan-topic and --ros-scan need DDS)");
  }
  if (ros.outputs && offline) throw std::invalid_argument("--ros needs DDS (not --offline)");
  if (accept_contributions && (offline || serving_map())) {
    throw std::invalid_argument(
        "--accept-contributions needs a mapping leader on DDS (not --offline, not --map)");
  }
  if (log.empty() && rate > 0.0) {
    throw std::invalid_argument("--rate paces a --log; scans from a topic come as sent");
  }
  if (!(idle_exit >= 0.0)) throw std::invalid_argument("--idle-exit must be >= 0");
  if (idle_exit > 0.0 && (!log.empty() || serving_map())) {
    throw std::invalid_argument("--idle-exit needs --scan-topic or --ros-scan");
  }
  if (ros.any() && !secure.empty()) {
    throw std::invalid_argument(
        "--ros and --ros-scan do not work with --secure yet (the ROS topics are not in the "
        "security permissions)");
  }
  ros.validate(robot_id);
}

std::string LeaderOptions::input_name() const {
  if (serving_map()) return "map " + map;
  if (!log.empty()) return "log " + log;
  return scan_robot.empty() ? "ros-scan " + ros.scan_topic : "scan-topic " + scan_robot;
}

void add_leader_flags(CLI::App& cli, LeaderOptions& o, app::ParamTable& params) {
  cli.add_option("--log", o.log, "CARMEN log (.log/.clf, plain or .gz)");
  cli.add_option("--scan-topic", o.scan_robot,
                 "map the scans robot ID publishes on esfleet/robots/scan (e.g. from "
                 "esfleet-replay) instead of a log");
  cli.add_option(
         "--map", o.map,
         "serve a saved map instead of mapping (no SLAM) until stopped or --linger S: PATH is a "
         "leader's checkpoint, given as the leader's --out directory OUT (holding OUT/checkpoint) "
         "or as OUT/checkpoint itself, served with its counters, its map id and a new --epoch; or "
         "a ROS map_server YAML file (PGM/PNG image) whose cell value v in 0..100 becomes "
         "hit = round(v/20), err = 5 - hit (-1 stays unknown) in cells of its resolution "
         "(docs/faults.md, 'Serving a saved map'). Tiles, summary (complete) and, with --ros, "
         "/map go out at once, then every --publish-period and --ros-map-period wall seconds. "
         "Excludes --log, --scan-topic, --ros-scan, --resume and --offline; --out gets stats.json, "
         "map.digest, map.pgm and map.yaml of the served map")
      ->type_name("PATH");
  cli.add_option("--idle-exit", o.idle_exit,
                 "--scan-topic: end the map once no scan came for S seconds after the first "
                 "(0 = only on Ctrl-C)")
      ->capture_default_str();
  cli.add_option("--out", o.out_dir, "output directory")->capture_default_str();
  cli.add_flag("--offline", o.offline, "run the log through the SLAM without DDS");
  cli.add_option("--max-scans", o.max_scans, "stop after N scans (0 = all)")->capture_default_str();
  cli.add_option("--checkpoint-every", o.checkpoint_every,
                 "write OUT/checkpoint every N scans (while serving: every N accepted "
                 "contributions) and at exit, for --resume (0 = never); a leader killed loses "
                 "at most the N - 1 scans since the last one")
      ->capture_default_str();
  cli.add_option("--resume", o.resume_dir,
                 "continue the map checkpointed in DIR/checkpoint (same map id and epoch; the SLAM "
                 "parameters are the checkpoint's, and a SLAM flag, --config or --paper given "
                 "with it must agree with them; without --log, --scan-topic or --ros-scan the "
                 "checkpoint's input; a log continues after the last checkpointed scan)");
  cli.add_flag("--paper", o.paper,
               "start from the paper's exact configuration (previous-pose prediction, no "
               "extensions) before applying --config and the flags below");
  app::add_ros_flags(cli, o.ros, true);
  auto* dds = cli.add_option_group("DDS", "Map sharing (without --offline)");
  app::add_dds_flags(*dds, o.domain, o.profile, o.secure);
  dds->add_option("--map-id", o.map_id,
                  "name of the shared map (default: map; with --resume: the checkpoint's)");
  dds->add_option("--epoch", o.epoch,
                  "map epoch (default: the start time in seconds, a new map; with --resume: "
                  "the checkpoint's)");
  dds->add_option("--robot-id", o.robot_id, "id on the pose topic")->capture_default_str();
  dds->add_option("--rate", o.rate,
                  "--log replay speed: 0 = as fast as possible, 1 = recorded speed, 2 = twice")
      ->capture_default_str();
  dds->add_option("--publish-period", o.publish_period,
                  "seconds of scan time between tile publishes (at --rate 1: wall seconds)")
      ->capture_default_str();
  dds->add_option("--linger", o.linger,
                  "after the input: keep serving the map this many seconds (< 0: until Ctrl-C)")
      ->capture_default_str();
  dds->add_option_function<std::string>(
         "--encoding",
         [&o](const std::string& v) {
           o.encoding = v == "raw"      ? TileEncoding::kRaw
                        : v == "varint" ? TileEncoding::kVarintZlib
                                        : TileEncoding::kMedZlib;
         },
         "tile payload encoding: med = predicted residuals + zlib (smallest), varint = "
         "varints + zlib, raw = 8 bytes per cell")
      ->check(CLI::IsMember({"med", "varint", "raw"}).description(""))
      ->type_name("med|varint|raw")
      ->default_str("med");
  dds->add_option("--full-every", o.full_every,
                  "send a changed tile whole every N publishes of it, as a delta against the "
                  "previous publish in between (1 = always whole)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  dds->add_option("--full-period", o.full_period,
                  "send a changed tile whole when its whole copy is S seconds of scan time old")
      ->capture_default_str();
  dds->add_flag("--accept-contributions", o.accept_contributions,
                "check the scans followers contribute with their pose (esfleet-follower "
                "--contribute) and write the accepted ones into the map, while mapping and "
                "during --linger; each robot gets its counts back on "
                "esfleet/robots/contribution_status");
  app::add_slam_params(params, &o.slam, &o.reader);
  params.bind(cli, "SLAM parameters");
}

namespace {

/// --resume: the checkpoint's input when none is given, and its parameters for every one not
/// given now (--paper, --config or a flag); a given one must agree with the checkpoint. A parameter
/// the checkpoint lacks (written by an older esfleet) keeps this run's value, one it has that this
/// version lacks is ignored; both are noted.
/// Returns the parameters it set from the checkpoint (name, value).
std::vector<std::pair<std::string, std::string>> adopt_checkpoint(LeaderOptions& o,
                                                                  app::ParamTable& params) {
  std::vector<std::pair<std::string, std::string>> adopted;
  CheckpointSettings settings;
  try {
    settings = checkpoint_settings(o.resume_dir);
  } catch (const std::runtime_error& e) {
    throw app::UsageError("--resume " + o.resume_dir + ": " + e.what());
  }
  // No input given: the checkpoint's.
  if (o.log.empty() && o.scan_robot.empty() && o.ros.scan_topic.empty()) {
    const std::string& in = settings.input;
    const auto rest = [&](const std::string& prefix) {
      return in.rfind(prefix, 0) == 0 && in.size() > prefix.size() ? in.substr(prefix.size())
                                                                   : std::string();
    };
    if (const std::string p = rest("log "); !p.empty()) {
      o.log = p;
    } else if (const std::string id = rest("scan-topic "); !id.empty()) {
      o.scan_robot = id;
    } else if (const std::string topic = rest("ros-scan "); !topic.empty()) {
      o.ros.scan_topic = topic;
    } else {
      throw app::UsageError("--resume " + o.resume_dir + ": the checkpoint's field 'input' is '" +
                            in + "'; give --log, --scan-topic or --ros-scan");
    }
  }
  const std::map<std::string, std::string>& saved = settings.parameters;
  std::set<std::string> by_paper;
  if (o.paper) {
    for (const auto& [name, value] : params.changed()) by_paper.insert(name);
  }
  std::set<std::string> known;
  std::string conflicts;
  for (const auto& [name, now] : params.values()) {
    known.insert(name);
    const auto it = saved.find(name);
    if (it == saved.end()) {
      o.resume_notes.push_back(name + " = " + now +
                               ": the checkpoint does not have it (written by an older esfleet)");
    } else if (it->second != now) {
      if (params.given(name) || by_paper.count(name) != 0) {
        conflicts += (conflicts.empty() ? "" : ", ") + name + " (checkpoint " + it->second +
                     ", given " + now + ")";
        continue;
      }
      try {
        params.set(name, it->second);
        adopted.emplace_back(name, it->second);
      } catch (const std::invalid_argument& e) {
        throw app::UsageError("--resume " + o.resume_dir + ": checkpoint parameter '" + name +
                              "': " + e.what());
      }
    }
  }
  for (const auto& [name, value] : saved) {
    if (known.count(name) == 0) {
      o.resume_notes.push_back(name + " = " + value +
                               ": the checkpoint has it but this esfleet does not; ignored");
    }
  }
  if (!conflicts.empty()) {
    throw app::UsageError("--resume " + o.resume_dir +
                          ": the SLAM parameters given differ from the checkpoint's: " + conflicts +
                          " (leave them out to continue with the checkpoint's)");
  }
  return adopted;
}

/// Whether `text` has `word` as a whole word (a parameter name, not part of a longer one or
/// of "must").
bool names_word(const std::string& text, const std::string& word) {
  auto part = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_'; };
  for (std::size_t at = text.find(word); at != std::string::npos; at = text.find(word, at + 1)) {
    const std::size_t end = at + word.size();
    if ((at == 0 || !part(text[at - 1])) && (end == text.size() || !part(text[end]))) return true;
  }
  return false;
}

}  // namespace

void finish_leader_options(LeaderOptions& o, app::ParamTable& params) {
  if (o.paper) o.slam = SlamConfig::paper();
  params.apply();
  std::vector<std::pair<std::string, std::string>> adopted;
  if (!o.resume_dir.empty() && !o.serving_map()) adopted = adopt_checkpoint(o, params);
  o.parameters = params.values();
  o.parameter_changes = params.describe_changes();
  try {
    o.validate();
  } catch (const std::invalid_argument& e) {
    // A value the checkpoint gave (a hand-edited manifest): say where it came from.
    const std::string what = e.what();
    for (const auto& [name, value] : adopted) {
      if (names_word(what, name)) {
        throw app::UsageError("--resume " + o.resume_dir + ": checkpoint parameter '" + name +
                              "' = " + value + ": " + what);
      }
    }
    throw;
  }
}

}  // namespace esfleet::leader
