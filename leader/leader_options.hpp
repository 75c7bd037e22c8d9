#pragma once
// esfleet-leader's options: what to map (a log or a robot's scan topic) or which saved map to
// serve (--map), where the results go, how the map is shared over DDS, checkpoints, and the SLAM
// parameters.

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

#include "app/param_table.hpp"
#include "app/ros_options.hpp"
#include "esfleet/core/carmen_reader.hpp"
#include "esfleet/core/slam.hpp"
#include "esfleet/core/tile_codec.hpp"

namespace esfleet::leader {

struct LeaderOptions {
  // --- input: exactly one of log, scan_robot, ros.scan_topic and map ---
  std::string log;  ///< CARMEN log (.log/.clf, plain or .gz)
  /// Serve this saved map without SLAM (a checkpoint directory or a ROS map YAML file).
  std::string map;
  std::string scan_robot;     ///< map the scans this robot publishes on the scan topic
  double idle_exit = 0.0;     ///< scan topic: end once no scan came for this long (s); 0 = never
  std::size_t max_scans = 0;  ///< stop after this many scans; 0 = all
  double rate = 0.0;          ///< log replay speed: 0 = as fast as possible, 1 = recorded speed

  // --- outputs and checkpoints ---
  std::string out_dir = "out";
  std::size_t checkpoint_every = 50;  ///< scans between checkpoints; 0 = none
  std::string resume_dir;             ///< continue the map checkpointed here

  // --- map sharing (off with offline) ---
  bool offline = false;  ///< run a log through the SLAM without DDS
  int domain = 0;
  std::string profile;                 ///< Fast DDS XML profile; empty = Fast DDS defaults
  std::string secure;                  ///< DDS Security directory (docs/security.md); empty = off
  std::optional<std::string> map_id;   ///< name of the shared map; default "map" (or resumed)
  std::optional<std::uint32_t> epoch;  ///< map epoch; default the start time (or resumed)
  std::string robot_id = "leader";     ///< id on the pose topic
  double publish_period = 1.0;         ///< seconds of scan time between publishes
  double linger = -1.0;  ///< seconds to keep serving after the input; < 0 = until stopped
  TileEncoding encoding = TileEncoding::kMedZlib;
  std::uint64_t full_every = 60;  ///< a changed tile goes whole every this many publishes of it
  double full_period = 60.0;      ///< ... and when its whole copy is this old (s of scan time)
  /// Check the scans followers contribute (esfleet-follower --contribute) and write the
  /// accepted ones into the map, while mapping and while lingering (contribution_intake.hpp).
  bool accept_contributions = false;

  // --- ROS 2 (docs/ros2.md) ---
  app::RosOptions ros;
  // --- SLAM ---
  bool paper = false;  ///< start from the paper's exact configuration
  SlamConfig slam;
  CarmenReaderOptions reader;
  /// Every parameter's name and value as the run uses it (stats.json, checkpoints, the map
  /// summary); filled by finish_leader_options.
  std::vector<std::pair<std::string, std::string>> parameters;
  /// The parameters not at their defaults, for the log ("all defaults" or "2 changed: ...").
  std::string parameter_changes;
  /// --resume: what could not be taken from the checkpoint as it is (a parameter it lacks or
  /// one this version does not know), one line each, for the log.
  std::vector<std::string> resume_notes;

  /// Throws std::invalid_argument naming the flag.
  void validate() const;
  /// --map: serving a saved map, no SLAM.
  bool serving_map() const { return !map.empty(); }
  /// "log PATH", "scan-topic ROBOT_ID" or "ros-scan TOPIC": what the map was made from
  /// (checkpoints).
  std::string input_name() const;
};

/// Registers every flag on `cli`, bound to `o` and, for the SLAM parameters, to `params` (both
/// must outlive the parse).
void add_leader_flags(CLI::App& cli, LeaderOptions& o, app::ParamTable& params);

/// After parsing: applies --paper, then the parameter file and flags (`params`); with --resume
/// every parameter not given by --paper, the file or a flag takes the checkpoint's value, and a
/// given one that differs from it is a UsageError naming it. Records the parameters and
/// validates. Throws std::invalid_argument (or std::runtime_error from the parameter file or
/// the checkpoint's manifest) naming the flag, file or line.
void finish_leader_options(LeaderOptions& o, app::ParamTable& params);

}  // namespace esfleet::leader
