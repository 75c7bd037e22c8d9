#pragma once
// Shared by the map file tests (ros_map_writer_test, ros_map_reader_test, map_png_test,
// file_io_test): a fresh directory per test and the test map.

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/ros_map_reader.hpp"

namespace esfleet::testing {

namespace fs = std::filesystem;

/// A fresh directory per test (tests may run in parallel processes under CTest).
class MapFilesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::path(::testing::TempDir()) /
           ("esfleet_map_files_" + std::string(info->name()) + "_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  void write_bytes(const std::string& name, const std::string& bytes) const {
    std::ofstream(path(name), std::ios::binary) << bytes;
  }

  static std::string slurp(const std::string& file) {
    std::ifstream in(file, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
  }

  /// The message of the std::runtime_error that load_ros_map throws on `yaml`.
  static std::string load_error(const std::string& yaml) {
    try {
      load_ros_map(yaml);
    } catch (const std::runtime_error& e) {
      return e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << "load_ros_map(" << yaml << ") threw a non-runtime_error: " << e.what();
      return {};
    }
    ADD_FAILURE() << "load_ros_map(" << yaml << ") did not throw";
    return {};
  }

  fs::path dir_;
};

inline void add(GridMap& map, CellIndex c, int hits, int errs) {
  for (int i = 0; i < hits; ++i) ASSERT_TRUE(map.add_hit(c));
  for (int i = 0; i < errs; ++i) ASSERT_TRUE(map.add_err(c));
}

/// The test map: 14 x 12 cells (x -9..4, y -6..5) over four 8-cell tiles, with cells chosen
/// at and around the default OccupancyThresholds (occupied: hit >= 2 and p > 0.196; free:
/// p <= 0.196).
inline GridMap make_test_map() {
  GridMap map(GridMapConfig{.cell_size = 0.05, .tile_edge = 8});
  add(map, {-9, 5}, 3, 0);    // occupied, top-left pixel
  add(map, {-9, -6}, 2, 8);   // p = 0.2, two hits: occupied (a grazed wall)
  add(map, {4, -6}, 0, 2);    // free, bottom-right pixel
  add(map, {4, 5}, 49, 201);  // p = 0.196 exactly: free (threshold inclusive), 49 hits or not
  add(map, {0, 0}, 1, 1);     // p = 0.5 but one hit: unknown
  add(map, {2, 3}, 1, 0);     // p = 1 but one hit: unknown
  add(map, {-1, -1}, 1, 9);   // p = 0.1: free
  add(map, {3, 2}, 50, 150);  // p = 0.25: occupied
  for (int x = -3; x <= 3; ++x) add(map, {x, -4}, 0, 1);  // a free row
  map.commit_update();
  return map;
}

}  // namespace esfleet::testing
