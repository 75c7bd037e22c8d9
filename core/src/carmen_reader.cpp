#include "esfleet/core/carmen_reader.hpp"

#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <iterator>
#include <numbers>
#include <string_view>
#include <system_error>
#include <utility>

#include "line_fields.hpp"

namespace esfleet {
namespace {

constexpr std::size_t kMaxLineBytes = std::size_t{1} << 20;  // 1 MiB
constexpr unsigned kReadChunk = 256u * 1024u;                // bytes per gzread
constexpr long long kMaxBeams = 10000;
constexpr std::size_t kTimeFields = 3;  // ipc_timestamp host logger_timestamp
// ROBOTLASER1 angle limits: a scan must fit the scan message (scan_from_msg: |angle_min| <= 7,
// |angle_increment| <= 1) and its angles must be finite, non-degenerate floats.
constexpr double kMaxStartAngle = 2.0 * std::numbers::pi;
constexpr double kMinResolution = 1e-6;
constexpr double kMaxResolution = 1.0;
// FLASER beams are spread over 180°, so fewer than 4 are more than 1 rad apart
// (kMaxResolution): 3 beams are pi/2 apart, a scan the message refuses.
constexpr long long kMinFlaserBeams = 4;

// A CARMEN message name: a letter, then letters, digits, '_' or '-'.
bool is_message_name(std::string_view s) {
  auto alpha = [](char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z'); };
  if (s.empty() || !alpha(s[0])) return false;
  for (char c : s) {
    if (!alpha(c) && !(c >= '0' && c <= '9') && c != '_' && c != '-') return false;
  }
  return true;
}

// The token as it appears in a message: quoted, shortened if long, control bytes escaped.
std::string quote(std::string_view s) {
  constexpr std::size_t kMax = 32;
  std::string out = "\"";
  for (std::size_t i = 0; i < s.size() && i < kMax; ++i) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c < 0x20 || c == 0x7f) {
      constexpr char kHex[] = "0123456789abcdef";
      out += "\\x";
      out += kHex[c >> 4];
      out += kHex[c & 0xf];
    } else {
      out += static_cast<char>(c);
    }
  }
  if (s.size() > kMax) out += "...";
  return out + "\"";
}

// from_chars takes no leading '+', which strtod-style writers may emit, so one is skipped.
std::string_view without_plus(std::string_view s) {
  if (s.size() > 1 && s[0] == '+' && s[1] != '-') s.remove_prefix(1);
  return s;
}

// Parses a whole token as a number; false on anything else (trailing characters included).
template <typename T>
bool parse_number(std::string_view s, T& value) {
  return detail::parse_number(without_plus(s), value).ok();
}

// Why parse_number<T> rejected `s`, for an error message.
template <typename T>
std::string parse_problem(std::string_view s, std::string_view kind) {
  T value{};
  s = without_plus(s);
  const detail::NumberParse p = detail::parse_number(s, value);
  if (p.ec == std::errc::result_out_of_range && p.whole) {
    return "is out of range for its type: " + quote(s);
  }
  return "is not " + std::string(kind) + ": " + quote(s);
}

}  // namespace

LogError::LogError(std::string file, std::size_t line, const std::string& what)
    : std::runtime_error(detail::line_message(file, line, what)),
      file_(std::move(file)),
      line_(line) {}

struct CarmenReader::Impl {
  std::string path;
  CarmenReaderOptions options;
  gzFile file = nullptr;

  // Decompressed bytes: [begin, buffer.size()) not yet consumed; `scanned` bytes from begin
  // are known to hold no '\n' (so a long line is searched once, not once per chunk).
  std::string buffer;
  std::size_t begin = 0;
  std::size_t scanned = 0;
  bool at_eof = false;

  std::vector<std::string_view> tokens;
  std::map<std::string, std::string> params;
  std::size_t line_number = 0;
  std::size_t skipped_lines = 0;
  std::size_t bad_params = 0;
  std::vector<std::size_t> bad_param_lines;  ///< the first kMaxBadParamLines
  std::size_t odom_messages = 0;
  bool saw_corrected_poses = false;

  ~Impl() {
    if (file != nullptr) gzclose(file);
  }

  [[noreturn]] void fail(const std::string& what) const { throw LogError(path, line_number, what); }

  // Throws if zlib recorded an error (corrupt data, truncated stream, read error).
  void check_stream() {
    int errnum = Z_OK;
    const char* message = gzerror(file, &errnum);
    if (errnum == Z_OK) return;
    const std::size_t line = line_number + 1;  // the line being read when the stream failed
    if (errnum == Z_ERRNO) {
      throw LogError(path, line, "read error: " + std::generic_category().message(errno));
    }
    // zlib prefixes its message with the path; the LogError names the path already.
    std::string_view detail = message != nullptr ? message : "unknown error";
    if (const std::string prefix = path + ": "; detail.starts_with(prefix)) {
      detail.remove_prefix(prefix.size());
    }
    throw LogError(path, line,
                   "gzip stream is truncated or corrupt (zlib: " + std::string(detail) + ")");
  }

  // Next line without its '\n'; false at the end of the file.
  bool read_line(std::string_view& line) {
    for (;;) {
      const std::size_t available = buffer.size() - begin;
      const char* start = buffer.data() + begin;
      if (const void* newline = std::memchr(start + scanned, '\n', available - scanned)) {
        const auto length = static_cast<std::size_t>(static_cast<const char*>(newline) - start);
        if (length > kMaxLineBytes) break;
        line = std::string_view(start, length);
        begin += length + 1;
        scanned = 0;
        ++line_number;
        return true;
      }
      scanned = available;
      if (available > kMaxLineBytes) break;
      if (at_eof) {
        if (available == 0) return false;
        line = std::string_view(start, available);  // last line has no '\n'
        begin = buffer.size();
        scanned = 0;
        ++line_number;
        return true;
      }
      buffer.erase(0, begin);
      begin = 0;
      const std::size_t kept = buffer.size();
      buffer.resize(kept + kReadChunk);
      const int n = gzread(file, buffer.data() + kept, kReadChunk);
      buffer.resize(kept + static_cast<std::size_t>(n > 0 ? n : 0));
      if (n <= 0) {
        check_stream();  // truncated .gz: zlib reports Z_BUF_ERROR at the end of the input
        at_eof = true;
      }
    }
    throw LogError(path, line_number + 1,
                   "line is longer than " + std::to_string(kMaxLineBytes) + " bytes");
  }

  // --- field access; `index` is the token index (0 = message name) ---

  void expect_field_count(std::string_view type, std::size_t expected) const {
    if (tokens.size() == expected) return;
    fail(std::string(type) + " line has " + std::to_string(tokens.size() - 1) +
         " fields after the message name, expected " + std::to_string(expected - 1) +
         (tokens.size() < expected ? " (truncated line?)" : " (extra fields)"));
  }

  [[noreturn]] void fail_field(std::string_view type, std::string_view name, std::size_t index,
                               const std::string& problem) const {
    fail(std::string(type) + " " + std::string(name) + " (field " + std::to_string(index) + ") " +
         problem);
  }

  double number(std::string_view type, std::string_view name, std::size_t index) const {
    double value = 0.0;
    if (!parse_number(tokens[index], value)) {
      fail_field(type, name, index, parse_problem<double>(tokens[index], "a number"));
    }
    if (!std::isfinite(value))
      fail_field(type, name, index, "is not finite: " + quote(tokens[index]));
    return value;
  }

  long long count(std::string_view type, std::string_view name, std::size_t index,
                  long long min) const {
    long long value = 0;
    if (!parse_number(tokens[index], value)) {
      fail_field(type, name, index, parse_problem<long long>(tokens[index], "an integer"));
    }
    if (value < min || value > kMaxBeams) {
      fail_field(type, name, index,
                 "is " + std::to_string(value) + ", outside [" + std::to_string(min) + ", " +
                     std::to_string(kMaxBeams) + "]");
    }
    return value;
  }

  // n ranges starting at token `first`: finite and >= 0.
  std::vector<float> ranges(std::string_view type, std::size_t first, std::size_t n) const {
    std::vector<float> out(n);
    for (std::size_t j = 0; j < n; ++j) {
      const std::size_t index = first + j;
      float& r = out[j];
      if (!parse_number(tokens[index], r) || !(r >= 0.0f) || std::isinf(r)) {
        const std::string name = "range[" + std::to_string(j) + "]";
        if (!parse_number(tokens[index], r)) {
          fail_field(type, name, index, parse_problem<float>(tokens[index], "a number"));
        }
        if (std::isnan(r)) fail_field(type, name, index, "is NaN");
        if (std::isinf(r)) fail_field(type, name, index, "is infinite: " + quote(tokens[index]));
        fail_field(type, name, index, "is negative: " + quote(tokens[index]));
      }
    }
    return out;
  }

  // ipc_timestamp host logger_timestamp at the end of the line; returns ipc_timestamp.
  double timestamps(std::string_view type) const {
    const std::size_t n = tokens.size();
    number(type, "logger_timestamp", n - 1);
    return number(type, "ipc_timestamp", n - 3);
  }

  // --- messages ---

  LaserScan parse_flaser() {
    constexpr std::string_view kType = "FLASER";
    if (tokens.size() < 2) fail("FLASER line ends before its beam count");
    const auto n = static_cast<std::size_t>(count(kType, "beam count", 1, kMinFlaserBeams));
    const std::size_t expected = 2 + n + 6 + kTimeFields;
    if (tokens.size() != expected) {
      fail("FLASER declares " + std::to_string(n) + " beams, so " + std::to_string(expected - 2) +
           " fields must follow the beam count (" + std::to_string(n) +
           " ranges, 6 pose, 3 time), but the line has " + std::to_string(tokens.size() - 2) +
           (tokens.size() < expected ? " (truncated line?)" : " (extra fields)"));
    }
    LaserScan scan;
    scan.ranges = ranges(kType, 2, n);
    const std::size_t p = 2 + n;
    number(kType, "x", p);  // corrected pose in corrected logs: checked, never used
    number(kType, "y", p + 1);
    number(kType, "theta", p + 2);
    scan.odometry = Pose2{number(kType, "odom_x", p + 3), number(kType, "odom_y", p + 4),
                          number(kType, "odom_theta", p + 5)};
    scan.stamp = timestamps(kType);
    const double beams = static_cast<double>(n);
    double angle_min = -std::numbers::pi / 2.0;
    double increment = std::numbers::pi / beams;
    if (n % 2 == 1) {
      increment = std::numbers::pi / (beams - 1.0);
    } else if (options.even_beams == EvenBeamConvention::kCentered) {
      angle_min += 0.5 * increment;
    }
    scan.angle_min = static_cast<float>(angle_min);
    scan.angle_increment = static_cast<float>(increment);
    scan.max_range = options.no_return_range;
    return scan;
  }

  LaserScan parse_robotlaser1() {
    constexpr std::string_view kType = "ROBOTLASER1";
    constexpr std::size_t kHeader = 9;  // name, 7 laser config fields, num_readings
    constexpr std::size_t kTail = 6 + 5 + kTimeFields;
    if (tokens.size() < kHeader) fail("ROBOTLASER1 line ends before its beam count");
    const auto n = static_cast<std::size_t>(count(kType, "num_readings", 8, 1));
    const std::size_t remissions_at = kHeader + n;
    if (tokens.size() <= remissions_at) {
      fail("ROBOTLASER1 declares " + std::to_string(n) + " readings but the line ends after " +
           std::to_string(tokens.size() - kHeader) + " of them (truncated line?)");
    }
    const auto m = static_cast<std::size_t>(count(kType, "num_remissions", remissions_at, 0));
    expect_field_count(kType, remissions_at + 1 + m + kTail);

    LaserScan scan;
    number(kType, "laser_type", 1);
    const double start_angle = number(kType, "start_angle", 2);
    if (std::abs(start_angle) > kMaxStartAngle) {
      fail_field(kType, "start_angle", 2, "is outside [-2pi, 2pi]: " + quote(tokens[2]));
    }
    number(kType, "field_of_view", 3);
    const double resolution = number(kType, "angular_resolution", 4);
    if (resolution == 0.0) fail_field(kType, "angular_resolution", 4, "is zero");
    // Also catches a resolution that is zero as a float (1e-300) or would overflow it (1e300).
    if (!(std::abs(resolution) >= kMinResolution && std::abs(resolution) <= kMaxResolution)) {
      fail_field(kType, "angular_resolution", 4,
                 "is outside 1e-6 .. 1 rad in magnitude: " + quote(tokens[4]));
    }
    const double maximum_range = number(kType, "maximum_range", 5);
    // Tested as the float the scan carries: 1e-320 is positive, but 0 as a float, a scan
    // scan_from_msg refuses.
    if (!(static_cast<float>(maximum_range) > 0.0f)) {
      fail_field(
          kType, "maximum_range", 5,
          (maximum_range > 0.0 ? "is not positive as a 32-bit float: " : "is not positive: ") +
              quote(tokens[5]));
    }
    number(kType, "accuracy", 6);
    number(kType, "remission_mode", 7);
    scan.ranges = ranges(kType, kHeader, n);
    for (std::size_t k = 0; k < m; ++k) {
      const std::size_t index = remissions_at + 1 + k;
      double ignored = 0.0;
      if (!parse_number(tokens[index], ignored)) {
        fail_field(kType, "remission[" + std::to_string(k) + "]", index,
                   parse_problem<double>(tokens[index], "a number"));
      }
    }
    const std::size_t p = remissions_at + 1 + m;
    static constexpr const char* kTailNames[] = {
        "laser_pose_x",        "laser_pose_y",     "laser_pose_theta", "robot_pose_x",
        "robot_pose_y",        "robot_pose_theta", "laser_tv",         "laser_rv",
        "forward_safety_dist", "side_safety_dist", "turn_axis"};
    double tail[std::size(kTailNames)] = {};
    for (std::size_t k = 0; k < std::size(kTailNames); ++k) {
      tail[k] = number(kType, kTailNames[k], p + k);
    }
    scan.odometry = Pose2{tail[3], tail[4], tail[5]};
    scan.stamp = timestamps(kType);
    scan.angle_min = static_cast<float>(start_angle);
    scan.angle_increment = static_cast<float>(resolution);
    scan.max_range = std::min(static_cast<float>(maximum_range), options.no_return_range);
    return scan;
  }

  void parse_odom() {
    constexpr std::string_view kType = "ODOM";
    expect_field_count(kType, 7 + kTimeFields);
    static constexpr const char* kNames[] = {"x", "y", "theta", "tv", "rv", "accel"};
    for (std::size_t k = 0; k < std::size(kNames); ++k) number(kType, kNames[k], 1 + k);
    timestamps(kType);
    ++odom_messages;
  }

  /// Whether `field` is a number (any finite or infinite double).
  static bool is_number(std::string_view field) {
    double v = 0.0;
    return parse_number(field, v);
  }

  // PARAM is metadata: every form real logs have is read, and a line that holds no value is
  // skipped and counted (bad_params), never fatal. Forms, after the name:
  //   value... ipc_timestamp host logger_timestamp   (CARMEN's logger)
  //   value... host logger_timestamp                 (no ipc timestamp)
  //   value...                                       (no time fields)
  // The value is everything before the time fields, single-space joined.
  void parse_param() {
    std::size_t end = tokens.size();
    if (end >= 6 && is_number(tokens[end - 1]) && is_number(tokens[end - 3]) &&
        !is_number(tokens[end - 2])) {
      end -= 3;
    } else if (end >= 5 && is_number(tokens[end - 1]) && !is_number(tokens[end - 2])) {
      end -= 2;
    }
    if (end < 3) {
      ++bad_params;
      if (bad_param_lines.size() < kMaxBadParamLines) bad_param_lines.push_back(line_number);
      return;
    }
    std::string value(tokens[2]);
    for (std::size_t k = 3; k < end; ++k) {
      value += ' ';
      value += tokens[k];
    }
    params.insert_or_assign(std::string(tokens[1]), std::move(value));
  }

  void parse_neff() {
    if (tokens.size() < 2) fail("NEFF line has no value");
    number("NEFF", "value", 1);
    saw_corrected_poses = true;
  }

  std::optional<LaserScan> next_scan() {
    std::string_view line;
    while (read_line(line)) {
      detail::split_fields(line, tokens);
      if (tokens.empty() || tokens[0][0] == '#') continue;
      const std::string_view type = tokens[0];
      if (type == "FLASER") return parse_flaser();
      if (type == "ROBOTLASER1") return parse_robotlaser1();
      if (type == "ODOM") {
        parse_odom();
      } else if (type == "PARAM") {
        parse_param();
      } else if (type == "NEFF") {
        parse_neff();
      } else if (is_message_name(type)) {
        ++skipped_lines;
      } else {
        fail("line does not start with a message name: " + quote(type));
      }
    }
    return std::nullopt;
  }
};

namespace {
void check_options(const CarmenReaderOptions& options) {
  if (!std::isfinite(options.no_return_range) || !(options.no_return_range > 0.0f)) {
    throw std::invalid_argument("CarmenReaderOptions::no_return_range must be finite and > 0");
  }
}
}  // namespace

CarmenReader::CarmenReader(const std::string& path, CarmenReaderOptions options)
    : impl_(std::make_unique<Impl>()) {
  check_options(options);
  impl_->path = path;
  impl_->options = options;
  errno = 0;
  impl_->file = gzopen(path.c_str(), "rb");
  if (impl_->file == nullptr) {
    const int error = errno;
    throw LogError(path, 0,
                   "cannot open: " + (error != 0 ? std::generic_category().message(error)
                                                 : std::string("out of memory")));
  }
  gzbuffer(impl_->file, kReadChunk);
}

CarmenReader::CarmenReader(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

CarmenReader CarmenReader::from_text(std::string text, std::string name,
                                     CarmenReaderOptions options) {
  check_options(options);
  auto impl = std::make_unique<Impl>();
  impl->path = std::move(name);
  impl->options = options;
  // No gzFile: the whole text is the buffer and the end of the input is already reached, so
  // read_line never calls zlib.
  impl->buffer = std::move(text);
  impl->at_eof = true;
  return CarmenReader(std::move(impl));
}

CarmenReader::~CarmenReader() = default;
CarmenReader::CarmenReader(CarmenReader&&) noexcept = default;
CarmenReader& CarmenReader::operator=(CarmenReader&&) noexcept = default;

std::optional<LaserScan> CarmenReader::next_scan() { return impl_->next_scan(); }
const std::string& CarmenReader::name() const { return impl_->path; }
const std::map<std::string, std::string>& CarmenReader::params() const { return impl_->params; }

std::size_t CarmenReader::bad_param_count() const { return impl_->bad_params; }

const std::vector<std::size_t>& CarmenReader::bad_param_lines() const {
  return impl_->bad_param_lines;
}
std::size_t CarmenReader::line_number() const { return impl_->line_number; }
std::size_t CarmenReader::skipped_lines() const { return impl_->skipped_lines; }
std::size_t CarmenReader::odom_messages() const { return impl_->odom_messages; }
bool CarmenReader::saw_corrected_poses() const { return impl_->saw_corrected_poses; }

std::vector<LaserScan> read_scans(CarmenReader& reader, std::size_t max_scans,
                                  const std::atomic<bool>* stop) {
  std::vector<LaserScan> scans;
  while (max_scans == 0 || scans.size() < max_scans) {
    std::optional<LaserScan> scan = reader.next_scan();
    if (!scan) break;
    scans.push_back(std::move(*scan));
    if (stop != nullptr && stop->load()) break;
  }
  if (scans.empty()) {
    throw LogError(reader.name(), 0, "no laser scans (FLASER/ROBOTLASER1) in file");
  }
  return scans;
}

std::vector<LaserScan> read_carmen_log(const std::string& path, CarmenReaderOptions options,
                                       std::size_t max_scans, const std::atomic<bool>* stop) {
  CarmenReader reader(path, options);
  return read_scans(reader, max_scans, stop);
}

std::vector<LaserScan> read_carmen_text(std::string text, const std::string& name,
                                        CarmenReaderOptions options, std::size_t max_scans) {
  CarmenReader reader = CarmenReader::from_text(std::move(text), name, options);
  return read_scans(reader, max_scans);
}

}  // namespace esfleet
