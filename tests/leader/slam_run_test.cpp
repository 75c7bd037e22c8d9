// SlamRunStats: the poor stretches the leader warns about and writes to stats.json.
#include "slam_run.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace esfleet::leader {
namespace {

SlamStep step_with_agreement(int hits_of_ten) {
  SlamStep s;
  s.fitness.n_points = 10;
  s.fitness.n_known = 10;
  s.fitness.n_hit = hits_of_ten;
  return s;
}

using Stretch = SlamRunStats::Stretch;

/// Records one scan per character: 'w' a weak match (agreement 0.2), '.' a good one (0.9).
std::vector<Stretch> run(SlamRunStats& stats, const std::string& scans) {
  std::vector<Stretch> events;
  for (const char c : scans)
    events.push_back(stats.record(step_with_agreement(c == 'w' ? 2 : 9), 1.0));
  return events;
}

TEST(SlamRunStats, ScatteredWeakMatchesOpenNoStretch) {
  SlamRunStats stats;
  std::string scans;
  for (int i = 0; i < 30; ++i) scans += "w...";  // a quarter weak, evenly
  for (const Stretch e : run(stats, scans)) EXPECT_EQ(e, Stretch::kNone);
  EXPECT_TRUE(stats.poor_stretches.empty());
  EXPECT_EQ(stats.weak_matches, 29u);  // the first scan's match is never weak
}

TEST(SlamRunStats, HalfOfTwentyWeakOpensAStretchThatClosesAfterTenGoodScans) {
  SlamRunStats stats;
  // Scans 1-30 good; 31-50 alternate weak (31, 33, ..., 49: the 10th at scan 49); 51-54 weak;
  // then 10 good ones (55-64).
  std::string scans(30, '.');
  for (int i = 0; i < 10; ++i) scans += "w.";
  scans += "wwww";
  scans += std::string(10, '.');
  const std::vector<Stretch> events = run(stats, scans);
  for (std::size_t i = 0; i < events.size(); ++i) {
    const std::size_t scan = i + 1;
    const Stretch want =
        scan == 49 ? Stretch::kOpened : (scan == 64 ? Stretch::kClosed : Stretch::kNone);
    EXPECT_EQ(events[i], want) << "scan " << scan;
  }
  ASSERT_EQ(stats.poor_stretches.size(), 1u);
  const PoorStretch& p = stats.poor_stretches[0];
  EXPECT_EQ(p.first, 31u);
  EXPECT_EQ(p.last, 54u);
  EXPECT_EQ(p.weak, 14u);
  EXPECT_FALSE(p.open);
}

TEST(SlamRunStats, AStretchStillOpenAtTheEndAndASecondOne) {
  SlamRunStats stats;
  // The first scan has no agreement (nothing mapped yet): never weak. Scans 2-11 weak, 12-51
  // good, 52-63 weak.
  run(stats, std::string(11, 'w') + std::string(40, '.') + std::string(12, 'w'));
  ASSERT_EQ(stats.poor_stretches.size(), 2u);
  EXPECT_EQ(stats.poor_stretches[0].first, 2u);
  EXPECT_EQ(stats.poor_stretches[0].last, 11u);
  EXPECT_EQ(stats.poor_stretches[0].weak, 10u);
  EXPECT_FALSE(stats.poor_stretches[0].open);
  EXPECT_EQ(stats.poor_stretches[1].first, 52u);
  EXPECT_EQ(stats.poor_stretches[1].last, 63u);
  EXPECT_EQ(stats.poor_stretches[1].weak, 12u);
  EXPECT_TRUE(stats.poor_stretches[1].open);
}

}  // namespace
}  // namespace esfleet::leader
