#include "esfleet/core/trajectory_io.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace esfleet {
namespace {

namespace fs = std::filesystem;

/// A fresh directory per test (tests may run in parallel processes under CTest).
class TrajectoryIoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("esfleet_trajectory_io_" + std::string(info->name()) + "_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  void write_text(const std::string& name, const std::string& text) const {
    std::ofstream(path(name), std::ios::binary) << text;
  }

  static std::string slurp(const std::string& file) {
    std::ifstream in(file, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
  }

  /// The message of the std::runtime_error that read_trajectory throws on `file`.
  static std::string read_error(const std::string& file) {
    try {
      read_trajectory(file);
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    ADD_FAILURE() << "read_trajectory(" << file << ") did not throw";
    return {};
  }

  fs::path dir_;
};

std::vector<TimedPose> random_trajectory(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> pos(-500.0, 500.0), ang(-3.14159, 3.14159);
  std::vector<TimedPose> out;
  double t = 1134864629.895182;  // a real epoch stamp: needs all 16 significant digits
  for (std::size_t i = 0; i < n; ++i) {
    t += 0.2 + 0.01 * ang(rng);
    out.push_back({t, {pos(rng), pos(rng), ang(rng)}});
  }
  return out;
}

TEST_F(TrajectoryIoTest, RoundTripKeepsValuesToMicroUnits) {
  const auto original = random_trajectory(200, 42);
  write_trajectory(path("a.txt"), original);
  const auto back = read_trajectory(path("a.txt"));
  ASSERT_EQ(back.size(), original.size());
  for (std::size_t i = 0; i < back.size(); ++i) {
    SCOPED_TRACE(i);
    EXPECT_NEAR(back[i].stamp, original[i].stamp, 1e-6);
    EXPECT_NEAR(back[i].pose.x, original[i].pose.x, 1e-6);
    EXPECT_NEAR(back[i].pose.y, original[i].pose.y, 1e-6);
    EXPECT_NEAR(back[i].pose.theta, original[i].pose.theta, 1e-6);
  }
  EXPECT_FALSE(fs::exists(path("a.txt.tmp"))) << "the temporary file must be renamed away";
}

TEST_F(TrajectoryIoTest, OutputIsByteIdenticalAndHasTheDocumentedFormat) {
  const auto trajectory = random_trajectory(50, 7);
  write_trajectory(path("a.txt"), trajectory);
  write_trajectory(path("b.txt"), trajectory);
  EXPECT_EQ(slurp(path("a.txt")), slurp(path("b.txt")));

  write_trajectory(path("c.txt"), {{0.5, {1.0, -2.25, 0.125}}, {12.0, {1e-7, 3.0, -3.0}}});
  EXPECT_EQ(slurp(path("c.txt")),
            "0.500000 1.000000 -2.250000 0.125000\n"
            "12.000000 0.000000 3.000000 -3.000000\n");
}

TEST_F(TrajectoryIoTest, OverwritesAnExistingFileAndWritesEmptyTrajectories) {
  write_trajectory(path("a.txt"), random_trajectory(10, 1));
  write_trajectory(path("a.txt"), {{1.0, {2.0, 3.0, 0.5}}});
  EXPECT_EQ(read_trajectory(path("a.txt")).size(), 1u);
  write_trajectory(path("a.txt"), {});
  EXPECT_EQ(slurp(path("a.txt")), "");
  EXPECT_TRUE(read_trajectory(path("a.txt")).empty());
}

TEST_F(TrajectoryIoTest, SkipsCommentsAndBlankLinesAndAcceptsAnyWhitespace) {
  write_text("a.txt",
             "# t x y theta\n"
             "\n"
             "1 2 3 0.5\n"
             "   # indented comment\n"
             "\t2.5\t-1e-3   4\t-0.25\r\n"
             "   \n");
  const auto t = read_trajectory(path("a.txt"));
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t[0].stamp, 1.0);
  EXPECT_EQ(t[0].pose, (Pose2{2.0, 3.0, 0.5}));
  EXPECT_EQ(t[1].stamp, 2.5);
  EXPECT_EQ(t[1].pose, (Pose2{-1e-3, 4.0, -0.25}));
}

TEST_F(TrajectoryIoTest, MalformedLinesNameFileAndLine) {
  const std::string good = "# header\n1 0 0 0\n";
  write_text("few.txt", good + "2 0 0\n");
  EXPECT_EQ(read_error(path("few.txt")),
            path("few.txt") + ":3: expected 4 fields (t x y theta), got 3");

  write_text("many.txt", good + "\n2 0 0 0 9\n");
  EXPECT_NE(read_error(path("many.txt")).find(path("many.txt") + ":4: "), std::string::npos);

  write_text("text.txt", good + "2 0 abc 0\n");
  const std::string text_error = read_error(path("text.txt"));
  EXPECT_NE(text_error.find(path("text.txt") + ":3: "), std::string::npos) << text_error;
  EXPECT_NE(text_error.find("field 3"), std::string::npos) << text_error;
  EXPECT_NE(text_error.find("abc"), std::string::npos) << text_error;

  write_text("suffix.txt", good + "2 0 1.5m 0\n");  // a number with trailing junk
  EXPECT_NE(read_error(path("suffix.txt")).find(":3: "), std::string::npos);

  write_text("nan.txt", good + "2 nan 0 0\n");
  EXPECT_NE(read_error(path("nan.txt")).find(":3: "), std::string::npos);
  write_text("inf.txt", "1 0 0 inf\n");
  EXPECT_NE(read_error(path("inf.txt")).find(":1: "), std::string::npos);
  write_text("huge.txt", "1 0 1e999 0\n");
  EXPECT_NE(read_error(path("huge.txt")).find(":1: "), std::string::npos);
}

TEST_F(TrajectoryIoTest, MissingFileErrorNamesThePath) {
  const std::string missing = path("does_not_exist.txt");
  const std::string error = read_error(missing);
  EXPECT_NE(error.find(missing), std::string::npos) << error;
}

TEST_F(TrajectoryIoTest, UnwritablePathErrorNamesThePathAndLeavesNoFile) {
  const std::string target = path("no_such_dir/out.txt");
  try {
    write_trajectory(target, {{1.0, {0.0, 0.0, 0.0}}});
    FAIL() << "write_trajectory into a missing directory did not throw";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(target), std::string::npos) << e.what();
  }
}

TEST_F(TrajectoryIoTest, NonFiniteValuesAreRefusedBeforeTouchingTheFile) {
  write_trajectory(path("a.txt"), {{1.0, {2.0, 3.0, 0.5}}});
  const std::string before = slurp(path("a.txt"));
  EXPECT_THROW(write_trajectory(path("a.txt"), {{1.0, {std::nan(""), 0.0, 0.0}}}),
               std::runtime_error);
  EXPECT_EQ(slurp(path("a.txt")), before) << "a failed write must keep the old file";
  EXPECT_FALSE(fs::exists(path("a.txt.tmp")));
}

}  // namespace
}  // namespace esfleet
