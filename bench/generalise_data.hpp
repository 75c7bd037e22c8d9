#pragma once
// The pieces of esfleet-bench generalise that do not run the SLAM: which scans a subsampled run
// keeps, the key-scan log's true stamps, what the SLAM is given (laser only or noisy odometry,
// never a reference pose) and how a run is scored against the relations and the reference poses.
//
// A GeneraliseLog keeps apart what the SLAM may see (the scans' ranges and stamps) from what only
// evaluation reads (reference poses, relations). Its scans' odometry fields hold the source of
// the noisy odometry (corrected poses, or CSAIL's raw odometry): slam_input() clears or replaces
// them, and it is the only way a run gets its scans.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "esfleet/core/carmen_reader.hpp"
#include "esfleet/core/laser_scan.hpp"
#include "esfleet/core/odometry_noise.hpp"
#include "esfleet/core/relations.hpp"

namespace esfleet::bench {

/// How the SLAM gets motion information in a run.
enum class GeneraliseMode {
  kLaserOnly,      ///< tracking.use_odometry off, no odometry in the scans
  kNoisyOdometry,  ///< tracking.use_odometry on, noisy_odometry() of the kept scans' odometry
};
/// "laser" or "odom" (the --modes names).
const char* mode_name(GeneraliseMode mode);

/// Seeds from "1-5", "1,2,3" or a mix ("1-3,7"), in the order given, without repeats. Throws
/// std::invalid_argument naming the bad part (empty, not a number, a range whose end is before
/// its start).
std::vector<std::uint64_t> parse_seed_list(const std::string& text);

/// Indices 0, k, 2k, ... below n: every k-th scan from the first; at most `max_count` of them
/// when it is > 0. Throws std::invalid_argument if k is 0.
std::vector<std::size_t> subsample_indices(std::size_t n, std::size_t k, std::size_t max_count = 0);

/// For each scan of a key-scan log (`keys`), the index of the scan of the raw log (`raw`) it was
/// taken from: the one raw scan whose range list is identical (bit for bit, the same beam
/// count). The matches must be strictly increasing, and a key scan's own stamp must agree with
/// the raw stamp to the 6 significant digits it is printed with (|difference| <= 5e-6 of the
/// stamp). Throws std::runtime_error naming `keys_name`, the key scan (0-based) and what failed:
/// no identical raw scan, more than one, out of order, or a stamp that disagrees.
std::vector<std::size_t> match_key_scans(const std::vector<LaserScan>& keys,
                                         const std::vector<LaserScan>& raw,
                                         const std::string& keys_name, const std::string& raw_name);

/// One log of the benchmark, read and matched, ready to be subsampled.
struct GeneraliseLog {
  std::string name;  ///< csail-keys, csail, fr079
  std::string path;  ///< the log the scans come from
  /// The log's scans in order, with true stamps (the key-scan log: the raw scans' stamps). The
  /// odometry field is the source of the noisy odometry, not for the SLAM (see slam_input).
  std::vector<LaserScan> scans;
  /// Per scan: its ground-truth pose where the log has one (evaluation only).
  std::vector<std::optional<Pose2>> reference;
  /// Per scan: its index in the log the relations were matched against (the raw log for the
  /// key-scan log, the log itself otherwise).
  std::vector<std::size_t> match_index;
  std::vector<Relation> relations;
  /// Per relation: the scans of the matched log its ends fall on (match_relation_ends).
  std::vector<std::optional<RelationEnds>> relation_ends;
  RelationsOptions relation_options;  ///< time offset (fr079: 1211.45) and tolerance
};

/// The key-scan log: `keys` (as read, corrected poses in the odometry field) matched to `raw`
/// (match_key_scans); stamps become the raw stamps, the reference is the key scans' poses, and
/// the relations are matched against the raw log's stamps.
GeneraliseLog make_key_scan_log(std::vector<LaserScan> keys, const std::vector<LaserScan>& raw,
                                std::vector<Relation> relations, const std::string& keys_name,
                                const std::string& raw_name);
/// The raw CSAIL log: reference poses only on the scans that are key scans (`key_raw_index`, the
/// result of match_key_scans; those scans take the key scans' poses `key_poses`).
GeneraliseLog make_raw_log_with_keys(std::vector<LaserScan> raw,
                                     const std::vector<std::size_t>& key_raw_index,
                                     const std::vector<Pose2>& key_poses,
                                     std::vector<Relation> relations, const std::string& raw_name);
/// A GMapping-corrected log (fr079): every scan's odometry field is its reference pose.
/// Throws std::runtime_error naming the scan if one has no odometry field.
GeneraliseLog make_corrected_log(std::vector<LaserScan> scans, std::vector<Relation> relations,
                                 double time_offset, const std::string& name,
                                 const std::string& path);

/// The scans a run gives the SLAM: log.scans at `kept`, in order. Laser only: no odometry.
/// Noisy odometry: noisy_odometry() of the kept scans' odometry fields, seeded with `seed`.
/// Throws std::runtime_error naming the scan if noisy odometry is asked and one has none.
std::vector<LaserScan> slam_input(const GeneraliseLog& log, const std::vector<std::size_t>& kept,
                                  GeneraliseMode mode, const OdometryNoise& noise,
                                  std::uint64_t seed);

/// `scan` with only every `step`-th beam from the first (step 2 turns a 0.5 deg laser into a
/// 1 deg one, as many logs have); step <= 1 returns it unchanged.
LaserScan keep_every_beam(LaserScan scan, std::size_t step);

/// The relations of the log whose both ends are kept scans, scored against the run's trajectory.
struct KeptRelations {
  std::size_t used = 0;   ///< relations with both ends on kept scans
  std::size_t total = 0;  ///< relations in the file
  RelationsResult result;
};

/// Scores `estimate` (one pose per kept scan, in the order of `kept`) on the relations whose both
/// ends are kept scans. Throws std::invalid_argument if the sizes differ.
KeptRelations score_kept_relations(const GeneraliseLog& log, const std::vector<std::size_t>& kept,
                                   const std::vector<Pose2>& estimate);

/// Scores `estimate` (one pose per kept scan) on relations derived from the reference poses of the
/// kept scans that have one, gaps counted in those scans. reference_scans says how many.
struct KeptDerived {
  std::size_t reference_scans = 0;
  DerivedRelationsResult result;
};
KeptDerived score_kept_derived(const GeneraliseLog& log, const std::vector<std::size_t>& kept,
                               const std::vector<Pose2>& estimate,
                               const std::vector<std::size_t>& gaps);

/// The floor of that score: how a run on every scan scores on the same derived relations. The
/// reference is GMapping's path, not the truth, so the derived score of a run that kept `kept`
/// scans of `log` cannot rank accuracy below what the poses of a run on the whole log score
/// there. `dense` holds one pose per scan of the log `log.match_index` points into (the log
/// itself, or the raw log a key-scan log was taken from), from the first; the poses at the kept
/// scans are scored as score_kept_derived scores a run. nullopt if a kept scan's index is past
/// the end of `dense` (a run capped by --max-scans).
std::optional<KeptDerived> score_derived_floor(const GeneraliseLog& log,
                                               const std::vector<std::size_t>& kept,
                                               const std::vector<Pose2>& dense,
                                               const std::vector<std::size_t>& gaps);

}  // namespace esfleet::bench
