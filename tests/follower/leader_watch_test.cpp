// The follower's view of the leader: present from its first summary, gone when DDS unmatches
// its writer or (while it maps) its summaries stop for longer than the timeout, back at the
// next summary.

#include "leader_watch.hpp"

#include <gtest/gtest.h>

namespace esfleet::follower {
namespace {

using Event = LeaderWatch::Event;

TEST(LeaderWatch, AbsentUntilTheFirstSummaryThenPresent) {
  LeaderWatch w(5.0);
  EXPECT_EQ(w.update(0.0, 0, 0, false), Event::kNone);
  EXPECT_FALSE(w.present());
  EXPECT_EQ(w.update(20.0, 0, 1, true), Event::kNone);  // matched, but nothing received
  EXPECT_FALSE(w.present());
  EXPECT_EQ(w.update(21.0, 1, 1, true), Event::kNone);  // the first summary is no return
  EXPECT_TRUE(w.present());
  EXPECT_EQ(w.lost(), 0u);
}

TEST(LeaderWatch, GoneWhenItsSummariesStopWhileMappingOnlyThen) {
  LeaderWatch w(5.0);
  w.update(0.0, 1, 1, true);
  EXPECT_EQ(w.update(4.9, 1, 1, true), Event::kNone);
  EXPECT_EQ(w.update(5.2, 1, 1, true), Event::kGone);
  EXPECT_FALSE(w.present());
  EXPECT_EQ(w.lost(), 1u);
  EXPECT_NEAR(w.silence_at_loss_s(), 5.2, 1e-9);
  EXPECT_NE(w.reason().find("no map summary for 5.2 s while it was mapping"), std::string::npos)
      << w.reason();
  EXPECT_EQ(w.update(6.0, 1, 1, true), Event::kNone);  // reported once
  // A complete map is not expected to be republished often: silence is no loss.
  LeaderWatch done(5.0);
  done.update(0.0, 1, 1, false);
  EXPECT_EQ(done.update(100.0, 1, 1, false), Event::kNone);
  EXPECT_TRUE(done.present());
  // Timeout 0: only DDS's report counts.
  LeaderWatch dds_only(0.0);
  dds_only.update(0.0, 1, 1, true);
  EXPECT_EQ(dds_only.update(100.0, 1, 1, true), Event::kNone);
}

TEST(LeaderWatch, GoneWhenDdsUnmatchesItsWriterBackAtTheNextSummary) {
  LeaderWatch w(5.0);
  w.update(0.0, 1, 1, true);
  EXPECT_EQ(w.update(1.0, 2, 0, true), Event::kGone);
  EXPECT_NE(w.reason().find("DDS reports its map writer gone"), std::string::npos);
  EXPECT_DOUBLE_EQ(w.lost_at_s(), 1.0);
  EXPECT_EQ(w.update(3.0, 2, 0, true), Event::kNone);
  EXPECT_EQ(w.update(4.0, 3, 1, true), Event::kBack);
  EXPECT_TRUE(w.present());
  EXPECT_EQ(w.returned(), 1u);
  EXPECT_DOUBLE_EQ(w.returned_at_s(), 4.0);
  const nlohmann::json j = w.json();
  EXPECT_EQ(j["present"], true);
  EXPECT_EQ(j["leader_timeout_s"], 5.0);
}

TEST(LeaderWatch, AWriterNeverMatchedDuringAPresenceIsNoLoss) {
  // Summaries may arrive before DDS reports the match (or through another leader's writer).
  LeaderWatch w(5.0);
  EXPECT_EQ(w.update(0.0, 1, 0, true), Event::kNone);
  EXPECT_EQ(w.update(1.0, 2, 0, true), Event::kNone);
  EXPECT_TRUE(w.present());
}

TEST(LeaderWatch, MatchesAreCheckedAtMostEveryTenthOfASecond) {
  LeaderWatch w(5.0);
  w.update(0.0, 1, 1, true);
  EXPECT_EQ(w.update(0.05, 1, 0, true), Event::kNone);  // too soon after the last check
  EXPECT_EQ(w.update(0.11, 1, 0, true), Event::kGone);
}

}  // namespace
}  // namespace esfleet::follower
