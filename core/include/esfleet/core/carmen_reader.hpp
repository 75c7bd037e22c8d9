#pragma once
// Reader for CARMEN text logs (.log / .clf, plain or gzip-compressed): turns FLASER and
// ROBOTLASER1 lines into LaserScans, one at a time, and rejects a broken line with its file and
// line number instead of skipping it or guessing.
//
// Line formats (whitespace-separated; "host" is any token, every other field a number):
//   FLASER n r_1 .. r_n x y theta odom_x odom_y odom_theta ipc_timestamp host logger_timestamp
//   ROBOTLASER1 laser_type start_angle field_of_view angular_resolution maximum_range accuracy
//       remission_mode n r_1 .. r_n m rem_1 .. rem_m laser_pose_x laser_pose_y laser_pose_theta
//       robot_pose_x robot_pose_y robot_pose_theta laser_tv laser_rv forward_safety_dist
//       side_safety_dist turn_axis ipc_timestamp host logger_timestamp
//   ODOM x y theta tv rv accel ipc_timestamp host logger_timestamp
//   PARAM name value ipc_timestamp host logger_timestamp   (a value may hold spaces; also
//       without the ipc timestamp or without time fields: PARAM is metadata, and a PARAM line
//       without a value is skipped and counted, never an error)
//   NEFF value ...                                          (GMapping-corrected logs only)
// Blank lines and lines whose first non-blank character is '#' are comments. A line whose first
// token is any other message name (letters, digits, '_' and '-', starting with a letter, e.g.
// RLASER, RAWLASER1, TRUEPOS, SYNC) is skipped and counted; a line that does not start with a
// message name (e.g. the second half of a broken line) is an error.
//
// Validation: each known line must have exactly its format's field count; every numeric field
// must parse completely (no trailing characters) and be finite (remissions, which are not used,
// need only be numbers); ranges must be >= 0; a beam count must lie in [1, 10000] (FLASER: in
// [4, 10000], since its beams span 180° and fewer than 4 are more than 1 rad apart, more than
// the scan message accepts); a ROBOTLASER1 start_angle must lie in [-2pi, 2pi] and its
// angular_resolution in 1e-6 .. 1 rad in magnitude (so the scan's float angles are finite and
// non-zero, and the scan fits the scan message). Readings at or above the
// no-return range (81.91 in the logs) are valid and kept unchanged; LaserScan::is_no_return finds
// them. Messages name the bad field and its position, counting the first token after the message
// name as field 1, e.g. "log.clf:12: FLASER range[17] (field 19) is NaN".

#include <atomic>
#include <cstddef>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "esfleet/core/laser_scan.hpp"

namespace esfleet {

/// Beam angles of a FLASER line with an even beam count (FLASER carries no angles; its n beams
/// cover the 180° front field of view). Odd counts (361) are unambiguous: beam j is at
/// -90° + j·180°/(n−1), so there is a beam at 0°.
enum class EvenBeamConvention {
  kStartAtMinus90,  ///< beam j at -90° + j·180°/n  (n even: 360 beams -> -90° .. +89.5°)
  kCentered,        ///< beam j at -90° + (j+0.5)·180°/n (no beam at 0°, as GMapping reads it)
};

struct CarmenReaderOptions {
  /// Angles of FLASER scans with an even beam count (fr079: 360 beams).
  EvenBeamConvention even_beams = EvenBeamConvention::kStartAtMinus90;
  /// FLASER readings at or above this (m) are no-return readings; becomes LaserScan::max_range
  /// (for ROBOTLASER1: the smaller of this and the line's maximum_range). Must be finite and > 0.
  float no_return_range = 81.9f;
};

/// How many line numbers of skipped PARAM lines a CarmenReader keeps.
inline constexpr std::size_t kMaxBadParamLines = 10;

/// Error in a log. what() is "<file>:<line>: <what>", or "<file>: <what>" when no line applies
/// (line() == 0), e.g. "<file>: cannot open: <reason>".
class LogError : public std::runtime_error {
 public:
  LogError(std::string file, std::size_t line, const std::string& what);
  const std::string& file() const { return file_; }
  /// 1-based line number, 0 if the error concerns the file as a whole.
  std::size_t line() const { return line_; }

 private:
  std::string file_;
  std::size_t line_;
};

/// Streams the laser scans of one CARMEN log. Opens with zlib, so gzip-compressed and plain
/// files read alike; a truncated or corrupt gzip stream is a LogError when reading reaches it.
/// Lines may be of any length up to 1 MiB (a longer line is an error). Non-copyable, movable;
/// a moved-from reader may only be destroyed or assigned to.
class CarmenReader {
 public:
  /// Opens `path`. Throws LogError "<path>: cannot open: <reason>" if it cannot be opened and
  /// std::invalid_argument if options.no_return_range is not finite and > 0.
  explicit CarmenReader(const std::string& path, CarmenReaderOptions options = {});
  /// A reader over log text already in memory (plain text, not gzip), e.g. received over the
  /// network or fed by a fuzzer: parses exactly as from a file, never touches the filesystem.
  /// `name` stands for the file in LogError messages. Throws std::invalid_argument as above.
  static CarmenReader from_text(std::string text, std::string name = "<text>",
                                CarmenReaderOptions options = {});
  ~CarmenReader();
  CarmenReader(const CarmenReader&) = delete;
  CarmenReader& operator=(const CarmenReader&) = delete;
  CarmenReader(CarmenReader&&) noexcept;
  CarmenReader& operator=(CarmenReader&&) noexcept;

  /// Next laser scan (FLASER or ROBOTLASER1), or std::nullopt at the end of the file; other
  /// lines on the way are validated and recorded (PARAM, ODOM, NEFF) or skipped (unknown
  /// types, comments). Throws LogError naming file and 1-based line on a malformed line, and
  /// naming the line being read when the file cannot be read further (corrupt/truncated .gz).
  ///
  /// FLASER: stamp = ipc_timestamp; angle_min = -90°; increment 180°/(n−1) for odd n, else
  /// per options.even_beams; max_range = options.no_return_range; odometry = (odom_x, odom_y,
  /// odom_theta). The x y theta fields are checked but not used (corrected poses in corrected
  /// logs). ROBOTLASER1: angle_min = start_angle, angle_increment = angular_resolution,
  /// max_range = min(maximum_range, no_return_range), odometry = robot pose fields.
  std::optional<LaserScan> next_scan();

  /// The file being read, or the name given to from_text: what LogErrors name.
  const std::string& name() const;
  /// PARAM lines seen so far: name -> value (a later line for the same name wins).
  const std::map<std::string, std::string>& params() const;
  /// PARAM lines skipped because they hold no value, so far, and the line numbers of the first
  /// kMaxBadParamLines of them (for a warning).
  std::size_t bad_param_count() const;
  const std::vector<std::size_t>& bad_param_lines() const;
  /// Last line read (1-based); 0 before the first.
  std::size_t line_number() const;
  /// Lines of unknown message types skipped so far (comments and blank lines not counted).
  std::size_t skipped_lines() const;
  /// ODOM lines seen so far (each parsed and validated).
  std::size_t odom_messages() const;
  /// True once a NEFF line was seen: a GMapping-corrected log, whose pose fields and ODOM lines
  /// are corrected poses rather than odometry (run such logs laser-only).
  bool saw_corrected_poses() const;

 private:
  struct Impl;
  explicit CarmenReader(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// Reads the rest of `reader`'s laser scans in file order: only the first `max_scans` if > 0,
/// and none after the scan at which `*stop` (if given; e.g. a program's signal flag) is found
/// set. The one loop behind reading a whole log. Throws LogError as next_scan does, and
/// "<reader.name()>: no laser scans (FLASER/ROBOTLASER1) in file" if it read none.
std::vector<LaserScan> read_scans(CarmenReader& reader, std::size_t max_scans = 0,
                                  const std::atomic<bool>* stop = nullptr);

/// read_scans over the log `path` from its start: all its laser scans in file order (only the
/// first `max_scans` if > 0, fewer if `*stop` is set while reading). Throws LogError as
/// CarmenReader does, and "<path>: no laser scans (FLASER/ROBOTLASER1) in file" if the file
/// holds none (an empty file included).
std::vector<LaserScan> read_carmen_log(const std::string& path, CarmenReaderOptions options = {},
                                       std::size_t max_scans = 0,
                                       const std::atomic<bool>* stop = nullptr);

/// read_carmen_log over log text in memory (CarmenReader::from_text); `name` stands for the file
/// in messages.
std::vector<LaserScan> read_carmen_text(std::string text, const std::string& name = "<text>",
                                        CarmenReaderOptions options = {},
                                        std::size_t max_scans = 0);

}  // namespace esfleet
