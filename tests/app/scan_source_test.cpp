// Reading a log for the programs: a log whose stamps were printed rounded (all equal) still
// reads whole, and its stamps are seen as not increasing.

#include "app/scan_source.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "esfleet/core/relations.hpp"

namespace esfleet::app {
namespace {

TEST(ReadLog, ALogWithRoundedStampsReadsWhole) {
  // Stamps printed with 6 significant digits, as in the CSAIL key-scan log: all equal.
  const std::filesystem::path path = std::filesystem::path(::testing::TempDir()) /
                                     ("rounded-stamps-" + std::to_string(::getpid()) + ".clf");
  {
    std::ofstream out(path);
    for (int i = 0; i < 3; ++i) {
      out << "FLASER 4 1.0 1.5 2.0 2.5 " << 0.1 * i << " 0 0 " << 0.1 * i
          << " 0 0 1.13486e+09 host 1.13486e+09\n";
    }
  }
  const std::atomic<bool> stop{false};
  const std::vector<LaserScan> scans = read_log(path.string(), {}, 0, false, stop);
  std::filesystem::remove(path);
  ASSERT_EQ(scans.size(), 3u);
  std::vector<double> stamps;
  for (const LaserScan& s : scans) stamps.push_back(s.stamp);
  const StampOrder order = stamp_order(stamps);
  EXPECT_EQ(order.not_after, 2u);
  EXPECT_EQ(order.first, 1u);
}

}  // namespace
}  // namespace esfleet::app
