#include "esfleet/core/relations.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace esfleet {
namespace {

namespace fs = std::filesystem;

constexpr double kEps = 1e-12;

/// Relations between consecutive poses (and every `stride`-th pair further apart), computed
/// from `truth` itself: the ground truth for a perfect estimate.
std::vector<Relation> relations_from(const std::vector<TimedPose>& truth, std::size_t stride) {
  std::vector<Relation> out;
  for (std::size_t i = 0; i + 1 < truth.size(); ++i) {
    out.push_back(
        {truth[i].stamp, truth[i + 1].stamp, truth[i + 1].pose.relative_to(truth[i].pose)});
    if (i + stride < truth.size()) {
      out.push_back({truth[i].stamp, truth[i + stride].stamp,
                     truth[i + stride].pose.relative_to(truth[i].pose)});
    }
  }
  return out;
}

/// A wandering robot path, one pose every 0.2 s from t = 100.
std::vector<TimedPose> random_walk(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> step(0.0, 0.5), turn(-0.4, 0.4);
  std::vector<TimedPose> out;
  Pose2 p{3.0, -1.0, 0.3};
  for (std::size_t i = 0; i < n; ++i) {
    out.push_back({100.0 + 0.2 * static_cast<double>(i), p});
    p = p.compose({step(rng), 0.1 * turn(rng), turn(rng)});
  }
  return out;
}

/// Forward motion along +x with the given x positions, one pose per second from t = 0.
std::vector<TimedPose> along_x(const std::vector<double>& xs) {
  std::vector<TimedPose> out;
  for (std::size_t i = 0; i < xs.size(); ++i)
    out.push_back({static_cast<double>(i), {xs[i], 0, 0}});
  return out;
}

TEST(EvaluateRelations, PerfectTrajectoryHasZeroError) {
  const auto truth = random_walk(300, 1);
  const auto relations = relations_from(truth, 25);
  const RelationsResult r = evaluate_relations(truth, relations);
  EXPECT_EQ(r.total, relations.size());
  EXPECT_EQ(r.matched, relations.size());
  EXPECT_NEAR(r.trans_mean, 0.0, 1e-9);
  EXPECT_NEAR(r.trans_std, 0.0, 1e-9);
  EXPECT_NEAR(r.rot_mean_deg, 0.0, 1e-9);
  EXPECT_NEAR(r.rot_std_deg, 0.0, 1e-9);
}

TEST(EvaluateRelations, GlobalRigidMotionOfTheEstimateDoesNotMatter) {
  // The metric only looks at relative poses: moving the whole estimate changes nothing.
  const auto truth = random_walk(200, 2);
  auto moved = truth;
  const Pose2 shift{-40.0, 12.5, 2.0};
  for (auto& p : moved) p.pose = shift.compose(p.pose);
  const RelationsResult r = evaluate_relations(moved, relations_from(truth, 10));
  EXPECT_EQ(r.matched, r.total);
  EXPECT_NEAR(r.trans_mean, 0.0, 1e-9);
  EXPECT_NEAR(r.rot_mean_deg, 0.0, 1e-9);
}

TEST(EvaluateRelations, ScaledTranslationGivesTheScaleError) {
  // Ground truth: 3 relations of 1 m forward. The estimate moves 1.1 m each time, so
  // est = (1.1, 0, 0), err = inv((1, 0, 0))·est = (0.1, 0, 0): every error is 0.1 m.
  // mean = 0.1, population std = 0; no rotation error.
  const auto estimate = along_x({0.0, 1.1, 2.2, 3.3});
  const std::vector<Relation> relations = {{0, 1, {1, 0, 0}}, {1, 2, {1, 0, 0}}, {2, 3, {1, 0, 0}}};
  const RelationsResult r = evaluate_relations(estimate, relations);
  EXPECT_EQ(r.matched, 3u);
  EXPECT_EQ(r.total, 3u);
  EXPECT_NEAR(r.trans_mean, 0.1, kEps);
  EXPECT_NEAR(r.trans_std, 0.0, kEps);
  EXPECT_NEAR(r.rot_mean_deg, 0.0, kEps);
  EXPECT_NEAR(r.rot_std_deg, 0.0, kEps);
}

TEST(EvaluateRelations, StdIsThePopulationStd) {
  // Steps of 1.1 m and 1.3 m against relations of 1 m: errors 0.1 and 0.3.
  // mean = 0.2; population std = sqrt(((0.1-0.2)^2 + (0.3-0.2)^2) / 2) = 0.1
  // (the sample std would be 0.1 * sqrt(2) = 0.1414).
  const auto estimate = along_x({0.0, 1.1, 2.4});
  const std::vector<Relation> relations = {{0, 1, {1, 0, 0}}, {1, 2, {1, 0, 0}}};
  const RelationsResult r = evaluate_relations(estimate, relations);
  EXPECT_EQ(r.matched, 2u);
  EXPECT_NEAR(r.trans_mean, 0.2, kEps);
  EXPECT_NEAR(r.trans_std, 0.1, kEps);
}

TEST(EvaluateRelations, WorstErrorAndOutliersAgainstTheThresholds) {
  // Errors 0.1, 0.6 and 0.2 m; one relation also off by 20 degrees.
  const auto estimate = along_x({0.0, 1.1, 2.7, 3.9});
  const std::vector<Relation> relations = {
      {0, 1, {1, 0, 0}}, {1, 2, {1, 0, 0}}, {2, 3, {1, 0, deg_to_rad(20.0)}}};
  RelationsOptions options;
  options.outlier_trans = 0.5;
  options.outlier_rot_deg = 10.0;
  RelationsResult r = evaluate_relations(estimate, relations, options);
  EXPECT_NEAR(r.trans_max, 0.6, 1e-9);
  EXPECT_EQ(r.outliers, 2u);  // 0.6 m, and the 20 degree one
  options.outlier_rot_deg = 30.0;
  r = evaluate_relations(estimate, relations, options);
  EXPECT_EQ(r.outliers, 1u);
}

TEST(EvaluateRelations, HeadingBiasTurnsATranslationIntoAChord) {
  // The truth says "1 m straight ahead"; the estimate's heading is off by 60 deg, so it went
  // 1 m at 60 deg: est = (cos 60°, sin 60°, 0) = (0.5, 0.866, 0),
  // err = est - (1, 0, 0) = (-0.5, 0.866, 0), |err| = 2 sin(30°) = 1 (an equilateral triangle).
  const double a = deg_to_rad(60.0);
  const std::vector<TimedPose> estimate = {{0, {0, 0, 0}}, {1, {std::cos(a), std::sin(a), 0}}};
  const RelationsResult r = evaluate_relations(estimate, {{0, 1, {1, 0, 0}}});
  EXPECT_EQ(r.matched, 1u);
  EXPECT_NEAR(r.trans_mean, 1.0, kEps);
  EXPECT_NEAR(r.rot_mean_deg, 0.0, kEps);
}

TEST(EvaluateRelations, TranslationErrorIsMeasuredInTheRelationsFrame) {
  // rel = (1, 0, 90°), est = (1, 0.5, 90°): err = inv(rel)·est has translation
  // R(-90°)·(est.xy - rel.xy) = R(-90°)·(0, 0.5) = (0.5, 0); its norm is 0.5, rotation error 0.
  const double q = deg_to_rad(90.0);
  const std::vector<TimedPose> estimate = {{0, {2, 2, q}},
                                           {1, Pose2{2, 2, q}.compose({1, 0.5, q})}};
  const RelationsResult r = evaluate_relations(estimate, {{0, 1, {1, 0, q}}});
  EXPECT_EQ(r.matched, 1u);
  EXPECT_NEAR(r.trans_mean, 0.5, kEps);
  EXPECT_NEAR(r.rot_mean_deg, 0.0, 1e-9);
}

TEST(EvaluateRelations, RotationErrorIsAbsoluteAndInDegrees) {
  // Turning in place. Truth: +10° then +10°. Estimate: +8° (error -2°) then +14° (error +4°).
  // Absolute errors 2° and 4°: mean 3°, population std 1° (a signed mean would be 1°).
  const std::vector<TimedPose> estimate = {
      {0, {0, 0, 0}}, {1, {0, 0, deg_to_rad(8)}}, {2, {0, 0, deg_to_rad(22)}}};
  const std::vector<Relation> relations = {{0, 1, {0, 0, deg_to_rad(10)}},
                                           {1, 2, {0, 0, deg_to_rad(10)}}};
  const RelationsResult r = evaluate_relations(estimate, relations);
  EXPECT_EQ(r.matched, 2u);
  EXPECT_NEAR(r.rot_mean_deg, 3.0, 1e-9);
  EXPECT_NEAR(r.rot_std_deg, 1.0, 1e-9);
  EXPECT_NEAR(r.trans_mean, 0.0, kEps);
}

TEST(EvaluateRelations, RotationErrorWrapsAroundPi) {
  // Truth turns +179°, the estimate turns -179° (= +181°): the error is 2°, not 358°.
  const std::vector<TimedPose> estimate = {{0, {0, 0, 0}}, {1, {0, 0, deg_to_rad(-179)}}};
  const RelationsResult r = evaluate_relations(estimate, {{0, 1, {0, 0, deg_to_rad(179)}}});
  EXPECT_NEAR(r.rot_mean_deg, 2.0, 1e-9);
}

TEST(EvaluateRelations, TimeOffsetMapsRelationStampsOntoTrajectoryStamps) {
  // Relation stamp = trajectory stamp + 1000 s.
  const auto estimate = along_x({0.0, 1.1, 2.2, 3.3});
  const std::vector<Relation> relations = {{1000, 1001, {1, 0, 0}}, {1001, 1002, {1, 0, 0}}};

  RelationsOptions options;
  options.time_offset = 1000.0;
  const RelationsResult r = evaluate_relations(estimate, relations, options);
  EXPECT_EQ(r.matched, 2u);
  EXPECT_NEAR(r.trans_mean, 0.1, kEps);

  const RelationsResult without = evaluate_relations(estimate, relations);
  EXPECT_EQ(without.matched, 0u);
  EXPECT_EQ(without.total, 2u);
  EXPECT_EQ(without.trans_mean, 0.0);
  EXPECT_EQ(without.trans_std, 0.0);
  EXPECT_EQ(without.rot_mean_deg, 0.0);
  EXPECT_EQ(without.rot_std_deg, 0.0);
}

TEST(EvaluateRelations, StampsOutsideTheToleranceAreSkipped) {
  // Poses at t = 0, 1, 2, 3 (x = 0, 1.1, 2.2, 3.3); tolerance 0.25 s (exact in binary).
  const auto estimate = along_x({0.0, 1.1, 2.2, 3.3});
  RelationsOptions options;
  options.tolerance = 0.25;
  const std::vector<Relation> relations = {
      {0.1, 1.2, {1, 0, 0}},    // both within 0.2 s: matched, error 0.1
      {1.25, 2.0, {1, 0, 0}},   // t1 exactly at the tolerance: matched (inclusive), error 0.1
      {1.0, 2.3, {1, 0, 0}},    // t2 is 0.3 s from the nearest pose: skipped
      {-0.5, 1.0, {1, 0, 0}},   // t1 before the trajectory by 0.5 s: skipped
      {2.0, 3.26, {1, 0, 0}}};  // t2 after the trajectory by 0.26 s: skipped
  const RelationsResult r = evaluate_relations(estimate, relations, options);
  EXPECT_EQ(r.total, 5u);
  EXPECT_EQ(r.matched, 2u);
  EXPECT_NEAR(r.trans_mean, 0.1, kEps);
  EXPECT_NEAR(r.trans_std, 0.0, kEps);

  options.tolerance = 0.0;  // only exact stamps match
  EXPECT_EQ(evaluate_relations(estimate, relations, options).matched, 0u);
  EXPECT_EQ(evaluate_relations(estimate, {{1.0, 2.0, {1, 0, 0}}}, options).matched, 1u);
}

TEST(EvaluateRelations, PicksTheNearestPose) {
  // Poses at t = 0, 1, 2 with x = 0, 1, 5. A relation from t = 0.1 to t = 1.4 must use the
  // pose at t = 1 (0.4 s away), not t = 2 (0.6 s away): est = 1 m, error 0 against a 1 m
  // relation (with t = 2 it would be 4 m).
  const auto estimate = along_x({0.0, 1.0, 5.0});
  RelationsOptions options;
  options.tolerance = 1.0;
  EXPECT_NEAR(evaluate_relations(estimate, {{0.1, 1.4, {1, 0, 0}}}, options).trans_mean, 0.0, kEps);
  EXPECT_NEAR(evaluate_relations(estimate, {{0.1, 1.6, {1, 0, 0}}}, options).trans_mean, 4.0, kEps);
  // Exactly half way between t = 1 and t = 2: the earlier pose wins.
  EXPECT_NEAR(evaluate_relations(estimate, {{0.0, 1.5, {1, 0, 0}}}, options).trans_mean, 0.0, kEps);
}

TEST(EvaluateRelations, UnsortedTrajectoryGivesTheSameResult) {
  const auto truth = random_walk(150, 3);
  auto estimate = truth;
  std::mt19937 rng(4);
  std::normal_distribution<double> noise(0.0, 0.02);
  for (auto& p : estimate) p.pose = p.pose.compose({noise(rng), noise(rng), noise(rng)});
  const auto relations = relations_from(truth, 7);

  const RelationsResult sorted = evaluate_relations(estimate, relations);
  std::shuffle(estimate.begin(), estimate.end(), rng);
  ASSERT_FALSE(
      std::is_sorted(estimate.begin(), estimate.end(),
                     [](const TimedPose& a, const TimedPose& b) { return a.stamp < b.stamp; }));
  const RelationsResult shuffled = evaluate_relations(estimate, relations);

  EXPECT_EQ(sorted.matched, relations.size());
  EXPECT_GT(sorted.trans_mean, 0.001);  // the noise must show, or the comparison proves nothing
  EXPECT_EQ(shuffled.matched, sorted.matched);
  EXPECT_DOUBLE_EQ(shuffled.trans_mean, sorted.trans_mean);
  EXPECT_DOUBLE_EQ(shuffled.trans_std, sorted.trans_std);
  EXPECT_DOUBLE_EQ(shuffled.rot_mean_deg, sorted.rot_mean_deg);
  EXPECT_DOUBLE_EQ(shuffled.rot_std_deg, sorted.rot_std_deg);
}

TEST(EvaluateRelations, EmptyInputsMatchNothing) {
  const RelationsResult no_trajectory = evaluate_relations({}, {{0, 1, {1, 0, 0}}});
  EXPECT_EQ(no_trajectory.matched, 0u);
  EXPECT_EQ(no_trajectory.total, 1u);
  const RelationsResult no_relations = evaluate_relations(along_x({0, 1}), {});
  EXPECT_EQ(no_relations.matched, 0u);
  EXPECT_EQ(no_relations.total, 0u);
}

TEST(EvaluateRelations, RejectsInvalidOptionsAndStamps) {
  const auto estimate = along_x({0, 1});
  RelationsOptions negative;
  negative.tolerance = -0.1;
  EXPECT_THROW(evaluate_relations(estimate, {}, negative), std::invalid_argument);
  RelationsOptions nan_offset;
  nan_offset.time_offset = std::nan("");
  EXPECT_THROW(evaluate_relations(estimate, {}, nan_offset), std::invalid_argument);
  EXPECT_THROW(evaluate_relations({{std::nan(""), {}}}, {}), std::invalid_argument);
}

/// A fresh directory per test (tests may run in parallel processes under CTest).
class ReadRelationsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("esfleet_relations_" + std::string(info->name()) + "_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string write_text(const std::string& name, const std::string& text) const {
    const std::string file = (dir_ / name).string();
    std::ofstream(file, std::ios::binary) << text;
    return file;
  }

  static std::string read_error(const std::string& file) {
    try {
      read_relations(file);
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    ADD_FAILURE() << "read_relations(" << file << ") did not throw";
    return {};
  }

  fs::path dir_;
};

TEST_F(ReadRelationsTest, ReadsTheRealFormats) {
  // Lines from fr079.relations and mit-csail.relations (which has a double space).
  const auto relations = read_relations(ESFLEET_TEST_DATA_DIR "/relations/excerpt.relations");
  ASSERT_EQ(relations.size(), 5u);
  EXPECT_EQ(relations[0].t1, 1216.630413);
  EXPECT_EQ(relations[0].t2, 1217.490267);
  EXPECT_EQ(relations[0].rel, (Pose2{0.407950, -0.016330, -0.069620}));
  EXPECT_EQ(relations[2].t1, 1215.570657);
  EXPECT_EQ(relations[3].t1, 1134864645.90321);
  EXPECT_EQ(relations[3].t2, 1134864646.32420);
  EXPECT_EQ(relations[4].rel, (Pose2{0.31166, 0.01278, 0.23840}));
}

TEST_F(ReadRelationsTest, IgnoresZRollPitchAndWrapsYaw) {
  const auto relations = read_relations(write_text("a.relations", "1 2 0.5 -0.25 9 8 7 4\n"));
  ASSERT_EQ(relations.size(), 1u);
  EXPECT_EQ(relations[0].rel.x, 0.5);
  EXPECT_EQ(relations[0].rel.y, -0.25);
  EXPECT_NEAR(relations[0].rel.theta, 4.0 - 2.0 * std::numbers::pi, 1e-15);
}

TEST_F(ReadRelationsTest, MalformedLinesNameFileAndLine) {
  const std::string good = "1 2 0.5 0 0 0 0 0.1\n";
  const std::string few = write_text("few.relations", good + good + "1 2 0.5 0 0 0 0\n");
  EXPECT_EQ(read_error(few), few + ":3: expected 8 fields (t1 t2 x y z roll pitch yaw), got 7");

  const std::string bad = write_text("bad.relations", "# comment\n\n" + good + "1 2 x 0 0 0 0 0\n");
  const std::string message = read_error(bad);
  EXPECT_NE(message.find(bad + ":4: "), std::string::npos) << message;
  EXPECT_NE(message.find("field 3"), std::string::npos) << message;

  EXPECT_NE(read_error(write_text("nan.relations", "1 nan 0 0 0 0 0 0\n")).find(":1: "),
            std::string::npos);
  EXPECT_NE(read_error(write_text("many.relations", good + "1 2 0 0 0 0 0 0 0\n")).find(":2: "),
            std::string::npos);
}

TEST_F(ReadRelationsTest, MissingFileErrorNamesThePath) {
  const std::string missing = (dir_ / "missing.relations").string();
  const std::string message = read_error(missing);
  EXPECT_NE(message.find(missing), std::string::npos) << message;
}

TEST_F(ReadRelationsTest, ReadRelationsFeedTheMetric) {
  // End to end on the fixture's fr079 lines: a trajectory built from the relations themselves
  // (chained 1216.63 -> 1217.49 -> 1218.34, stamps shifted by the fr079 offset) scores zero on
  // the two chained lines; the third line's first stamp (1215.57) has no pose and is skipped.
  const auto relations = read_relations(ESFLEET_TEST_DATA_DIR "/relations/excerpt.relations");
  const std::vector<Relation> fr079(relations.begin(), relations.begin() + 3);
  const double offset = 1211.45;
  const Pose2 p0{1.0, 2.0, 0.5};
  const Pose2 p1 = p0.compose(fr079[0].rel);
  const Pose2 p2 = p1.compose(fr079[1].rel);
  const std::vector<TimedPose> estimate = {
      {fr079[0].t1 - offset, p0}, {fr079[0].t2 - offset, p1}, {fr079[1].t2 - offset, p2}};
  RelationsOptions options;
  options.time_offset = offset;
  const RelationsResult r = evaluate_relations(estimate, fr079, options);
  EXPECT_EQ(r.total, 3u);
  EXPECT_EQ(r.matched, 2u);
  EXPECT_NEAR(r.trans_mean, 0.0, 1e-9);
  EXPECT_NEAR(r.rot_mean_deg, 0.0, 1e-9);
}

// --- match_relation_ends ---

TEST(MatchRelationEnds, GivesTheIndicesOfTheNearestStampsInTheCallersOrder) {
  // Unsorted stamps: indices refer to the list as given.
  const std::vector<double> stamps = {3.0, 1.0, 2.0, 0.0};
  const std::vector<Relation> relations = {{1.04, 2.96, {}}, {0.0, 2.0, {}}};
  const auto ends = match_relation_ends(stamps, relations);
  ASSERT_EQ(ends.size(), 2u);
  ASSERT_TRUE(ends[0]);
  EXPECT_EQ(ends[0]->first, 1u);
  EXPECT_EQ(ends[0]->second, 0u);
  ASSERT_TRUE(ends[1]);
  EXPECT_EQ(ends[1]->first, 3u);
  EXPECT_EQ(ends[1]->second, 2u);
}

TEST(MatchRelationEnds, AnEndOutsideTheToleranceMatchesNothing) {
  const std::vector<double> stamps = {0.0, 1.0};
  RelationsOptions options;
  options.time_offset = 10.0;  // relation stamp = scan stamp + 10
  const std::vector<Relation> relations = {{10.0, 11.14, {}}, {10.0, 11.16, {}}};
  const auto ends = match_relation_ends(stamps, relations, options);
  ASSERT_TRUE(ends[0]);  // 0.14 s off: within the 0.15 s tolerance
  EXPECT_EQ(ends[0]->second, 1u);
  EXPECT_FALSE(ends[1]);
  EXPECT_THROW(match_relation_ends({std::nan("")}, relations), std::invalid_argument);
}

TEST(MatchRelationEnds, AgreesWithEvaluateRelations) {
  // The ends it gives, used directly, give the score evaluate_relations computes.
  const auto truth = random_walk(200, 3);
  auto relations = relations_from(truth, 7);
  auto estimate = truth;
  for (std::size_t i = 0; i < estimate.size(); ++i) {
    const double t = static_cast<double>(i);
    estimate[i].pose = estimate[i].pose.compose({0.01 * std::sin(0.3 * t), 0.0, 0.002 * t});
  }
  std::vector<double> stamps;
  for (const auto& p : estimate) stamps.push_back(p.stamp);
  const auto ends = match_relation_ends(stamps, relations);
  double sum = 0.0;
  for (std::size_t r = 0; r < relations.size(); ++r) {
    ASSERT_TRUE(ends[r]);
    const Pose2 est = estimate[ends[r]->second].pose.relative_to(estimate[ends[r]->first].pose);
    const Pose2 err = est.relative_to(relations[r].rel);
    sum += std::hypot(err.x, err.y);
  }
  const auto expected = evaluate_relations(estimate, relations);
  EXPECT_NEAR(sum / static_cast<double>(relations.size()), expected.trans_mean, 1e-12);
}

// --- evaluate_derived_relations ---

std::vector<Pose2> poses_of(const std::vector<TimedPose>& path) {
  std::vector<Pose2> out;
  for (const auto& p : path) out.push_back(p.pose);
  return out;
}

TEST(DerivedRelations, PerfectEstimateInAnyFrameHasZeroError) {
  const auto reference = poses_of(random_walk(150, 4));
  std::vector<Pose2> estimate;
  const Pose2 frame{-4.0, 7.0, 2.5};  // the SLAM's frame is arbitrary
  for (const Pose2& p : reference) estimate.push_back(frame.compose(p));
  const auto r = evaluate_derived_relations(reference, estimate, {1, 5, 20, 100});
  EXPECT_EQ(r.count, 149u + 145u + 130u + 50u);
  EXPECT_NEAR(r.trans_mean, 0.0, 1e-9);
  EXPECT_NEAR(r.rot_mean_deg, 0.0, 1e-9);
  ASSERT_EQ(r.gaps.size(), 4u);
  EXPECT_EQ(r.gaps[0].gap, 1u);
  EXPECT_EQ(r.gaps[0].count, 149u);
  EXPECT_EQ(r.gaps[3].gap, 100u);
  EXPECT_EQ(r.gaps[3].count, 50u);
}

TEST(DerivedRelations, ScaledPathGivesTheScaleErrorPerGap) {
  // Reference at x = 0..4 along +x; the estimate 10 % longer: a gap of g metres is off by 0.1 g.
  std::vector<Pose2> reference, estimate;
  for (int i = 0; i < 5; ++i) {
    reference.push_back({1.0 * i, 0.0, 0.0});
    estimate.push_back({1.1 * i, 0.0, 0.0});
  }
  const auto r = evaluate_derived_relations(reference, estimate, {1, 2, 10});
  ASSERT_EQ(r.gaps.size(), 3u);
  EXPECT_EQ(r.gaps[0].count, 4u);
  EXPECT_NEAR(r.gaps[0].trans_mean, 0.1, 1e-12);
  EXPECT_EQ(r.gaps[1].count, 3u);
  EXPECT_NEAR(r.gaps[1].trans_mean, 0.2, 1e-12);
  EXPECT_EQ(r.gaps[2].count, 0u);  // longer than the path: no relation, not an error
  EXPECT_EQ(r.gaps[2].trans_mean, 0.0);
  EXPECT_EQ(r.count, 7u);
  EXPECT_NEAR(r.trans_mean, (4 * 0.1 + 3 * 0.2) / 7.0, 1e-12);
  EXPECT_NEAR(r.trans_max, 0.2, 1e-12);
  EXPECT_NEAR(r.rot_mean_deg, 0.0, 1e-12);
}

TEST(DerivedRelations, OneTurnedPoseGivesARotationAndAChordError) {
  // Reference x = 0..3 heading 0; the estimate's pose 2 is turned by a = 0.1 rad. Gap 1:
  // 0->1 exact; 1->2 rotation a, no translation; 2->3 rotation a and translation 2 sin(a/2)
  // (the step seen from the turned pose, a chord of the unit circle).
  const double a = 0.1;
  const std::vector<Pose2> reference = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}};
  const std::vector<Pose2> estimate = {{0, 0, 0}, {1, 0, 0}, {2, 0, a}, {3, 0, 0}};
  const auto r = evaluate_derived_relations(reference, estimate, {1});
  EXPECT_EQ(r.count, 3u);
  EXPECT_NEAR(r.trans_mean, 2.0 * std::sin(a / 2.0) / 3.0, 1e-12);
  EXPECT_NEAR(r.trans_max, 2.0 * std::sin(a / 2.0), 1e-12);
  EXPECT_NEAR(r.rot_mean_deg, rad_to_deg(2.0 * a / 3.0), 1e-9);
  EXPECT_NEAR(r.gaps[0].rot_mean_deg, r.rot_mean_deg, 1e-12);
}

TEST(DerivedRelations, RejectsMismatchedInputsAndAZeroGap) {
  const std::vector<Pose2> two = {{0, 0, 0}, {1, 0, 0}};
  const std::vector<Pose2> three = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  EXPECT_THROW(evaluate_derived_relations(two, three, {1}), std::invalid_argument);
  EXPECT_THROW(evaluate_derived_relations(two, two, {0}), std::invalid_argument);
  const std::vector<Pose2> bad = {{0, 0, 0}, {std::nan(""), 0, 0}};
  EXPECT_THROW(evaluate_derived_relations(two, bad, {1}), std::invalid_argument);
  const auto empty = evaluate_derived_relations({}, {}, {1, 5});
  EXPECT_EQ(empty.count, 0u);
  EXPECT_EQ(empty.trans_mean, 0.0);
}

/// `path` moved as a whole: turned by `angle` about the origin, scaled by `scale`, shifted.
std::vector<TimedPose> moved(const std::vector<TimedPose>& path, double angle, double scale,
                             double dx, double dy) {
  std::vector<TimedPose> out;
  const double c = std::cos(angle), s = std::sin(angle);
  for (const TimedPose& p : path) {
    out.push_back({p.stamp,
                   {scale * (c * p.pose.x - s * p.pose.y) + dx,
                    scale * (s * p.pose.x + c * p.pose.y) + dy, p.pose.theta + angle}});
  }
  return out;
}

TEST(EvaluateAbsolute, AnEstimateInAnyFrameHasZeroError) {
  const auto truth = random_walk(300, 3);
  const auto r = evaluate_absolute(moved(truth, 2.1, 1.0, -40.0, 7.5), truth);
  EXPECT_EQ(r.matched, 300u);
  EXPECT_EQ(r.total, 300u);
  EXPECT_NEAR(r.rms, 0.0, 1e-9);
  EXPECT_NEAR(r.max, 0.0, 1e-9);
  EXPECT_NEAR(r.scale, 1.0, 1e-12);
}

TEST(EvaluateAbsolute, AShrunkMapIsScaledBackAndItsErrorGrowsWithItsSize) {
  const auto truth = random_walk(300, 4);
  // 1 % smaller: the rigid fit leaves errors of 1 % of each pose's distance from the centroid.
  const auto r = evaluate_absolute(moved(truth, -0.7, 0.99, 3.0, 1.0), truth);
  EXPECT_NEAR(r.scale, 1.0 / 0.99, 1e-9);
  EXPECT_NEAR(r.rms_scaled, 0.0, 1e-9);
  double cx = 0, cy = 0;
  for (const auto& p : truth) {
    cx += p.pose.x / 300;
    cy += p.pose.y / 300;
  }
  double sq = 0;
  for (const auto& p : truth) sq += std::pow(std::hypot(p.pose.x - cx, p.pose.y - cy), 2) / 300;
  EXPECT_NEAR(r.rms, 0.01 * std::sqrt(sq), 1e-9);
}

TEST(EvaluateAbsolute, OneMisplacedPoseOfASymmetricPathIsItsWholeError) {
  // A square of four poses and its centre; the estimate has the centre 0.5 m off. The fit
  // moves the estimate by a fifth of that (centroids), turns nothing (the square is symmetric
  // about the displacement's line), and leaves 0.4 m at the centre, 0.1 m at each corner.
  std::vector<TimedPose> truth = {
      {0, {1, 1, 0}}, {1, {-1, 1, 0}}, {2, {-1, -1, 0}}, {3, {1, -1, 0}}, {4, {0, 0, 0}}};
  std::vector<TimedPose> estimate = truth;
  estimate[4].pose.x += 0.5;
  const auto r = evaluate_absolute(estimate, truth);
  EXPECT_NEAR(r.max, 0.4, 1e-9);
  EXPECT_NEAR(r.mean, (0.4 + 4 * 0.1) / 5, 1e-9);
  EXPECT_NEAR(r.rms, std::sqrt((0.16 + 4 * 0.01) / 5), 1e-9);
}

TEST(EvaluateAbsolute, ReferencePosesWithoutATrajectoryPoseNearbyAreNotMatched) {
  const auto truth = random_walk(50, 5);  // a pose every 0.2 s
  std::vector<TimedPose> reference = truth;
  for (auto& p : reference) p.stamp += 0.05;  // within the tolerance: all match
  EXPECT_EQ(evaluate_absolute(truth, reference).matched, 50u);
  EXPECT_EQ(evaluate_absolute(truth, reference, 0.04).matched, 0u);
  const auto none = evaluate_absolute(truth, reference, 0.04);
  EXPECT_EQ(none.total, 50u);
  EXPECT_EQ(none.rms, 0.0);
  EXPECT_EQ(none.scale, 1.0);
  reference.push_back({1000.0, {0, 0, 0}});  // after the run
  EXPECT_EQ(evaluate_absolute(truth, reference).matched, 50u);
}

TEST(EvaluateAbsolute, RejectsABadToleranceAndNonFiniteInput) {
  const auto truth = random_walk(10, 6);
  EXPECT_THROW(evaluate_absolute(truth, truth, -1.0), std::invalid_argument);
  EXPECT_THROW(evaluate_absolute(truth, truth, std::nan("")), std::invalid_argument);
  auto bad = truth;
  bad[3].pose.y = std::nan("");
  EXPECT_THROW(evaluate_absolute(truth, bad), std::invalid_argument);
  bad = truth;
  bad[2].stamp = std::numeric_limits<double>::infinity();
  EXPECT_THROW(evaluate_absolute(bad, truth), std::invalid_argument);
}

TEST(StampOrder, CountsStampsNotAfterTheOneBefore) {
  EXPECT_EQ(stamp_order({1.0, 1.1, 1.2, 5.0}).not_after, 0u);
  const StampOrder bad = stamp_order({1.0, 2.0, 2.0, 3.0, 0.5, 4.0});
  EXPECT_EQ(bad.not_after, 2u);  // the repeated 2.0 and the 0.5
  EXPECT_EQ(bad.first, 2u);
  EXPECT_EQ(stamp_order({}).not_after, 0u);
  EXPECT_EQ(stamp_order({7.0}).not_after, 0u);
}

}  // namespace
}  // namespace esfleet
