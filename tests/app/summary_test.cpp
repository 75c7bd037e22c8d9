// Order statistics as every program reports them, and the peak-memory figure in stats.json.

#include "app/summary.hpp"

#include <gtest/gtest.h>

#include <cstddef>
#include <vector>

namespace esfleet::app {
namespace {

TEST(Summary, QuantilesInterpolateBetweenSortedValues) {
  const Summary s = summarize({4.0, 1.0, 3.0, 2.0, 5.0});
  EXPECT_DOUBLE_EQ(s.median, 3.0);
  EXPECT_DOUBLE_EQ(s.p95, 4.8);  // 1 + 0.95 * 4 = position 4.8 -> between 4 and 5
  EXPECT_DOUBLE_EQ(s.max, 5.0);
  EXPECT_DOUBLE_EQ(s.mean, 3.0);
}

TEST(Summary, EmptySampleIsAllZeros) {
  const Summary s = summarize({});
  EXPECT_EQ(s.median, 0.0);
  EXPECT_EQ(s.max, 0.0);
}

TEST(PeakRss, GrowsWithMemoryTouched) {
  const double before = peak_rss_mb();
  EXPECT_GT(before, 0.0);
  constexpr std::size_t kBytes = 64u << 20;
  std::vector<unsigned char> block(kBytes);
  for (std::size_t i = 0; i < kBytes; i += 4096) block[i] = static_cast<unsigned char>(i);
  const double after = peak_rss_mb();
  EXPECT_GE(after - before, 60.0) << "before " << before << " MB, after " << after << " MB";
  EXPECT_LT(after, before + 200.0);
  EXPECT_EQ(block[4096], static_cast<unsigned char>(4096));
}

}  // namespace
}  // namespace esfleet::app
