// Reading a log for the programs: scans stamped no later than the scan before them (rounded
// stamps) are counted, and such a log still reads whole.

#include "app/scan_source.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

namespace esfleet::app {
namespace {

std::vector<LaserScan> stamped(const std::vector<double>& stamps) {
  std::vector<LaserScan> scans(stamps.size());
  for (std::size_t i = 0; i < stamps.size(); ++i) scans[i].stamp = stamps[i];
  return scans;
}

TEST(StampOrder, CountsScansNotStampedAfterTheOneBefore) {
  const StampOrder ok = stamp_order(stamped({1.0, 1.1, 1.2, 5.0}));
  EXPECT_EQ(ok.not_after, 0u);
  const StampOrder bad = stamp_order(stamped({1.0, 2.0, 2.0, 3.0, 0.5, 4.0}));
  EXPECT_EQ(bad.not_after, 2u);  // the repeated 2.0 and the 0.5
  EXPECT_EQ(bad.first, 2u);
  EXPECT_EQ(stamp_order({}).not_after, 0u);
  EXPECT_EQ(stamp_order(stamped({7.0})).not_after, 0u);
}

TEST(StampOrder, ALogWithRoundedStampsReadsWhole) {
  // Stamps printed with 6 significant digits, as in the CSAIL key-scan log: all equal.
  const std::filesystem::path path = std::filesystem::path(::testing::TempDir()) /
                                     ("rounded-stamps-" + std::to_string(::getpid()) + ".clf");
  {
    std::ofstream out(path);
    for (int i = 0; i < 3; ++i) {
      out << "FLASER 3 1.0 1.5 2.0 " << 0.1 * i << " 0 0 " << 0.1 * i
          << " 0 0 1.13486e+09 host 1.13486e+09\n";
    }
  }
  const std::atomic<bool> stop{false};
  const std::vector<LaserScan> scans = read_log(path.string(), {}, 0, false, stop);
  std::filesystem::remove(path);
  ASSERT_EQ(scans.size(), 3u);
  const StampOrder order = stamp_order(scans);
  EXPECT_EQ(order.not_after, 2u);
  EXPECT_EQ(order.first, 1u);
}

}  // namespace
}  // namespace esfleet::app
