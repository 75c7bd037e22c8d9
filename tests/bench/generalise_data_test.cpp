#include "generalise_data.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace esfleet::bench {
namespace {

/// A FLASER line; pose and odometry fields both `p`, stamp printed with `stamp`.
std::string flaser(const std::vector<float>& ranges, const Pose2& p, const std::string& stamp) {
  std::string line = "FLASER " + std::to_string(ranges.size());
  char buf[64];
  for (float r : ranges) {
    std::snprintf(buf, sizeof buf, " %.3f", r);
    line += buf;
  }
  std::snprintf(buf, sizeof buf, " %.3f %.3f %.5f", p.x, p.y, p.theta);
  line += buf;
  line += buf;
  return line + " " + stamp + " host " + stamp + "\n";
}

/// The raw log of the tests: 8 scans, stamps 1134863807.0 + 0.2 i, odometry (0.5 i, 0, 0),
/// ranges (1 + i, 2, 3, 4) so every scan differs.
std::vector<LaserScan> raw_log() {
  std::string text;
  for (int i = 0; i < 8; ++i) {
    char stamp[32];
    std::snprintf(stamp, sizeof stamp, "%.6f", 1134863807.0 + 0.2 * i);
    text += flaser({1.0f + static_cast<float>(i), 2.0f, 3.0f, 4.0f}, {0.5 * i, 0.0, 0.0}, stamp);
  }
  return read_carmen_text(text, "raw.log");
}

/// Key scans of raw scans `which`, with corrected poses (i, 1, 0.1) and 6-digit stamps.
std::vector<LaserScan> key_log(const std::vector<int>& which, const std::string& stamp) {
  std::string text;
  for (int i : which) {
    text += flaser({1.0f + static_cast<float>(i), 2.0f, 3.0f, 4.0f}, {1.0 * i, 1.0, 0.1}, stamp);
  }
  return read_carmen_text(text, "keys.log");
}

std::string error_of(const std::vector<LaserScan>& keys, const std::vector<LaserScan>& raw) {
  try {
    match_key_scans(keys, raw, "keys.log", "raw.log");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(ParseSeedList, RangesListsAndMixes) {
  EXPECT_EQ(parse_seed_list("1-5"), (std::vector<std::uint64_t>{1, 2, 3, 4, 5}));
  EXPECT_EQ(parse_seed_list("1,2,3"), (std::vector<std::uint64_t>{1, 2, 3}));
  EXPECT_EQ(parse_seed_list("7,1-3,2"), (std::vector<std::uint64_t>{7, 1, 2, 3}));
  EXPECT_EQ(parse_seed_list("4"), (std::vector<std::uint64_t>{4}));
  for (const char* bad : {"", "a", "5-1", "1,,2", "1-", "-3", "1.5"}) {
    EXPECT_THROW(parse_seed_list(bad), std::invalid_argument) << bad;
  }
}

TEST(SubsampleIndices, EveryKthFromTheFirstCappedByMaxCount) {
  EXPECT_EQ(subsample_indices(10, 3), (std::vector<std::size_t>{0, 3, 6, 9}));
  EXPECT_EQ(subsample_indices(10, 1, 3), (std::vector<std::size_t>{0, 1, 2}));
  EXPECT_EQ(subsample_indices(10, 4, 2), (std::vector<std::size_t>{0, 4}));
  EXPECT_TRUE(subsample_indices(0, 2).empty());
  EXPECT_THROW(subsample_indices(10, 0), std::invalid_argument);
}

TEST(MatchKeyScans, FindsEachKeyScansRawScanByItsRanges) {
  const auto raw = raw_log();
  const auto keys = key_log({1, 3, 4, 7}, "1.13486e+09");
  EXPECT_EQ(match_key_scans(keys, raw, "keys.log", "raw.log"),
            (std::vector<std::size_t>{1, 3, 4, 7}));
}

TEST(MatchKeyScans, RefusesMissingAmbiguousOutOfOrderAndWrongStamps) {
  const auto raw = raw_log();
  auto changed = key_log({1, 3}, "1.13486e+09");
  changed[1].ranges[2] = 3.001f;
  const std::string missing = error_of(changed, raw);
  EXPECT_NE(missing.find("keys.log: key scan 1 (FLASER 2): no scan of raw.log"), std::string::npos)
      << missing;

  auto twice = raw;
  twice.push_back(raw[3]);
  const std::string ambiguous = error_of(key_log({3}, "1.13486e+09"), twice);
  EXPECT_NE(ambiguous.find("key scan 0"), std::string::npos) << ambiguous;
  EXPECT_NE(ambiguous.find("ambiguous"), std::string::npos) << ambiguous;

  const std::string order = error_of(key_log({4, 2}, "1.13486e+09"), raw);
  EXPECT_NE(order.find("key scan 1"), std::string::npos) << order;
  EXPECT_NE(order.find("not after"), std::string::npos) << order;

  // 1.13487e+09 is 6193 s away from 1134863807: not the same stamp to 6 digits.
  const std::string stamp = error_of(key_log({2}, "1.13487e+09"), raw);
  EXPECT_NE(stamp.find("6 significant digits"), std::string::npos) << stamp;
}

TEST(MakeKeyScanLog, TrueStampsReferencePosesAndRelationsOnTheRawLog) {
  const auto raw = raw_log();
  // Relations in raw stamps: raw 1 -> 3 (both key scans), raw 1 -> 2 (2 is not a key scan).
  const std::vector<Relation> relations = {{raw[1].stamp, raw[3].stamp, {1.0, 0.0, 0.0}},
                                           {raw[1].stamp, raw[2].stamp, {0.5, 0.0, 0.0}}};
  const GeneraliseLog log =
      make_key_scan_log(key_log({1, 3, 4}, "1.13486e+09"), raw, relations, "keys.log", "raw.log");
  ASSERT_EQ(log.scans.size(), 3u);
  EXPECT_EQ(log.scans[1].stamp, raw[3].stamp);  // not the printed 1.13486e+09
  EXPECT_EQ(log.match_index, (std::vector<std::size_t>{1, 3, 4}));
  ASSERT_TRUE(log.reference[2]);
  EXPECT_EQ(*log.reference[2], (Pose2{4.0, 1.0, 0.1}));
  ASSERT_TRUE(log.relation_ends[1]);
  EXPECT_EQ(log.relation_ends[1]->second, 2u);  // raw index

  // Kept: all three. The first relation is used, the second (its end raw 2 is no key scan) not.
  const std::vector<Pose2> estimate = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  const KeptRelations kr = score_kept_relations(log, {0, 1, 2}, estimate);
  EXPECT_EQ(kr.used, 1u);
  EXPECT_EQ(kr.total, 2u);
  EXPECT_EQ(kr.result.matched, 1u);
  EXPECT_NEAR(kr.result.trans_mean, 0.0, 1e-12);
}

TEST(MakeRawLogWithKeys, ReferencePosesOnlyOnKeyScans) {
  const auto raw = raw_log();
  const GeneraliseLog log = make_raw_log_with_keys(
      raw, {1, 3, 4, 6}, {{1, 1, 0}, {3, 1, 0}, {4, 1, 0}, {6, 1, 0}}, {}, "raw.log");
  ASSERT_EQ(log.reference.size(), 8u);
  EXPECT_FALSE(log.reference[0]);
  EXPECT_TRUE(log.reference[3]);
  // Every 2nd scan: 0 2 4 6 kept, of which 4 and 6 have a reference: one gap-1 relation.
  const std::vector<std::size_t> kept = subsample_indices(8, 2);
  const std::vector<Pose2> estimate = {{0, 0, 0}, {2, 0, 0}, {4, 0, 0}, {6.5, 0, 0}};
  const KeptDerived d = score_kept_derived(log, kept, estimate, {1, 5});
  EXPECT_EQ(d.reference_scans, 2u);
  EXPECT_EQ(d.result.gaps[0].count, 1u);
  EXPECT_EQ(d.result.gaps[1].count, 0u);
  EXPECT_NEAR(d.result.trans_mean, 0.5, 1e-12);
}

TEST(ScoreDerivedFloor, TheRunOnEveryScanAtTheKeptScansScoredAsTheRunIs) {
  // A corrected log of 10 scans 1 m apart; the run on every scan is 5 % long per step.
  std::vector<LaserScan> scans(10);
  std::vector<Pose2> dense;
  for (std::size_t i = 0; i < scans.size(); ++i) {
    scans[i].stamp = static_cast<double>(i);
    scans[i].odometry = Pose2{static_cast<double>(i), 0.0, 0.0};
    dense.push_back({1.05 * static_cast<double>(i), 0.0, 0.0});
  }
  const GeneraliseLog log = make_corrected_log(scans, {}, 0.0, "test", "test.log");
  // Every 3rd scan (0 3 6 9): gap 1 = 3 m, 0.15 m off; gap 2 = 6 m, 0.3 m off.
  const std::vector<std::size_t> kept = subsample_indices(10, 3);
  const std::optional<KeptDerived> floor = score_derived_floor(log, kept, dense, {1, 2});
  ASSERT_TRUE(floor);
  EXPECT_EQ(floor->reference_scans, 4u);
  EXPECT_EQ(floor->result.gaps[0].count, 3u);
  EXPECT_NEAR(floor->result.gaps[0].trans_mean, 0.15, 1e-12);
  EXPECT_NEAR(floor->result.gaps[1].trans_mean, 0.30, 1e-12);
  // A run on fewer scans than the kept ones reach (--max-scans) gives no floor.
  const std::vector<Pose2> short_run(dense.begin(), dense.begin() + 8);
  EXPECT_FALSE(score_derived_floor(log, kept, short_run, {1}));
  // A key-scan log: its scans are raw scans 1, 4 and 8; the floor reads the raw run there.
  GeneraliseLog keys;
  keys.reference = {Pose2{1, 0, 0}, Pose2{4, 0, 0}, Pose2{8, 0, 0}};
  keys.match_index = {1, 4, 8};
  const std::optional<KeptDerived> key_floor = score_derived_floor(keys, {0, 1, 2}, dense, {1});
  ASSERT_TRUE(key_floor);
  EXPECT_NEAR(key_floor->result.trans_mean, (0.15 + 0.2) / 2.0, 1e-12);
}

TEST(ScoreKeptRelations, AnEndOnADroppedScanIsDroppedNotMovedToANeighbour) {
  // 10 scans 0.1 s apart: with the 0.15 s tolerance a neighbour is always in reach.
  std::vector<LaserScan> scans(10);
  for (std::size_t i = 0; i < scans.size(); ++i) {
    scans[i].stamp = 0.1 * static_cast<double>(i);
    scans[i].odometry = Pose2{static_cast<double>(i), 0.0, 0.0};
  }
  const std::vector<Relation> relations = {
      {0.0, 0.5, {5.0, 0.0, 0.0}}, {0.0, 0.4, {4.0, 0.0, 0.0}}, {0.2, 0.8, {6.0, 0.0, 0.0}}};
  const GeneraliseLog log = make_corrected_log(scans, relations, 0.0, "test", "test.log");
  const std::vector<std::size_t> kept = subsample_indices(10, 2);  // 0 2 4 6 8
  std::vector<Pose2> estimate;
  for (std::size_t i : kept) estimate.push_back({1.05 * static_cast<double>(i), 0.0, 0.0});
  const KeptRelations kr = score_kept_relations(log, kept, estimate);
  EXPECT_EQ(kr.used, 2u);  // 0->4 and 2->8; 0->5 dropped
  EXPECT_NEAR(kr.result.trans_mean, (0.2 + 0.3) / 2.0, 1e-12);
  // Derived relations over the kept scans: gap 1 = 2 m apart, each 0.1 m off.
  const KeptDerived d = score_kept_derived(log, kept, estimate, {1});
  EXPECT_EQ(d.reference_scans, 5u);
  EXPECT_EQ(d.result.count, 4u);
  EXPECT_NEAR(d.result.trans_mean, 0.1, 1e-12);
}

TEST(KeepEveryBeam, ACoarserLaserOverTheSameFieldOfView) {
  LaserScan s;
  s.angle_min = -1.0f;
  s.angle_increment = 0.25f;
  s.ranges = {1.0f, 2.0f, 3.0f, 4.0f, 5.0f, 6.0f, 7.0f, 8.0f, 9.0f};  // -1 ... +1 rad
  s.odometry = Pose2{1.0, 2.0, 0.5};
  const LaserScan two = keep_every_beam(s, 2);
  EXPECT_EQ(two.ranges, (std::vector<float>{1.0f, 3.0f, 5.0f, 7.0f, 9.0f}));
  EXPECT_FLOAT_EQ(two.angle_increment, 0.5f);
  EXPECT_FLOAT_EQ(two.angle(4), 1.0f);  // the last beam keeps its direction
  EXPECT_EQ(two.odometry, s.odometry);
  EXPECT_EQ(keep_every_beam(s, 3).ranges, (std::vector<float>{1.0f, 4.0f, 7.0f}));
  EXPECT_EQ(keep_every_beam(s, 1).ranges, s.ranges);
  EXPECT_EQ(keep_every_beam(s, 0).ranges, s.ranges);
}

TEST(SlamInput, LaserOnlyHasNoOdometryAndNoisyOdometryIsNeverTheReference) {
  std::vector<LaserScan> scans(20);
  for (std::size_t i = 0; i < scans.size(); ++i) {
    scans[i].stamp = static_cast<double>(i);
    scans[i].ranges = {1.0f, 2.0f};
    scans[i].odometry = Pose2{0.3 * static_cast<double>(i), 0.05 * static_cast<double>(i), 0.02};
  }
  const GeneraliseLog log = make_corrected_log(scans, {}, 0.0, "test", "test.log");
  const auto kept = subsample_indices(scans.size(), 3);
  const OdometryNoise noise;
  for (const LaserScan& s : slam_input(log, kept, GeneraliseMode::kLaserOnly, noise, 1)) {
    EXPECT_FALSE(s.odometry);
  }
  const auto a = slam_input(log, kept, GeneraliseMode::kNoisyOdometry, noise, 7);
  const auto b = slam_input(log, kept, GeneraliseMode::kNoisyOdometry, noise, 7);
  const auto c = slam_input(log, kept, GeneraliseMode::kNoisyOdometry, noise, 8);
  ASSERT_EQ(a.size(), kept.size());
  for (std::size_t j = 1; j < a.size(); ++j) {  // the first pose is the path's start
    ASSERT_TRUE(a[j].odometry);
    EXPECT_NE(*a[j].odometry, *log.reference[kept[j]]) << "scan " << kept[j];
    EXPECT_EQ(*a[j].odometry, *b[j].odometry) << "same seed, same noise";
    EXPECT_NE(*a[j].odometry, *c[j].odometry) << "another seed, other noise";
    EXPECT_EQ(a[j].stamp, scans[kept[j]].stamp);
  }
  // The noise follows the kept scans' motion: seeded like noisy_odometry of that subpath.
  std::vector<Pose2> source;
  for (std::size_t i : kept) source.push_back(*scans[i].odometry);
  const auto expected = noisy_odometry(source, noise, 7);
  for (std::size_t j = 0; j < a.size(); ++j) EXPECT_EQ(*a[j].odometry, expected[j]);
}

}  // namespace
}  // namespace esfleet::bench
