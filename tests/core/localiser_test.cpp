// The follower's localiser on scans ray-cast in synthetic rooms whose true poses the test knows:
// global and hinted localisation, a wrong hint, a symmetric room (must not guess), kidnapping.

#include "esfleet/core/localiser.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "synthetic_world.hpp"

namespace esfleet {
namespace {

using testing::asymmetric_room;
using testing::make_scan;
using testing::map_of;
using testing::Segment;

/// Straight drive from `from`, `n` scans `step` metres apart, then the same back.
std::vector<Pose2> drive(const Pose2& from, int n, double step) {
  std::vector<Pose2> path;
  for (int i = 0; i < n; ++i) {
    path.push_back({from.x + i * step * std::cos(from.theta),
                    from.y + i * step * std::sin(from.theta), from.theta});
  }
  return path;
}

bool near(const Pose2& a, const Pose2& b, double xy, double theta_deg) {
  return std::hypot(a.x - b.x, a.y - b.y) <= xy &&
         std::abs(normalize_angle(a.theta - b.theta)) <= theta_deg * std::numbers::pi / 180.0;
}

/// A plain 10 x 6 m rectangle with two identical pillars placed point-symmetrically: every
/// pose has a twin rotated by 180 degrees about the centre, which explains every scan equally
/// well.
std::vector<Segment> twin_pillar_room() {
  return {
      {0, 0, 10, 0}, {10, 0, 10, 6}, {10, 6, 0, 6}, {0, 6, 0, 0},
      {2, 1, 3, 1},  {3, 1, 3, 2},   {3, 2, 2, 2},  {2, 2, 2, 1},  // pillar
      {7, 4, 8, 4},  {8, 4, 8, 5},   {8, 5, 7, 5},  {7, 5, 7, 4},  // its twin
  };
}

/// Records what a localiser reports to its observer: the stages of the last global search
/// (only if `stages`) and the hypotheses after the last scan.
struct Recorder : LocaliserObserver {
  explicit Recorder(bool record_stages) : stages(record_stages) {}
  bool wants_search_stages() const override { return stages; }
  void on_search_stages(const SearchStages& s) override { last_search = s; }
  void on_scan(const LocaliserStep& /*step*/, const std::vector<HypothesisView>& h) override {
    hypotheses = h;
  }
  bool stages;
  SearchStages last_search;
  std::vector<HypothesisView> hypotheses;
};

struct Outcome {
  int declared_at = -1;  ///< scan index, -1 = never
  Pose2 declared;
  Pose2 truth;
};

Outcome localise(Localiser& loc, const GridMap& map, const std::vector<Segment>& world,
                 const std::vector<Pose2>& path, double t0 = 0.0) {
  Outcome r;
  for (std::size_t i = 0; i < path.size(); ++i) {
    const LocaliserStep s =
        loc.process(map, make_scan(world, path[i], t0 + 0.2 * static_cast<double>(i)));
    if (s.declared) {
      r.declared_at = static_cast<int>(i);
      r.declared = s.pose;
      r.truth = path[i];
      return r;
    }
  }
  return r;
}

TEST(Localiser, WaitsForAMapThenLocalisesGlobally) {
  const auto world = asymmetric_room();
  const GridMap map = map_of(world, 12, 8);
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    LocaliserConfig c;
    c.seed = seed;
    Localiser loc(c);
    const GridMap empty;
    EXPECT_EQ(loc.process(empty, make_scan(world, {6, 4, 0})).state,
              LocaliserState::kWaitingForMap);
    const Outcome r = localise(loc, map, world, drive({2.0, 1.5, 0.3}, 40, 0.1), 1.0);
    ASSERT_GE(r.declared_at, 0) << "seed " << seed << ": no pose declared";
    EXPECT_TRUE(near(r.declared, r.truth, 0.1, 3.0))
        << "seed " << seed << ": declared (" << r.declared.x << ", " << r.declared.y << ", "
        << r.declared.theta << "), truth (" << r.truth.x << ", " << r.truth.y << ", "
        << r.truth.theta << ")";
    EXPECT_EQ(loc.state(), LocaliserState::kTracking);
    // It waited for motion and several matching scans before declaring.
    EXPECT_GE(r.declared_at, c.confirm_scans - 1) << "seed " << seed;
  }
}

TEST(Localiser, TheEsSearchOfThePaperAlsoLocalises) {
  const auto world = asymmetric_room();
  const GridMap map = map_of(world, 12, 8);
  LocaliserConfig c;
  c.search.method = GlobalSearchMethod::kEs;
  c.seed = 5;
  Localiser loc(c);
  const Outcome r = localise(loc, map, world, drive({9.0, 6.0, -2.5}, 60, 0.1));
  ASSERT_GE(r.declared_at, 0) << "seed 5: no pose declared";
  EXPECT_TRUE(near(r.declared, r.truth, 0.1, 3.0)) << "seed 5";
}

TEST(Localiser, RecordsTheStagesOfItsGridSearchOnlyWhenAsked) {
  const auto world = asymmetric_room();
  const GridMap map = map_of(world, 12, 8);
  const Pose2 truth{2.0, 1.5, 0.3};
  LocaliserConfig c;
  c.seed = 2;
  Localiser quiet(c);
  Recorder quiet_observer(/*stages=*/false);
  quiet.set_observer(&quiet_observer);
  ASSERT_TRUE(quiet.process(map, make_scan(world, truth)).global_search);
  EXPECT_TRUE(quiet_observer.last_search.coarse.empty());

  Localiser loc(c);
  Recorder observer(/*stages=*/true);
  loc.set_observer(&observer);
  ASSERT_TRUE(loc.process(map, make_scan(world, truth)).global_search);
  const SearchStages& st = observer.last_search;
  ASSERT_FALSE(st.candidates.empty());
  EXPECT_LE(st.candidates.size(), static_cast<std::size_t>(c.search.candidates));
  EXPECT_LE(st.coarse.size(), static_cast<std::size_t>(c.search.coarse_keep));
  ASSERT_EQ(st.ranked.size(), st.coarse.size());
  ASSERT_EQ(st.ranked_evidence.size(), st.ranked.size());
  ASSERT_EQ(st.candidate_evidence.size(), st.candidates.size());
  EXPECT_EQ(st.candidate_evidence.front(), st.ranked_evidence.front());
  EXPECT_TRUE(std::is_sorted(st.ranked_evidence.rbegin(), st.ranked_evidence.rend()));
  // An asymmetric room seen from inside: the best re-ranked pose is the truth.
  EXPECT_TRUE(near(st.ranked.front(), truth, 0.3, 5.0))
      << "(" << st.ranked.front().x << ", " << st.ranked.front().y << ", "
      << st.ranked.front().theta << ")";
  EXPECT_TRUE(near(st.candidates.front(), truth, 0.3, 5.0));
  // Every sample position with its best heading's coarse score; the kept coarse poses are
  // among them.
  ASSERT_EQ(st.sample_score.size(), st.samples.size());
  EXPECT_GE(st.samples.size(), st.coarse.size());
  for (const Pose2& k : st.coarse) {
    EXPECT_TRUE(std::any_of(st.samples.begin(), st.samples.end(), [&](const Pose2& p) {
      return p.x == k.x && p.y == k.y && p.theta == k.theta;
    }));
  }
}

TEST(Localiser, HypothesisIdsAreDistinctAndKeptWhileFollowed) {
  const auto world = asymmetric_room();
  const GridMap map = map_of(world, 12, 8);
  LocaliserConfig c;
  c.seed = 3;
  Localiser loc(c);
  Recorder observer(/*stages=*/false);
  loc.set_observer(&observer);
  const std::vector<Pose2> path = drive({2.0, 1.5, 0.3}, 3, 0.1);
  loc.process(map, make_scan(world, path[0], 0.0));
  const auto first = observer.hypotheses;
  ASSERT_GE(first.size(), 2u);
  for (std::size_t i = 0; i < first.size(); ++i) {
    EXPECT_GT(first[i].id, 0u);
    for (std::size_t j = i + 1; j < first.size(); ++j) EXPECT_NE(first[i].id, first[j].id);
  }
  // The next scan follows the same hypotheses (some may merge or drop out): no new ids without
  // a new search.
  const LocaliserStep s = loc.process(map, make_scan(world, path[1], 0.2));
  ASSERT_FALSE(s.global_search);
  for (const auto& h : observer.hypotheses) {
    EXPECT_TRUE(
        std::any_of(first.begin(), first.end(), [&](const auto& f) { return f.id == h.id; }))
        << "id " << h.id;
  }
}

TEST(Localiser, TracksAfterDeclaringAndKeepsTracking) {
  const auto world = asymmetric_room();
  const GridMap map = map_of(world, 12, 8);
  LocaliserConfig c;
  c.seed = 2;
  Localiser loc(c);
  const auto path = drive({2.0, 1.5, 0.3}, 70, 0.1);
  bool tracking = false;
  for (std::size_t i = 0; i < path.size(); ++i) {
    const LocaliserStep s =
        loc.process(map, make_scan(world, path[i], 0.2 * static_cast<double>(i)));
    if (s.state == LocaliserState::kTracking) {
      tracking = true;
      EXPECT_TRUE(near(s.pose, path[i], 0.05, 1.0)) << "scan " << i << ", seed 2";
      EXPECT_FALSE(s.lost);
    }
  }
  EXPECT_TRUE(tracking);
}

TEST(Localiser, AHintNearTheTruthLocalisesAndAWrongOneDeclaresNothingWrong) {
  const auto world = asymmetric_room();
  const GridMap map = map_of(world, 12, 8);
  const auto path = drive({2.0, 1.5, 0.3}, 40, 0.1);
  {
    LocaliserConfig c;
    c.seed = 3;
    c.hint = PoseHint{{2.3, 1.3, 0.2}, 1.0, 20.0};
    Localiser loc(c);
    const Outcome r = localise(loc, map, world, path);
    ASSERT_GE(r.declared_at, 0);
    EXPECT_TRUE(near(r.declared, r.truth, 0.1, 3.0));
  }
  {
    // A hint 6 m away: the search around it must not settle on a wrong pose. (After
    // hint_scans it widens to the global search, which may then find the right one.)
    LocaliserConfig c;
    c.seed = 3;
    c.hint = PoseHint{{9.0, 6.0, 2.0}, 1.0, 20.0};
    c.hint_scans = 1000;
    Localiser loc(c);
    const Outcome r = localise(loc, map, world, path);
    if (r.declared_at >= 0) {
      EXPECT_TRUE(near(r.declared, r.truth, 0.3, 5.0)) << "wrong pose declared from a wrong hint";
    }
  }
}

TEST(Localiser, DoesNotGuessInASymmetricRoom) {
  const std::vector<Segment> world = twin_pillar_room();
  const GridMap map = map_of(world, 10, 6);
  for (std::uint64_t seed = 1; seed <= 2; ++seed) {
    LocaliserConfig c;
    c.seed = seed;
    Localiser loc(c);
    const Outcome r = localise(loc, map, world, drive({1.5, 3.0, 0.2}, 40, 0.1));
    if (r.declared_at >= 0) {
      // Declaring is allowed only if it happens to be right; the twin must not be taken.
      EXPECT_TRUE(near(r.declared, r.truth, 0.3, 5.0)) << "seed " << seed << ": wrong twin";
    }
  }
}

TEST(Localiser, NoticesAKidnapAndRelocalises) {
  const auto world = asymmetric_room();
  const GridMap map = map_of(world, 12, 8);
  LocaliserConfig c;
  c.seed = 4;
  Localiser loc(c);
  const Outcome first = localise(loc, map, world, drive({2.0, 1.5, 0.3}, 40, 0.1));
  ASSERT_GE(first.declared_at, 0);
  // Carried to the other side of the room, facing the other way.
  const auto there = drive({10.5, 6.5, -2.4}, 60, 0.08);
  int lost_at = -1, again_at = -1;
  for (std::size_t i = 0; i < there.size(); ++i) {
    const LocaliserStep s =
        loc.process(map, make_scan(world, there[i], 100.0 + 0.2 * static_cast<double>(i)));
    if (s.lost && lost_at < 0) lost_at = static_cast<int>(i);
    if (s.declared) {
      again_at = static_cast<int>(i);
      EXPECT_TRUE(near(s.pose, there[i], 0.1, 3.0)) << "relocalised wrongly, seed 4";
      break;
    }
  }
  EXPECT_GE(lost_at, 0) << "the kidnap went unnoticed";
  EXPECT_LE(lost_at, c.lost_scans + 2);
  EXPECT_GT(again_at, lost_at) << "not relocalised";
}

TEST(Localiser, TheContradictionRouteLocalisesAndStillDoesNotGuessATwin) {
  // The route clears a rival only on many more end points in known free space; a twin pose
  // has exactly as many, so the symmetric room must stay undeclared or right.
  const auto world = asymmetric_room();
  const GridMap map = map_of(world, 12, 8);
  const std::vector<Segment> twin_world = twin_pillar_room();
  const GridMap twin_map = map_of(twin_world, 10, 6);
  for (std::uint64_t seed = 1; seed <= 2; ++seed) {
    LocaliserConfig c;
    c.seed = seed;
    c.contradiction_factor = 2.0;
    c.contradiction_min_streak = 4;
    Localiser loc(c);
    const Outcome r = localise(loc, map, world, drive({2.0, 1.5, 0.3}, 40, 0.1));
    ASSERT_GE(r.declared_at, 0) << "seed " << seed << ": no pose declared";
    EXPECT_TRUE(near(r.declared, r.truth, 0.1, 3.0)) << "seed " << seed;
    Localiser twin(c);
    const Outcome t = localise(twin, twin_map, twin_world, drive({1.5, 3.0, 0.2}, 40, 0.1));
    if (t.declared_at >= 0) {
      EXPECT_TRUE(near(t.declared, t.truth, 0.3, 5.0)) << "seed " << seed << ": wrong twin";
    }
  }
}

TEST(Localiser, ConfigValidationNamesTheField) {
  LocaliserConfig c;
  c.search.candidates = 0;
  try {
    Localiser loc(c);
    FAIL() << "no throw";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("localise.candidates"), std::string::npos) << e.what();
  }
  LocaliserConfig h;
  h.hint = PoseHint{{0, 0, 0}, -1.0, 10.0};
  EXPECT_THROW(Localiser{h}, std::invalid_argument);
  LocaliserConfig k;
  k.contradiction_factor = -1.0;
  EXPECT_THROW(Localiser{k}, std::invalid_argument);
  k.contradiction_factor = 2.0;
  k.contradiction_min_streak = 0;
  EXPECT_THROW(Localiser{k}, std::invalid_argument);
  LocaliserConfig r;
  r.research_every_max = r.research_every - 1;
  try {
    Localiser loc(r);
    FAIL() << "no throw";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("localise.research_every_max"), std::string::npos)
        << e.what();
  }
}

/// The scans at which a localiser searched globally over `n` scans from a round room of
/// 1.6 m radius, which the map of the rectangular room does not hold: no pose explains a scan
/// there well.
std::vector<int> searches_where_nothing_matches(const LocaliserConfig& c, int n) {
  const GridMap map = map_of(asymmetric_room(), 12, 8);
  std::vector<Segment> round;
  constexpr int kSides = 36;
  for (int k = 0; k < kSides; ++k) {
    const double a = 2.0 * std::numbers::pi * k / kSides,
                 b = 2.0 * std::numbers::pi * (k + 1) / kSides;
    round.push_back({1.6 * std::cos(a), 1.6 * std::sin(a), 1.6 * std::cos(b), 1.6 * std::sin(b)});
  }
  Localiser loc(c);
  std::vector<int> at;
  for (int i = 0; i < n; ++i) {
    const Pose2 p{0.3, 0.0, 0.05 * i};  // turning on the spot
    const LocaliserStep s = loc.process(map, make_scan(round, p, 0.2 * i));
    EXPECT_FALSE(s.declared) << "declared a pose from a room the map does not hold, scan " << i;
    if (s.global_search) at.push_back(i);
  }
  return at;
}

TEST(Localiser, WaitsLongerBetweenFruitlessGlobalSearches) {
  LocaliserConfig c;
  c.seed = 3;
  const std::vector<int> backoff = searches_where_nothing_matches(c, 100);
  // Waits of 5, 10, then 20 scans (research_every, doubled up to research_every_max).
  ASSERT_GE(backoff.size(), 4u);
  std::vector<int> waits;
  for (std::size_t i = 1; i < backoff.size(); ++i) waits.push_back(backoff[i] - backoff[i - 1]);
  EXPECT_EQ(backoff.front(), 0);
  EXPECT_EQ(waits[0], c.research_every + 1);
  EXPECT_EQ(waits[1], 2 * c.research_every + 1);
  for (std::size_t i = 2; i < waits.size(); ++i) EXPECT_EQ(waits[i], c.research_every_max + 1);
  // research_every_max = research_every: a search every research_every + 1 scans throughout.
  c.research_every_max = c.research_every;
  const std::vector<int> fixed = searches_where_nothing_matches(c, 100);
  EXPECT_GE(fixed.size(), 2 * backoff.size());
  for (std::size_t i = 1; i < fixed.size(); ++i) {
    EXPECT_EQ(fixed[i] - fixed[i - 1], c.research_every + 1) << "search " << i;
  }
}

}  // namespace
}  // namespace esfleet
