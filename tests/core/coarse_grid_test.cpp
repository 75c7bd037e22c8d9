// The recovery search's coarse stage (core/src/coarse_grid.hpp, private to core): the pooled
// window must be the maximum over each block of the cells' values, the grid scores and the
// full-resolution sums must be the sums the definition gives position by position (for every
// pooling factor the configuration allows, end points near, far and outside the window, rows
// across tiles), and the best distinct poses those of a full sort.

#include "coarse_grid.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "esfleet/core/geometry.hpp"
#include "synthetic_world.hpp"

namespace esfleet::coarse_grid {
namespace {

using testing::asymmetric_room;
using testing::map_of;

constexpr float kFreePenalty = 0.5f;

/// A cell's value by the definition: occupied its score, known free -free_penalty, unknown 0.
float cell_value(const GridMap& map, std::int32_t cx, std::int32_t cy) {
  const float s = map.lookup(0).score(cx, cy);
  return s > 0.0f ? s : (s == 0.0f ? -kFreePenalty : 0.0f);
}

/// The cell holding coordinate v (cells), one far outside any window for a coordinate an
/// int32 cannot hold.
std::int32_t cell_of(double v) {
  return static_cast<std::int32_t>(std::floor(std::clamp(v, -1e9, 1e9)));
}

TEST(CoarseGrid, APooledBlockIsTheBestCellInItAndNothingOutsideTheWindow) {
  const GridMap map = map_of(asymmetric_room(), 12, 8);
  for (const std::int32_t factor : {1, 4, 16}) {
    // A window that cuts through the room, not aligned to blocks.
    const PooledWindow w(map, 37, -5, 173, 121, factor, kFreePenalty);
    ASSERT_TRUE(w.any_hit()) << "factor " << factor;
    EXPECT_EQ(w.x0() % factor, 0);
    int checked = 0;
    for (std::int32_t cy = -40; cy < 200; cy += 3) {
      for (std::int32_t cx = 0; cx < 260; cx += 3) {
        const std::int32_t bx = floor_div(cx, factor) * factor;
        const std::int32_t by = floor_div(cy, factor) * factor;
        const bool inside = bx + factor > 37 && bx <= 173 && by + factor > -5 && by <= 121;
        float expected = inside ? -kFreePenalty : 0.0f;
        for (std::int32_t y = by; inside && y < by + factor; ++y) {
          for (std::int32_t x = bx; x < bx + factor; ++x) {
            expected = std::max(expected, cell_value(map, x, y));
          }
        }
        ASSERT_EQ(w.coarse(cx, cy), expected)
            << "factor " << factor << " cell " << cx << ", " << cy;
        ++checked;
      }
    }
    EXPECT_GT(checked, 5000);
  }
}

TEST(CoarseGrid, GridScoresAreTheSumsAtEachPosition) {
  const GridMap map = map_of(asymmetric_room(), 12, 8);
  const unsigned seed = 20261207;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> centre_x(60.0, 180.0), centre_y(40.0, 120.0);
  for (const std::int32_t factor : {1, 4, 16}) {
    for (int trial = 0; trial < 4; ++trial) {
      const double cx = centre_x(rng), cy = centre_y(rng);
      const int n = trial == 0 ? 0 : 7 + trial;
      const double radius = 30.0;  // the window cuts through the room: its edges are known
      const auto reach = static_cast<std::int32_t>(radius + factor * (n + 2));
      const PooledWindow w(map, static_cast<std::int32_t>(cx) - reach,
                           static_cast<std::int32_t>(cy) - reach,
                           static_cast<std::int32_t>(cx) + reach,
                           static_cast<std::int32_t>(cy) + reach, factor, kFreePenalty);
      const GridScorer scorer(w, cx, cy, n);
      // End points within the radius, some on whole and half cells; a few beyond it, partly
      // outside the window; one far outside and one a int cannot hold.
      std::vector<float> px, py;
      std::uniform_real_distribution<double> angle(-3.14159, 3.14159), range(0.5, radius - 1.0);
      for (int j = 0; j < 150; ++j) {
        const double a = angle(rng);
        const double r = j % 30 == 29 ? radius + 40.0 : range(rng);
        double x = r * std::cos(a), y = r * std::sin(a);
        if (j % 7 == 0) x = std::round(x * 2.0) / 2.0;
        px.push_back(static_cast<float>(x));
        py.push_back(static_cast<float>(y));
      }
      // Across each edge of the window: in, partly in at some positions, out.
      for (double t = 0.0; t < factor * (n + 3) + 12.0; t += 0.5 * factor + 0.7) {
        const float d = static_cast<float>(radius + t), s = static_cast<float>(0.3 * t);
        px.insert(px.end(), {d, -d, s, -s});
        py.insert(py.end(), {s, -s, d, -d});
      }
      px.push_back(5000.0f);
      py.push_back(-20.0f);
      px.push_back(3e9f);
      py.push_back(-3e9f);
      const std::size_t side = scorer.side();
      ASSERT_EQ(side, static_cast<std::size_t>(2 * n + 1));
      std::vector<float> got(side * side, -1.0f);
      scorer.score(px.data(), py.data(), px.size(), got.data());
      const double q = 0.5 * factor;
      for (int iy = -n; iy <= n; ++iy) {
        for (int ix = -n; ix <= n; ++ix) {
          float expected = 0.0f;
          for (std::size_t j = 0; j < px.size(); ++j) {
            expected += w.coarse(cell_of(cx + q * ix + px[j]), cell_of(cy + q * iy + py[j]));
          }
          ASSERT_EQ(got[static_cast<std::size_t>((iy + n) * static_cast<int>(side) + ix + n)],
                    expected)
              << "seed " << seed << " factor " << factor << " trial " << trial << " at " << ix
              << ", " << iy;
        }
      }
    }
  }
}

TEST(CoarseGrid, FineSumsAreTheSumsAtEachCellAcrossTiles) {
  const GridMap map = map_of(asymmetric_room(), 12, 8);  // 64-cell tiles: rows cross them
  const PooledWindow w(map, 0, 0, 250, 170, 4, kFreePenalty);
  const unsigned seed = 11;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> centre_x(40.0, 200.0), centre_y(30.0, 130.0);
  std::uniform_real_distribution<double> angle(-3.14159, 3.14159), range(0.5, 80.0);
  int crossing = 0;
  for (const int n : {0, 2, 9}) {
    for (int trial = 0; trial < 5; ++trial) {
      const double cx = centre_x(rng), cy = centre_y(rng);
      std::vector<float> px, py;
      for (int j = 0; j < 120; ++j) {
        const double a = angle(rng), r = range(rng);
        px.push_back(static_cast<float>(r * std::cos(a)));
        py.push_back(static_cast<float>(r * std::sin(a)));
        const auto x = static_cast<std::int32_t>(std::floor(cx + px.back()));
        crossing += (x - n) / 64 != (x + n) / 64;
      }
      const auto side = static_cast<std::size_t>(2 * n + 1);
      std::vector<float> got(side * side, -1.0f);
      fine_sums(w, cx, cy, px.data(), py.data(), px.size(), n, got.data());
      for (int iy = -n; iy <= n; ++iy) {
        for (int ix = -n; ix <= n; ++ix) {
          float expected = 0.0f;
          for (std::size_t j = 0; j < px.size(); ++j) {
            expected += cell_value(map, static_cast<std::int32_t>(std::floor(cx + ix + px[j])),
                                   static_cast<std::int32_t>(std::floor(cy + iy + py[j])));
          }
          ASSERT_EQ(got[static_cast<std::size_t>(iy + n) * side + static_cast<std::size_t>(ix + n)],
                    expected)
              << "seed " << seed << " n " << n << " trial " << trial << " at " << ix << ", " << iy;
        }
      }
    }
  }
  EXPECT_GT(crossing, 20);  // rows across a tile edge were read
}

TEST(CoarseGrid, BestScoresKeepAPrefixOfTheSortedScoresInBoundedMemory) {
  const unsigned seed = 20261208;
  std::mt19937 rng(seed);
  for (const int levels : {3, 1000000}) {
    std::uniform_int_distribution<int> level(-levels, levels);
    std::vector<float> scores(20000);
    for (float& s : scores) s = static_cast<float>(level(rng));
    std::vector<BestScores::Entry> all;
    for (std::size_t i = 0; i < scores.size(); ++i) {
      if (scores[i] > 0.0f) all.push_back({scores[i], i});
    }
    std::sort(all.begin(), all.end(), BestScores::better);
    for (const std::size_t capacity : {1, 10, 999, 9000, 20000}) {
      for (const bool worst_first : {false, true}) {
        // In chunks of 100 in an order of their own; or one at a time, worst first, so that
        // every score offered is kept and those cut are the only ones dropped.
        BestScores top(capacity);
        const auto where = "seed " + std::to_string(seed) + " levels " + std::to_string(levels) +
                           " capacity " + std::to_string(capacity) +
                           (worst_first ? " worst first" : "");
        if (worst_first) {
          for (auto e = all.rbegin(); e != all.rend(); ++e) {
            top.add(&scores[e->index], 1, e->index);
            ASSERT_LT(top.size(), 2 * capacity) << where;
          }
        } else {
          std::vector<std::size_t> chunks(scores.size() / 100);
          for (std::size_t c = 0; c < chunks.size(); ++c) chunks[c] = c;
          std::shuffle(chunks.begin(), chunks.end(), rng);
          for (const std::size_t c : chunks) top.add(scores.data() + 100 * c, 100, 100 * c);
        }
        const std::vector<BestScores::Entry> kept = top.sorted();
        ASSERT_GE(kept.size(), std::min(capacity, all.size())) << where;
        ASSERT_LT(kept.size(), 2 * capacity) << where;
        EXPECT_EQ(top.dropped(), kept.size() < all.size()) << where;
        for (std::size_t k = 0; k < kept.size(); ++k) {
          ASSERT_EQ(kept[k].score, all[k].score) << where << " rank " << k;
          ASSERT_EQ(kept[k].index, all[k].index) << where << " rank " << k;
        }
      }
    }
  }
}

/// The definition: every pose sorted by score (stable: ties by index), then taken greedily.
std::vector<Scored> reference_best_distinct(const std::vector<float>& scores,
                                            const std::vector<Pose2>& poses, std::size_t keep,
                                            double dxy, double dtheta) {
  std::vector<Scored> all;
  for (std::size_t i = 0; i < scores.size(); ++i) all.push_back({scores[i], poses[i]});
  std::stable_sort(all.begin(), all.end(),
                   [](const Scored& a, const Scored& b) { return a.score > b.score; });
  std::vector<Scored> out;
  for (const Scored& s : all) {
    if (out.size() >= keep || !(s.score > 0.0f)) break;
    const bool near = std::any_of(out.begin(), out.end(), [&](const Scored& o) {
      return std::hypot(s.pose.x - o.pose.x, s.pose.y - o.pose.y) < dxy &&
             std::abs(normalize_angle(s.pose.theta - o.pose.theta)) < dtheta;
    });
    if (!near) out.push_back(s);
  }
  return out;
}

TEST(CoarseGrid, BestDistinctPosesAreThoseOfAFullSort) {
  const unsigned seed = 7;
  std::mt19937 rng(seed);
  // A grid of 41 x 41 positions 0.1 m apart at 60 headings 3 deg apart.
  const int side = 41, headings = 60;
  std::vector<Pose2> poses;
  for (int it = 0; it < headings; ++it) {
    for (int iy = 0; iy < side; ++iy) {
      for (int ix = 0; ix < side; ++ix) {
        poses.push_back({0.1 * ix, 0.1 * iy, normalize_angle(deg_to_rad(3.0 * it - 90.0))});
      }
    }
  }
  const auto pose_of = [&poses](std::uint64_t i) { return poses[i]; };
  // Scores as a search gives them: highest near a few poses and falling off around each, so
  // the best hundreds of scores are a handful of distinct poses (rounded: ties); and random
  // scores, with few levels (many ties) or many, and few of them positive or all.
  std::vector<std::vector<float>> landscapes;
  for (const float step : {0.01f, 0.5f}) {
    std::vector<float> scores(poses.size());
    for (std::size_t i = 0; i < poses.size(); ++i) {
      double best = -1.0;
      for (const Pose2& peak :
           {Pose2{1.0, 2.0, 0.3}, Pose2{3.0, 1.0, -1.0}, Pose2{2.5, 3.5, 1.2}}) {
        const double d = std::hypot(poses[i].x - peak.x, poses[i].y - peak.y) +
                         0.5 * std::abs(normalize_angle(poses[i].theta - peak.theta));
        best = std::max(best, 10.0 - 4.0 * d);
      }
      scores[i] = std::round(static_cast<float>(best) / step) * step;
    }
    landscapes.push_back(scores);
  }
  for (const int levels : {4, 40, 4000}) {
    for (const double positive : {0.002, 0.3, 1.0}) {
      std::uniform_int_distribution<int> level(1, levels);
      std::uniform_real_distribution<double> u(0.0, 1.0);
      std::vector<float> scores(poses.size());
      for (float& s : scores) s = u(rng) < positive ? static_cast<float>(level(rng)) : -1.0f;
      landscapes.push_back(scores);
    }
  }
  int compared = 0;
  int retried = 0;
  for (std::size_t l = 0; l < landscapes.size(); ++l) {
    const std::vector<float>& scores = landscapes[l];
    // Offered a heading at a time, first to last and last to first (ties are by index, not by
    // the order offered); the capacities make the kept scores be cut many times or never, and
    // the pass undecided on the first try (then scored again with 4 times the capacity).
    const std::size_t chunk = static_cast<std::size_t>(side * side);
    for (const std::size_t keep : {1, 8, 64, 600}) {
      const std::vector<Scored> want =
          reference_best_distinct(scores, poses, keep, 0.3, deg_to_rad(5.0));
      for (const bool backwards : {false, true}) {
        for (const std::size_t capacity : {1, 5, 64, 1000000}) {
          int calls = 0;
          const auto score_all = [&](BestScores& top) {
            ++calls;
            for (std::size_t h = 0; h < static_cast<std::size_t>(headings); ++h) {
              const std::size_t first = (backwards ? headings - 1 - h : h) * chunk;
              top.add(scores.data() + first, chunk, first);
            }
          };
          const std::vector<Scored> got =
              best_distinct(score_all, keep, 0.3, deg_to_rad(5.0), pose_of, capacity);
          retried += calls > 1;
          const auto where = [&] {
            return "seed " + std::to_string(seed) + " scores " + std::to_string(l) + " keep " +
                   std::to_string(keep) + " capacity " + std::to_string(capacity) +
                   (backwards ? " backwards" : "");
          };
          ASSERT_EQ(got.size(), want.size()) << where();
          for (std::size_t k = 0; k < got.size(); ++k) {
            ASSERT_EQ(got[k].score, want[k].score) << where() << " rank " << k;
            ASSERT_EQ(got[k].pose.x, want[k].pose.x) << where() << " rank " << k;
            ASSERT_EQ(got[k].pose.y, want[k].pose.y) << where() << " rank " << k;
            ASSERT_EQ(got[k].pose.theta, want[k].pose.theta) << where() << " rank " << k;
          }
          compared += static_cast<int>(got.size());
        }
      }
    }
  }
  EXPECT_GT(retried, 20);  // undecided passes were scored again
  EXPECT_GT(compared, 20000);
}

}  // namespace
}  // namespace esfleet::coarse_grid
