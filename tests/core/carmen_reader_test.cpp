// Tests of the CARMEN log reader on excerpts of the two benchmark logs (tests/data/carmen/), on
// a hand-written ROBOTLASER1 log, and on broken logs generated at test time.
#include "esfleet/core/carmen_reader.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <fstream>
#include <functional>
#include <iterator>
#include <numbers>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <unistd.h>

#include "scratch_paths.hpp"

namespace esfleet {
namespace {

constexpr double kPi = std::numbers::pi;

std::string fixture(const std::string& name) {
  return std::string(ESFLEET_TEST_DATA_DIR) + "/carmen/" + name;
}

// A path in the test temp dir, unique per test so tests can run in parallel.
std::string temp_path(const std::string& name) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  return test::scratch_paths()
      .add(::testing::TempDir() + "carmen_reader_test_" + info->name() + "_" +
           std::to_string(::getpid()) + "_" + name)
      .string();
}

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("test cannot read " + path);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::string write_file(const std::string& name, const std::string& content) {
  const std::string path = temp_path(name);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << content;
  if (!out) throw std::runtime_error("test cannot write " + path);
  return path;
}

std::vector<std::string> lines_of(const std::string& path) {
  std::istringstream in(read_bytes(path));
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

std::vector<std::string> split(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> tokens;
  for (std::string token; in >> token;) tokens.push_back(token);
  return tokens;
}

std::string join(const std::vector<std::string>& tokens) {
  std::string line;
  for (const auto& token : tokens) line += (line.empty() ? "" : " ") + token;
  return line;
}

// First FLASER line of the CSAIL excerpt (361 beams), as tokens.
std::vector<std::string> csail_flaser_tokens() {
  return split(lines_of(fixture("mit-csail-excerpt.clf")).at(0));
}

// A log of a comment, a good FLASER line, `bad_line` (line 3) and another good FLASER line.
std::string log_with_bad_line(const std::string& bad_line) {
  const std::string good = join(csail_flaser_tokens());
  return write_file("bad.log", "# comment\n" + good + "\n" + bad_line + "\n" + good + "\n");
}

// Expects `f` to throw a LogError for `path` at `line` whose message contains `what`.
void expect_log_error(const std::function<void()>& f, const std::string& path, std::size_t line,
                      const std::string& what) {
  try {
    f();
    ADD_FAILURE() << "no LogError thrown; expected " << what;
  } catch (const LogError& e) {
    const std::string message = e.what();
    EXPECT_EQ(e.file(), path) << message;
    EXPECT_EQ(e.line(), line) << message;
    const std::string prefix = line == 0 ? path + ": " : path + ":" + std::to_string(line) + ": ";
    EXPECT_EQ(message.rfind(prefix, 0), 0u) << message;
    EXPECT_NE(message.find(what), std::string::npos) << message;
  }
}

void expect_bad_line(const std::string& bad_line, const std::string& what) {
  const std::string path = log_with_bad_line(bad_line);
  expect_log_error([&] { read_carmen_log(path); }, path, 3, what);
}

std::size_t count_no_returns(const LaserScan& scan) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < scan.ranges.size(); ++i) n += scan.is_no_return(i) ? 1 : 0;
  return n;
}

// ---------------------------------------------------------------- real excerpts

TEST(CarmenReader, ParsesCsailExcerptWith361Beams) {
  CarmenReader reader(fixture("mit-csail-excerpt.clf"));
  std::vector<LaserScan> scans;
  while (auto scan = reader.next_scan()) scans.push_back(std::move(*scan));
  ASSERT_EQ(scans.size(), 5u);
  EXPECT_EQ(reader.line_number(), 5u);
  EXPECT_EQ(reader.skipped_lines(), 0u);
  EXPECT_EQ(reader.odom_messages(), 0u);
  EXPECT_TRUE(reader.params().empty());
  EXPECT_FALSE(reader.saw_corrected_poses());

  const LaserScan& first = scans.front();
  ASSERT_EQ(first.ranges.size(), 361u);
  EXPECT_FLOAT_EQ(first.ranges.front(), 1.40f);
  EXPECT_FLOAT_EQ(first.ranges[1], 1.39f);
  EXPECT_FLOAT_EQ(first.ranges.back(), 2.70f);
  EXPECT_DOUBLE_EQ(first.stamp, 1134864629.895182);
  EXPECT_DOUBLE_EQ(scans.back().stamp, 1134864630.745188);
  // 361 beams: 0.5 deg apart from -90 deg, one at 0 deg, the last at +90 deg.
  EXPECT_FLOAT_EQ(first.angle_min, static_cast<float>(-kPi / 2));
  EXPECT_FLOAT_EQ(first.angle_increment, static_cast<float>(deg_to_rad(0.5)));
  EXPECT_NEAR(first.angle(180), 0.0, 1e-6);
  EXPECT_NEAR(first.angle(360), kPi / 2, 1e-6);
  EXPECT_FLOAT_EQ(first.max_range, 81.9f);
  ASSERT_TRUE(first.odometry.has_value());
  EXPECT_DOUBLE_EQ(first.odometry->x, 576.536523);
  EXPECT_DOUBLE_EQ(first.odometry->y, 0.106594);
  EXPECT_DOUBLE_EQ(first.odometry->theta, -2.255213);

  // No-return readings (81.91) are kept as they are and recognised.
  EXPECT_FLOAT_EQ(first.ranges[24], 81.91f);
  EXPECT_TRUE(first.is_no_return(24));
  EXPECT_FALSE(first.is_no_return(0));
  std::size_t no_returns = 0;
  for (const auto& scan : scans) no_returns += count_no_returns(scan);
  EXPECT_EQ(no_returns, 375u);  // counted with awk on the excerpt
}

TEST(CarmenReader, GzipAndPlainTextGiveIdenticalScans) {
  const auto plain = read_carmen_log(fixture("mit-csail-excerpt.clf"));
  const auto gzipped = read_carmen_log(fixture("mit-csail-excerpt.clf.gz"));
  ASSERT_EQ(plain.size(), gzipped.size());
  for (std::size_t k = 0; k < plain.size(); ++k) {
    EXPECT_EQ(plain[k].ranges, gzipped[k].ranges);
    EXPECT_EQ(plain[k].stamp, gzipped[k].stamp);
    EXPECT_EQ(plain[k].odometry, gzipped[k].odometry);
  }
}

TEST(CarmenReader, ParsesCorrectedFr079ExcerptWithParamsOdomAndNeff) {
  CarmenReader reader(fixture("fr079-excerpt.log.gz"));

  auto first = reader.next_scan();
  ASSERT_TRUE(first.has_value());
  EXPECT_EQ(reader.line_number(), 23u);  // 2 comments, 18 PARAM, 2 ODOM before it
  EXPECT_EQ(reader.params().size(), 18u);
  EXPECT_EQ(reader.params().at("robot_front_laser_max"), "80.99");
  EXPECT_EQ(reader.params().at("robot_allow_rear_motion"), "off");
  EXPECT_EQ(reader.params().at("robot_frontlaser_offset"), "-0.04");
  EXPECT_EQ(reader.odom_messages(), 2u);
  EXPECT_FALSE(reader.saw_corrected_poses());  // the first NEFF comes after the first scan

  ASSERT_EQ(first->ranges.size(), 360u);
  EXPECT_FLOAT_EQ(first->ranges.front(), 1.65f);
  EXPECT_FLOAT_EQ(first->ranges.back(), 1.0f);
  EXPECT_DOUBLE_EQ(first->stamp, 0.227623);
  ASSERT_TRUE(first->odometry.has_value());
  EXPECT_DOUBLE_EQ(first->odometry->x, 0.00123601);
  EXPECT_DOUBLE_EQ(first->odometry->y, -0.00106807);
  EXPECT_DOUBLE_EQ(first->odometry->theta, 2.85e-05);
  // 360 beams, default convention: from -90 deg in 0.5 deg steps, the last at +89.5 deg.
  EXPECT_FLOAT_EQ(first->angle_min, static_cast<float>(-kPi / 2));
  EXPECT_FLOAT_EQ(first->angle_increment, static_cast<float>(deg_to_rad(0.5)));
  EXPECT_NEAR(first->angle(180), 0.0, 1e-6);
  EXPECT_NEAR(first->angle(359), deg_to_rad(89.5), 1e-6);

  auto second = reader.next_scan();
  ASSERT_TRUE(second.has_value());
  EXPECT_EQ(reader.line_number(), 27u);
  EXPECT_TRUE(reader.saw_corrected_poses());
  EXPECT_DOUBLE_EQ(second->stamp, 0.468274);
  EXPECT_FLOAT_EQ(second->ranges.back(), 0.99f);

  auto third = reader.next_scan();
  ASSERT_TRUE(third.has_value());
  EXPECT_DOUBLE_EQ(third->stamp, 0.700156);
  EXPECT_FALSE(reader.next_scan().has_value());
  EXPECT_EQ(reader.line_number(), 33u);
  EXPECT_EQ(reader.odom_messages(), 7u);
  EXPECT_EQ(reader.skipped_lines(), 0u);
  EXPECT_EQ(count_no_returns(*first) + count_no_returns(*second) + count_no_returns(*third), 3u);
}

TEST(CarmenReader, TheFewestFlaserBeamsAreFourAtMostOneRadianApart) {
  // 4 beams over 180°: pi/4 apart (at most 1 rad, as the scan message requires), 5 beams too.
  const auto four = read_carmen_text("FLASER 4 1 2 3 4 0 0 0 0 0 0 1 h 1\n", "four.log");
  ASSERT_EQ(four.size(), 1u);
  EXPECT_FLOAT_EQ(four.front().angle_min, static_cast<float>(-kPi / 2));
  EXPECT_FLOAT_EQ(four.front().angle_increment, static_cast<float>(kPi / 4));
  const auto five = read_carmen_text("FLASER 5 1 2 3 4 5 0 0 0 0 0 0 1 h 1\n", "five.log");
  ASSERT_EQ(five.size(), 1u);
  EXPECT_FLOAT_EQ(five.front().angle_increment, static_cast<float>(kPi / 4));
  EXPECT_NEAR(five.front().angle(4), kPi / 2, 1e-6);
}

TEST(CarmenReader, EvenBeamCountFollowsTheCenteredConvention) {
  CarmenReaderOptions options;
  options.even_beams = EvenBeamConvention::kCentered;
  const auto scans = read_carmen_log(fixture("fr079-excerpt.log.gz"), options);
  ASSERT_EQ(scans.size(), 3u);
  const LaserScan& scan = scans.front();
  EXPECT_FLOAT_EQ(scan.angle_min, static_cast<float>(deg_to_rad(-89.75)));
  EXPECT_FLOAT_EQ(scan.angle_increment, static_cast<float>(deg_to_rad(0.5)));
  EXPECT_NEAR(scan.angle(179), deg_to_rad(-0.25), 1e-6);  // no beam at 0 deg
  EXPECT_NEAR(scan.angle(180), deg_to_rad(0.25), 1e-6);
  EXPECT_NEAR(scan.angle(359), deg_to_rad(89.75), 1e-6);

  // Odd beam counts do not depend on the convention.
  const auto csail = read_carmen_log(fixture("mit-csail-excerpt.clf"), options, 1);
  EXPECT_FLOAT_EQ(csail.front().angle_min, static_cast<float>(-kPi / 2));
  EXPECT_NEAR(csail.front().angle(180), 0.0, 1e-6);
}

TEST(CarmenReader, NoReturnRangeOptionSetsMaxRange) {
  CarmenReaderOptions options;
  options.no_return_range = 30.0f;
  const auto scans = read_carmen_log(fixture("mit-csail-excerpt.clf"), options, 1);
  EXPECT_FLOAT_EQ(scans.front().max_range, 30.0f);
  options.no_return_range = std::nanf("");
  EXPECT_THROW(CarmenReader(fixture("mit-csail-excerpt.clf"), options), std::invalid_argument);
  options.no_return_range = 0.0f;
  EXPECT_THROW(CarmenReader(fixture("mit-csail-excerpt.clf"), options), std::invalid_argument);
}

TEST(CarmenReader, MaxScansStopsEarly) {
  const auto scans = read_carmen_log(fixture("mit-csail-excerpt.clf.gz"), {}, 2);
  ASSERT_EQ(scans.size(), 2u);
  EXPECT_DOUBLE_EQ(scans[1].stamp, 1134864630.105179);
}

TEST(CarmenReader, MovedReaderContinuesWhereItWas) {
  CarmenReader reader(fixture("mit-csail-excerpt.clf"));
  ASSERT_TRUE(reader.next_scan().has_value());
  CarmenReader moved(std::move(reader));
  auto scan = moved.next_scan();
  ASSERT_TRUE(scan.has_value());
  EXPECT_DOUBLE_EQ(scan->stamp, 1134864630.105179);
  EXPECT_EQ(moved.line_number(), 2u);
}

// ---------------------------------------------------------------- ROBOTLASER1, skipping

TEST(CarmenReader, ParsesRobotLaser1WithItsOwnAnglesAndMaxRange) {
  CarmenReader reader(fixture("robotlaser1.log"));
  auto first = reader.next_scan();
  ASSERT_TRUE(first.has_value());
  EXPECT_EQ(reader.line_number(), 5u);
  ASSERT_EQ(first->ranges.size(), 5u);
  EXPECT_FLOAT_EQ(first->ranges[0], 1.0f);
  EXPECT_FLOAT_EQ(first->ranges[4], 49.99f);
  EXPECT_FLOAT_EQ(first->angle_min, -1.5707963f);
  EXPECT_FLOAT_EQ(first->angle_increment, 0.7853982f);
  EXPECT_FLOAT_EQ(first->max_range, 50.0f);  // the line's maximum_range, below 81.9
  EXPECT_TRUE(first->is_no_return(3));       // 60.0 >= 50.0
  EXPECT_FALSE(first->is_no_return(4));
  EXPECT_DOUBLE_EQ(first->stamp, 123.456);
  ASSERT_TRUE(first->odometry.has_value());
  EXPECT_EQ(*first->odometry, (Pose2{1.0, 2.0, 0.5}));  // robot pose, not laser pose

  auto second = reader.next_scan();
  ASSERT_TRUE(second.has_value());
  ASSERT_EQ(second->ranges.size(), 3u);
  EXPECT_FLOAT_EQ(second->angle_min, -0.5f);
  EXPECT_FLOAT_EQ(second->angle_increment, 0.25f);
  EXPECT_FLOAT_EQ(second->max_range, 81.9f);  // capped at the no-return range
  EXPECT_TRUE(second->is_no_return(1));
  EXPECT_EQ(*second->odometry, (Pose2{-1.0, -2.0, -0.75}));
  EXPECT_DOUBLE_EQ(second->stamp, 124.5);

  EXPECT_FALSE(reader.next_scan().has_value());
  EXPECT_EQ(reader.skipped_lines(), 2u);  // TRUEPOS and SYNC
  EXPECT_EQ(reader.line_number(), 9u);
}

TEST(CarmenReader, SkipsAndCountsUnknownTypesCommentsAndBlankLines) {
  const std::string good = join(csail_flaser_tokens());
  const std::string path = write_file(
      "mixed.log", "\n# comment\n   \t\n  # indented comment\nRLASER 2 1 2 0 0 0 0 0 0 1 h 1\n" +
                       good + "\r\nRAWLASER1 junk that is not parsed\nTRUEPOS 1 2 3\n\n" + good);
  CarmenReader reader(path);
  ASSERT_TRUE(reader.next_scan().has_value());
  EXPECT_EQ(reader.line_number(), 6u);
  EXPECT_EQ(reader.skipped_lines(), 1u);
  auto last = reader.next_scan();  // last line without '\n'
  ASSERT_TRUE(last.has_value());
  EXPECT_EQ(last->ranges.size(), 361u);
  EXPECT_EQ(reader.line_number(), 10u);
  EXPECT_FALSE(reader.next_scan().has_value());
  EXPECT_EQ(reader.skipped_lines(), 3u);
}

TEST(CarmenReader, ParamLinesOfEveryFormAreReadAndOnesWithoutAValueSkipped) {
  const std::string path = write_file("param-forms.log",
                                      "PARAM full 1.5 100.0 host 100.0\n"
                                      "PARAM no_ipc 81.83 nr 1178020153.12\n"
                                      "PARAM bare some value\n"
                                      "PARAM name_only\n"
                                      "PARAM\n"
                                      "PARAM laser_max 50 host 12.5\n" +
                                          join(csail_flaser_tokens()) + "\n");
  CarmenReader reader(path);
  ASSERT_TRUE(reader.next_scan().has_value());
  EXPECT_EQ(reader.params().at("full"), "1.5");
  EXPECT_EQ(reader.params().at("no_ipc"), "81.83");
  EXPECT_EQ(reader.params().at("bare"), "some value");
  EXPECT_EQ(reader.params().at("laser_max"), "50");
  EXPECT_EQ(reader.params().count("name_only"), 0u);
  EXPECT_EQ(reader.bad_param_count(), 2u);
  EXPECT_EQ(reader.bad_param_lines(), (std::vector<std::size_t>{4, 5}));
}

TEST(CarmenReader, NoReturnRangeIsAnOptionAndAReadingAtItIsANoReturn) {
  auto tokens = csail_flaser_tokens();
  tokens[2] = "50";     // beam 0 at exactly the log's no-return value
  tokens[3] = "49.99";  // beam 1 just below
  const std::string path = write_file("no-return.log", join(tokens) + "\n");
  CarmenReaderOptions options;
  options.no_return_range = 50.0f;
  CarmenReader reader(path, options);
  const std::optional<LaserScan> scan = reader.next_scan();
  ASSERT_TRUE(scan.has_value());
  EXPECT_FLOAT_EQ(scan->max_range, 50.0f);
  EXPECT_TRUE(scan->is_no_return(0));
  EXPECT_FALSE(scan->is_no_return(1));
}

TEST(CarmenReader, ParamValueMayHoldSpacesAndLaterLinesWin) {
  const std::string path = write_file("params.log",
                                      "PARAM a first 1.0 host 1.0\n"
                                      "PARAM map_path /tmp/my map.pgm 2.0 host 2.0\n"
                                      "PARAM a second 3.0 host 3.0\n" +
                                          join(csail_flaser_tokens()) + "\n");
  CarmenReader reader(path);
  ASSERT_TRUE(reader.next_scan().has_value());
  EXPECT_EQ(reader.params().at("a"), "second");
  EXPECT_EQ(reader.params().at("map_path"), "/tmp/my map.pgm");
}

// ---------------------------------------------------------------- errors

TEST(CarmenReaderErrors, TruncatedLineCutMidRanges) {
  auto tokens = csail_flaser_tokens();
  tokens.resize(200);
  expect_bad_line(join(tokens), "FLASER declares 361 beams");
  expect_bad_line(join(tokens), "truncated line");
}

TEST(CarmenReaderErrors, WrongBeamCount) {
  auto tokens = csail_flaser_tokens();
  tokens[1] = "360";  // one range field too many for the declared count
  expect_bad_line(join(tokens), "FLASER declares 360 beams, so 369 fields must follow");
  tokens[1] = "362";
  expect_bad_line(join(tokens), "but the line has 370");
}

TEST(CarmenReaderErrors, ExtraTrailingField) {
  auto tokens = csail_flaser_tokens();
  tokens.push_back("0.5");
  expect_bad_line(join(tokens), "extra fields");
}

TEST(CarmenReaderErrors, BeamCountOutOfRangeOrNotAnInteger) {
  expect_bad_line("FLASER 0 1 2 3 4 5 6 1 h 1", "beam count (field 1) is 0, outside [4, 10000]");
  expect_bad_line("FLASER -3 1 2 3", "is -3, outside");
  expect_bad_line("FLASER 10001 1 2 3", "is 10001, outside");
  expect_bad_line("FLASER 361.0 1 2 3", "beam count (field 1) is not an integer: \"361.0\"");
  expect_bad_line("FLASER", "ends before its beam count");
}

TEST(CarmenReaderErrors, NanRange) {
  auto tokens = csail_flaser_tokens();
  tokens[2 + 17] = "nan";
  expect_bad_line(join(tokens), "FLASER range[17] (field 19) is NaN");
}

TEST(CarmenReaderErrors, InfiniteRange) {
  auto tokens = csail_flaser_tokens();
  tokens[2 + 360] = "inf";
  expect_bad_line(join(tokens), "FLASER range[360] (field 362) is infinite");
  tokens[2 + 360] = "1e39";  // beyond float
  expect_bad_line(join(tokens), "range[360] (field 362) is out of range for its type: \"1e39\"");
}

TEST(CarmenReaderErrors, NegativeRange) {
  auto tokens = csail_flaser_tokens();
  tokens[2] = "-0.5";
  expect_bad_line(join(tokens), "FLASER range[0] (field 2) is negative: \"-0.5\"");
}

TEST(CarmenReaderErrors, NonNumericFields) {
  auto tokens = csail_flaser_tokens();
  tokens[2 + 5] = "1.3x";
  expect_bad_line(join(tokens), "FLASER range[5] (field 7) is not a number: \"1.3x\"");
  tokens = csail_flaser_tokens();
  tokens[2 + 361 + 3] = "abc";
  expect_bad_line(join(tokens), "FLASER odom_x (field 366) is not a number: \"abc\"");
  expect_bad_line("ODOM 1 2 three 0 0 0 5.0 host 5.0", "ODOM theta (field 3) is not a number");
  expect_bad_line("NEFF many", "NEFF value (field 1) is not a number");
}

TEST(CarmenReaderErrors, NonFinitePoseOrTimestamp) {
  auto tokens = csail_flaser_tokens();
  tokens[2 + 361] = "nan";
  expect_bad_line(join(tokens), "FLASER x (field 363) is not finite");
  tokens = csail_flaser_tokens();
  tokens[2 + 361 + 6] = "inf";
  expect_bad_line(join(tokens), "FLASER ipc_timestamp (field 369) is not finite");
  tokens = csail_flaser_tokens();
  tokens.back() = "-nan";
  expect_bad_line(join(tokens), "FLASER logger_timestamp (field 371) is not finite");
}

TEST(CarmenReaderErrors, MalformedOdomParamAndRobotLaser1) {
  expect_bad_line("ODOM 1 2 3 0 0 0 5.0 host", "ODOM line has 8 fields after the message name");
  expect_bad_line("ROBOTLASER1 0 -1.57 3.14 0.785 50 0.01 0 5 1 2 3",
                  "ROBOTLASER1 declares 5 readings but the line ends after 3");
  expect_bad_line("ROBOTLASER1 0 -1.57 3.14 0 50 0.01 0 1 1.0 0 0 0 0 0 0 0 0 0 0 0 0 1 h 1",
                  "angular_resolution (field 4) is zero");
  expect_bad_line("ROBOTLASER1 0 -1.57 3.14 0.1 50 0.01 0 1 1.0 0 0 0 0 0 0 0 0 0 0 0 1 h 1",
                  "ROBOTLASER1 line has 23 fields after the message name, expected 24");
}

TEST(CarmenReaderErrors, LineThatDoesNotStartWithAMessageName) {
  // The second half of a FLASER line broken in two must not be skipped as an unknown type.
  expect_bad_line("1.40 1.39 576.5 0.1 -2.2 1134864629.9 b21 0.08",
                  "line does not start with a message name: \"1.40\"");
}

TEST(CarmenReaderErrors, LineLongerThanOneMebibyte) {
  const std::string path =
      write_file("long.log", "# fine\nFLASER 361 " + std::string(std::size_t{1} << 21, '1'));
  expect_log_error([&] { read_carmen_log(path); }, path, 2, "line is longer than 1048576 bytes");
}

TEST(CarmenReaderErrors, EmptyFileHasNoScans) {
  const std::string path = write_file("empty.log", "");
  expect_log_error([&] { read_carmen_log(path); }, path, 0,
                   "no laser scans (FLASER/ROBOTLASER1) in file");
  const std::string only_odom = write_file("odom.log", "# c\nODOM 0 0 0 0 0 0 1 h 1\n");
  expect_log_error([&] { read_carmen_log(only_odom); }, only_odom, 0, "no laser scans");
  CarmenReader reader(path);  // the reader itself just reports the end
  EXPECT_FALSE(reader.next_scan().has_value());
}

TEST(CarmenReaderErrors, MissingFile) {
  const std::string path = temp_path("does-not-exist.log.gz");
  expect_log_error([&] { CarmenReader reader(path); }, path, 0,
                   "cannot open: No such file or directory");
  expect_log_error([&] { read_carmen_log(path); }, path, 0, "cannot open");
}

// Reads `path` scan by scan until it throws; returns the scans delivered and the error.
std::pair<std::vector<LaserScan>, std::optional<LogError>> read_until_error(
    const std::string& path) {
  CarmenReader reader(path);
  std::vector<LaserScan> scans;
  try {
    while (auto scan = reader.next_scan()) scans.push_back(std::move(*scan));
  } catch (const LogError& e) {
    return {std::move(scans), e};
  }
  return {std::move(scans), std::nullopt};
}

TEST(CarmenReaderErrors, TruncatedGzipStream) {
  const std::string bytes = read_bytes(fixture("mit-csail-excerpt.clf.gz"));
  const std::string path = write_file("truncated.clf.gz", bytes.substr(0, bytes.size() / 2));
  const auto intact = read_carmen_log(fixture("mit-csail-excerpt.clf"));
  const auto [scans, error] = read_until_error(path);
  ASSERT_TRUE(error.has_value()) << "a truncated .gz must not end silently";
  // Complete lines before the cut are delivered unchanged; the line being read is the error.
  ASSERT_LT(scans.size(), intact.size());
  for (std::size_t k = 0; k < scans.size(); ++k) EXPECT_EQ(scans[k].ranges, intact[k].ranges);
  const std::size_t line = scans.size() + 1;
  expect_log_error([&] { throw *error; }, path, line,
                   "gzip stream is truncated or corrupt (zlib: unexpected end of file)");
  // read_carmen_log fails the same way.
  expect_log_error([&] { read_carmen_log(path); }, path, line, "unexpected end of file");
}

TEST(CarmenReaderErrors, CorruptGzipChecksum) {
  std::string bytes = read_bytes(fixture("mit-csail-excerpt.clf.gz"));
  bytes[bytes.size() - 8] = static_cast<char>(bytes[bytes.size() - 8] ^ 0x5a);  // CRC-32
  const std::string path = write_file("corrupt.clf.gz", bytes);
  const auto [scans, error] = read_until_error(path);
  ASSERT_TRUE(error.has_value()) << "a .gz with a bad checksum must not end silently";
  expect_log_error([&] { throw *error; }, path, scans.size() + 1,
                   "gzip stream is truncated or corrupt (zlib: incorrect data check)");
}

// ---------------------------------------------------------------- reading a whole log

TEST(ReadScans, ContinuesFromTheReaderAndStopsWhenAskedOrAtMaxScans) {
  const auto all = read_carmen_log(fixture("mit-csail-excerpt.clf"));
  ASSERT_GE(all.size(), 4u);
  CarmenReader reader(fixture("mit-csail-excerpt.clf"));
  ASSERT_TRUE(reader.next_scan());
  EXPECT_EQ(reader.name(), fixture("mit-csail-excerpt.clf"));
  const auto two = read_scans(reader, 2);  // the second and third scans
  ASSERT_EQ(two.size(), 2u);
  EXPECT_EQ(two[0].stamp, all[1].stamp);
  EXPECT_EQ(two[1].stamp, all[2].stamp);
  // A stop flag already set: the scan being read is kept, no further one.
  std::atomic<bool> stop{true};
  const auto one = read_carmen_log(fixture("mit-csail-excerpt.clf"), {}, 0, &stop);
  ASSERT_EQ(one.size(), 1u);
  EXPECT_EQ(one[0].stamp, all[0].stamp);
  stop = false;
  EXPECT_EQ(read_carmen_log(fixture("mit-csail-excerpt.clf"), {}, 0, &stop).size(), all.size());
  // Nothing left to read is an error naming the reader's file.
  while (reader.next_scan()) {
  }
  expect_log_error([&] { read_scans(reader); }, fixture("mit-csail-excerpt.clf"), 0,
                   "no laser scans");
}

// ---------------------------------------------------------------- in memory (from_text)

TEST(CarmenReaderFromText, GivesTheSameScansAsTheFile) {
  const auto from_file = read_carmen_log(fixture("mit-csail-excerpt.clf"));
  const auto from_text =
      read_carmen_text(read_bytes(fixture("mit-csail-excerpt.clf")), "excerpt.clf");
  ASSERT_EQ(from_text.size(), from_file.size());
  for (std::size_t k = 0; k < from_file.size(); ++k) {
    EXPECT_EQ(from_text[k].ranges, from_file[k].ranges);
    EXPECT_EQ(from_text[k].stamp, from_file[k].stamp);
    EXPECT_EQ(from_text[k].angle_min, from_file[k].angle_min);
    EXPECT_EQ(from_text[k].angle_increment, from_file[k].angle_increment);
  }
  CarmenReader reader = CarmenReader::from_text(read_bytes(fixture("robotlaser1.log")));
  std::size_t scans = 0;
  while (reader.next_scan()) ++scans;
  EXPECT_EQ(scans, 2u);
  EXPECT_EQ(reader.skipped_lines(), 2u);
}

TEST(CarmenReaderFromText, ErrorsNameTheGivenNameAndLine) {
  expect_log_error([] { read_carmen_text("# c\nFLASER 4 1 1\n", "mem.log"); }, "mem.log", 2,
                   "FLASER declares 4 beams");
  expect_log_error([] { read_carmen_text("", "mem.log"); }, "mem.log", 0, "no laser scans");
  // A last line without '\n' is read; one longer than 1 MiB is an error, as from a file.
  EXPECT_EQ(read_carmen_text(lines_of(fixture("mit-csail-excerpt.clf")).at(0)).size(), 1u);
  expect_log_error([] { read_carmen_text(std::string((1u << 20) + 1, 'x'), "big.log"); }, "big.log",
                   1, "line is longer than 1048576 bytes");
  CarmenReaderOptions bad;
  bad.no_return_range = 0.0f;
  EXPECT_THROW(CarmenReader::from_text("", "x", bad), std::invalid_argument);
}

// ---------------------------------------------------------------- fuzzing findings
// Inputs found with fuzz/fuzz_carmen (docs/fuzzing.md); each is also in fuzz/corpus/fuzz_carmen.

// fuzz_carmen, regress-robotlaser1-huge-start-angle: a finite double start_angle (1e300) became
// an infinite float angle_min; 1e-300 as angular_resolution became a zero float increment.
TEST(CarmenReaderFuzzRegressions, RobotLaser1AnglesMustFitTheScan) {
  const std::string head = "ROBOTLASER1 0 ";
  const std::string tail =
      " 5 1.0 2.5 0.0 60.0 49.99 2 0.5 0.25 0.1 0.0 0.0 1.0 2.0 0.5 0.3 0.1 0.5 0.2 0.0 123.456 "
      "host 123.457";
  const auto line = [&](const std::string& start, const std::string& resolution) {
    return head + start + " 3.1415927 " + resolution + " 50.0 0.01 0" + tail;
  };
  EXPECT_EQ(read_carmen_text(line("-1.5707963", "0.7853982")).size(), 1u);
  expect_log_error([&] { read_carmen_text(line("1e300", "0.7853982"), "f.log"); }, "f.log", 1,
                   "ROBOTLASER1 start_angle (field 2) is outside [-2pi, 2pi]: \"1e300\"");
  expect_log_error([&] { read_carmen_text(line("-7", "0.7853982"), "f.log"); }, "f.log", 1,
                   "start_angle (field 2) is outside");
  expect_log_error([&] { read_carmen_text(line("-1.57", "1e-300"), "f.log"); }, "f.log", 1,
                   "ROBOTLASER1 angular_resolution (field 4) is outside 1e-6 .. 1 rad");
  expect_log_error([&] { read_carmen_text(line("-1.57", "-1e300"), "f.log"); }, "f.log", 1,
                   "angular_resolution (field 4) is outside");
  // The exact corpus input.
  const std::string corpus = std::string(ESFLEET_PROJECT_DIR) + "/fuzz/corpus/fuzz_carmen/";
  expect_log_error(
      [&] { read_carmen_text(read_bytes(corpus + "regress-robotlaser1-huge-start-angle"), "f"); },
      "f", 1, "start_angle (field 2) is outside");
  expect_log_error(
      [&] { read_carmen_text(read_bytes(corpus + "regress-robotlaser1-tiny-resolution"), "f"); },
      "f", 1, "angular_resolution (field 4) is outside");
}

// fuzz_carmen, regress-flaser-three-beams: a FLASER of 3 (or 2) beams spread over 180° has beams
// pi/2 apart, a scan that scan_from_msg refuses (more than 1 rad), so esfleet-replay could not
// send it. The fewest FLASER beams are 4 (TheFewestFlaserBeamsAreFourAtMostOneRadianApart).
TEST(CarmenReaderFuzzRegressions, FlaserBeamsMustBeAtMostOneRadianApart) {
  expect_log_error([] { read_carmen_text("FLASER 3 1 2 3 0 0 0 0 0 0 1 h 1", "f.log"); }, "f.log",
                   1, "FLASER beam count (field 1) is 3, outside [4, 10000]");
  expect_log_error([] { read_carmen_text("FLASER 2 1 2 0 0 0 0 0 0 1 h 1", "f.log"); }, "f.log", 1,
                   "FLASER beam count (field 1) is 2, outside [4, 10000]");
  const std::string corpus = std::string(ESFLEET_PROJECT_DIR) + "/fuzz/corpus/fuzz_carmen/";
  expect_log_error(
      [&] { read_carmen_text(read_bytes(corpus + "regress-flaser-three-beams"), "f"); }, "f", 1,
      "beam count (field 1) is 3, outside");
}

// fuzz_carmen, regress-robotlaser1-subnormal-max-range: a maximum_range of 1e-320 is a positive
// double but 0 as the float a scan carries, a scan scan_from_msg refuses (max_range must be > 0).
TEST(CarmenReaderFuzzRegressions, RobotLaser1MaximumRangeMustBePositiveAsAFloat) {
  const auto line = [](const std::string& maximum_range) {
    return "ROBOTLASER1 0 -1.5707963 3.1415927 0.7853982 " + maximum_range +
           " 0.01 0 5 1.0 2.5 0.0 60.0 49.99 2 0.5 0.25 0.1 0.0 0.0 1.0 2.0 0.5 0.3 0.1 0.5 0.2 "
           "0.0 123.456 host 123.457";
  };
  const std::vector<LaserScan> ok = read_carmen_text(line("1e-30"));
  ASSERT_EQ(ok.size(), 1u);
  EXPECT_EQ(ok[0].max_range, 1e-30f);
  expect_log_error([&] { read_carmen_text(line("1e-320"), "f.log"); }, "f.log", 1,
                   "ROBOTLASER1 maximum_range (field 5) is not positive as a 32-bit float: "
                   "\"1e-320\"");
  expect_log_error([&] { read_carmen_text(line("-0"), "f.log"); }, "f.log", 1,
                   "ROBOTLASER1 maximum_range (field 5) is not positive: \"-0\"");
  const std::string corpus = std::string(ESFLEET_PROJECT_DIR) + "/fuzz/corpus/fuzz_carmen/";
  expect_log_error(
      [&] {
        read_carmen_text(read_bytes(corpus + "regress-robotlaser1-subnormal-max-range"), "f");
      },
      "f", 1, "maximum_range (field 5) is not positive as a 32-bit float");
}

}  // namespace
}  // namespace esfleet
