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
/// at and around the thresholds.
inline GridMap make_test_map() {
  GridMap map(GridMapConfig{.cell_size = 0.05, .tile_edge = 8});
  add(map, {-9, 5}, 3, 0);       // occupied, top-left pixel
  add(map, {-9, -6}, 13, 7);     // p = 0.65 exactly: occupied (threshold inclusive)
  add(map, {4, -6}, 0, 2);       // free, bottom-right pixel
  add(map, {4, 5}, 49, 201);     // p = 0.196 exactly: free (threshold inclusive)
  add(map, {0, 0}, 1, 1);        // p = 0.5: grey 128
  add(map, {2, 3}, 1299, 701);   // p = 0.6495: 89.4 would read occupied, clamped to 90
  add(map, {-1, -1}, 197, 803);  // p = 0.197: 204.8 rounds to 205 (unknown), moved to 204
  for (int x = -3; x <= 3; ++x) add(map, {x, -4}, 0, 1);  // a free row
  map.commit_update();
  return map;
}

}  // namespace esfleet::testing
