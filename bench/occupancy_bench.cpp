#include "occupancy_bench.hpp"

#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <unordered_map>
#include <vector>

#include "app/slam_params.hpp"
#include "esfleet/core/file_io.hpp"
#include "esfleet/core/ros_map_reader.hpp"
#include "esfleet/core/scan_points.hpp"
#include "esfleet/core/trajectory_io.hpp"
#include "esfleet/sim/world.hpp"

namespace esfleet::bench {

namespace {

/// Stamps of a trajectory row and its scan may differ by the %.6f rounding of the file.
constexpr double kStampTolerance = 2e-6;

void add_common_options(CLI::App& cmd, OccupancyBenchOptions& o) {
  cmd.add_option("--log", o.log, "CARMEN log the map was built from")->required();
  cmd.add_option("--trajectory", o.trajectory,
                 "the leader's trajectory.txt of that log (row i = scan i)")
      ->required();
  cmd.add_option("--map", o.map, "map.yaml, read as map_server reads it")->required();
  cmd.add_option("--json", o.json, "also write the figures to this JSON file");
  app::add_slam_params(o.params, &o.slam, &o.reader);
  o.params.bind(cmd, "The leader's SLAM parameters (the reader and beam range ones matter)");
}

/// How the figures count a map value: 100 occupied, 0 free, anything else (-1, and the
/// values in between of a scale-mode map) unknown.
struct ClassCounts {
  std::uint64_t occupied = 0, free = 0, unknown = 0;

  void add(std::int8_t value) {
    if (value == 100) {
      ++occupied;
    } else if (value == 0) {
      ++free;
    } else {
      ++unknown;
    }
  }
  std::uint64_t total() const { return occupied + free + unknown; }
  double share(std::uint64_t n) const {
    return total() > 0 ? static_cast<double>(n) / static_cast<double>(total()) : 0.0;
  }
  nlohmann::json to_json() const {
    return {{"occupied", occupied}, {"free", free}, {"unknown", unknown}};
  }
  nlohmann::json shares_json() const {
    return {{"occupied", share(occupied)}, {"free", share(free)}, {"unknown", share(unknown)}};
  }
};

/// Pixel (column, row from the bottom) of the world point (x, y); may lie outside the image.
struct Pixel {
  int col = 0, row = 0;
};
Pixel pixel_of(const OccupancyImage& img, double x, double y) {
  return {static_cast<int>(std::floor((x - img.origin_x) / img.resolution)),
          static_cast<int>(std::floor((y - img.origin_y) / img.resolution))};
}

OccupancyImage load_map(const std::string& path) {
  OccupancyImage img = load_ros_map(path);
  if (img.origin_theta != 0.0) {
    throw std::runtime_error(path + ": origin yaw " + std::to_string(img.origin_theta) +
                             " is not supported (esfleet writes 0)");
  }
  return img;
}

/// Calls f(i, x, y) for the world end point (x, y) of every valid beam (not a no-return,
/// within the SLAM's beam range) of scan i of the log at poses[i]. The poses must be the log's
/// scans in order (same stamps); there may be fewer (a run cut short), not more. Returns the
/// number of scans used. Throws std::runtime_error naming the file and row on a mismatch.
std::size_t for_each_end_point(const OccupancyBenchOptions& o, const std::vector<TimedPose>& poses,
                               const std::string& poses_file,
                               const std::function<void(std::size_t, double, double)>& f) {
  CarmenReader reader(o.log, o.reader);
  std::size_t i = 0;
  for (; i < poses.size(); ++i) {
    const std::optional<LaserScan> scan = reader.next_scan();
    if (!scan) {
      throw std::runtime_error(poses_file + ": " + std::to_string(poses.size()) + " poses but " +
                               o.log + " has only " + std::to_string(i) + " scans");
    }
    const TimedPose& tp = poses[i];
    if (std::abs(scan->stamp - tp.stamp) > kStampTolerance) {
      char msg[160];
      std::snprintf(msg, sizeof msg, ": pose %zu has stamp %.6f but scan %zu of the log %.6f",
                    i + 1, tp.stamp, i + 1, scan->stamp);
      throw std::runtime_error(poses_file + msg);
    }
    const ScanPoints pts = prepare_scan(*scan, o.slam.tracking);
    for (std::size_t k = 0; k < pts.size(); ++k) {
      const Pose2 e = tp.pose.compose({pts.x[k], pts.y[k], 0.0});
      f(i, e.x, e.y);
    }
  }
  return i;
}

/// Writes `j` to `path` (nothing if empty); 0, or 1 with a message when it cannot.
int write_json(const char* cmd, const std::string& path, const nlohmann::json& j) {
  if (path.empty()) return 0;
  try {
    write_file_atomically(path, j.dump(2) + "\n");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "esfleet-bench %s: %s\n", cmd, e.what());
    return 1;
  }
  return 0;
}

/// Bad input: the message, exit code 2.
int fail(const char* cmd, const std::exception& e) {
  std::fprintf(stderr, "esfleet-bench %s: %s\n", cmd, e.what());
  return 2;
}

// --- occupancy-truth ---------------------------------------------------------------------------

/// The SLAM's map is consistent with its own trajectory but may be bent against the world by a
/// few centimetres over tens of metres; a single rigid alignment would blame that on the map's
/// cells. So each place is compared through the pose nearest to it: world = T_i ⊕ slam point
/// with T_i = truth_i ⊕ slam_i⁻¹.
struct LocalAlignment {
  std::vector<Pose2> slam_to_world;  ///< T_i per pose
  std::vector<Pose2> slam;           ///< slam_i

  LocalAlignment(const std::vector<TimedPose>& slam_poses, const std::vector<TimedPose>& truth,
                 std::size_t n) {
    for (std::size_t i = 0; i < n; ++i) {
      slam.push_back(slam_poses[i].pose);
      slam_to_world.push_back(truth[i].pose.compose(slam_poses[i].pose.inverse()));
    }
  }
  /// The SLAM-frame point (x, y) in the world, through the SLAM pose nearest to it.
  Pose2 to_world(double x, double y) const {
    std::size_t best = 0;
    double best_d = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < slam.size(); ++i) {
      const double d = std::hypot(slam[i].x - x, slam[i].y - y);
      if (d < best_d) best_d = d, best = i;
    }
    return slam_to_world[best].compose({x, y, 0.0});
  }
  /// The world point (x, y) seen from pose i, in the SLAM frame.
  Pose2 to_slam(std::size_t i, double x, double y) const {
    return slam_to_world[i].inverse().compose({x, y, 0.0});
  }
};

std::uint64_t key(sim::Cell c) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(c.x)) << 32) |
         static_cast<std::uint32_t>(c.y);
}

/// Whether `pred` holds for `c` or one of its 8 neighbours (the 1-cell tolerance).
bool near(sim::Cell c, const std::function<bool(sim::Cell)>& pred) {
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      if (pred({c.x + dx, c.y + dy})) return true;
    }
  }
  return false;
}

/// The true wall cell a beam from `from` ending at (x, y) hit (esfleet-sim measures to the
/// face of the first occupied cell, plus noise): the occupied cell half a cell past the end
/// point, at it or a cell past it; nullopt if none is.
std::optional<sim::Cell> wall_hit(const sim::World& w, const Pose2& from, double x, double y) {
  const double dx = x - from.x, dy = y - from.y, d = std::hypot(dx, dy);
  if (d <= 0.0) return std::nullopt;
  for (const double past : {0.5, 0.0, 1.0}) {
    const double k = past * w.resolution() / d;
    const sim::Cell c = w.cell_at(x + k * dx, y + k * dy);
    if (w.occupied(c)) return c;
  }
  return std::nullopt;
}

/// n of `of` things.
struct Share {
  std::uint64_t n = 0, of = 0;
  double ratio() const { return of > 0 ? static_cast<double>(n) / static_cast<double>(of) : 0.0; }
};

/// Precision: the occupied map cells within a cell of a true wall, of all occupied map cells.
Share occupied_on_true_walls(const OccupancyImage& img, const sim::World& world,
                             const LocalAlignment& align) {
  Share s;
  for (int row = 0; row < img.height; ++row) {
    for (int col = 0; col < img.width; ++col) {
      if (img.at(col, row) != 100) continue;
      const Pose2 w = align.to_world(img.origin_x + (col + 0.5) * img.resolution,
                                     img.origin_y + (row + 0.5) * img.resolution);
      ++s.of;
      const sim::Cell c = world.cell_at(w.x, w.y);
      s.n += near(c, [&](sim::Cell q) { return world.occupied(q); }) ? 1 : 0;
    }
  }
  return s;
}

/// Recall: of the true wall cells the beams hit (from the true poses), those within a cell of an
/// occupied map cell, seen through the pose of the beam (found once found from any of them).
/// `no_wall` gets the end points that hit no true wall cell (wall_hit).
Share true_walls_found(const OccupancyBenchOptions& o, const OccupancyImage& img,
                       const sim::World& world, const LocalAlignment& align,
                       const std::vector<TimedPose>& truth, std::uint64_t& no_wall) {
  std::unordered_map<std::uint64_t, bool> walls;
  for_each_end_point(o, truth, o.truth, [&](std::size_t i, double x, double y) {
    const std::optional<sim::Cell> c = wall_hit(world, truth[i].pose, x, y);
    if (!c) {
      ++no_wall;
      return;
    }
    bool& found = walls[key(*c)];
    if (found) return;
    double cx = 0.0, cy = 0.0;
    world.centre_of(*c, cx, cy);
    const Pose2 m = align.to_slam(i, cx, cy);
    const Pixel p = pixel_of(img, m.x, m.y);
    found = near({p.col, p.row}, [&](sim::Cell q) { return img.at(q.x, q.y) == 100; });
  });
  Share s;
  s.of = walls.size();
  for (const auto& [k, f] : walls) s.n += f ? 1 : 0;
  return s;
}

}  // namespace

void add_occupancy_bench_options(CLI::App& cmd, OccupancyBenchOptions& o) {
  add_common_options(cmd, o);
}

void add_occupancy_truth_options(CLI::App& cmd, OccupancyBenchOptions& o) {
  add_common_options(cmd, o);
  cmd.add_option("--truth", o.truth, "esfleet-sim's <id>.truth of the same run")->required();
  cmd.add_option("--world", o.world, "the world map.yaml esfleet-sim drove in")->required();
}

int run_occupancy_bench(OccupancyBenchOptions& o) {
  try {
    o.params.apply();
    const OccupancyImage img = load_map(o.map);
    const std::vector<TimedPose> poses = read_trajectory(o.trajectory);
    ClassCounts cells, ends;
    std::uint64_t near_occupied = 0;  // end points on or next to an occupied cell
    for (const std::int8_t v : img.cells) cells.add(v);
    const std::size_t scans =
        for_each_end_point(o, poses, o.trajectory, [&](std::size_t, double x, double y) {
          const Pixel p = pixel_of(img, x, y);
          ends.add(img.at(p.col, p.row));
          const bool near_wall =
              near({p.col, p.row}, [&](sim::Cell q) { return img.at(q.x, q.y) == 100; });
          near_occupied += near_wall ? 1 : 0;
        });
    std::printf("%s: %dx%d cells: %llu occupied, %llu free, %llu unknown\n", o.map.c_str(),
                img.width, img.height, static_cast<unsigned long long>(cells.occupied),
                static_cast<unsigned long long>(cells.free),
                static_cast<unsigned long long>(cells.unknown));
    std::printf("end points: %llu of %zu scans: on occupied %.4f, on free %.4f, on unknown %.4f\n",
                static_cast<unsigned long long>(ends.total()), scans, ends.share(ends.occupied),
                ends.share(ends.free), ends.share(ends.unknown));
    std::printf("end points on or next to (8-neighbourhood) an occupied cell %.4f\n",
                ends.share(near_occupied));
    return write_json("occupancy", o.json,
                      {{"log", o.log},
                       {"trajectory", o.trajectory},
                       {"map", o.map},
                       {"cells", cells.to_json()},
                       {"scans", scans},
                       {"end_points", ends.total()},
                       {"end_point_share", ends.shares_json()},
                       {"end_point_share_near_occupied", ends.share(near_occupied)}});
  } catch (const std::exception& e) {
    return fail("occupancy", e);
  }
}

int run_occupancy_truth(OccupancyBenchOptions& o) {
  try {
    o.params.apply();
    const OccupancyImage img = load_map(o.map);
    const sim::World world = sim::load_world(o.world);
    const std::vector<TimedPose> slam = read_trajectory(o.trajectory);
    const std::vector<TimedPose> truth = read_trajectory(o.truth);
    const std::size_t n = std::min(slam.size(), truth.size());
    for (std::size_t i = 0; i < n; ++i) {
      if (std::abs(slam[i].stamp - truth[i].stamp) > kStampTolerance) {
        throw std::runtime_error(o.trajectory + ": pose " + std::to_string(i + 1) +
                                 " has another stamp than pose " + std::to_string(i + 1) + " of " +
                                 o.truth);
      }
    }
    if (n < 2) throw std::runtime_error(o.trajectory + ": fewer than 2 poses to align");
    const LocalAlignment align(slam, truth, n);

    const Share precision = occupied_on_true_walls(img, world, align);
    const std::vector<TimedPose> truth_used(truth.begin(), truth.begin() + static_cast<long>(n));
    std::uint64_t no_wall = 0;
    const Share recall = true_walls_found(o, img, world, align, truth_used, no_wall);
    std::printf("%zu poses aligned with the truth\n", n);
    std::printf("occupied map cells %llu: within a cell of a true wall %llu, precision %.4f\n",
                static_cast<unsigned long long>(precision.of),
                static_cast<unsigned long long>(precision.n), precision.ratio());
    std::printf(
        "true wall cells hit by the beams %llu (%llu end points found none): within a cell of an "
        "occupied map cell %llu, recall %.4f\n",
        static_cast<unsigned long long>(recall.of), static_cast<unsigned long long>(no_wall),
        static_cast<unsigned long long>(recall.n), recall.ratio());
    return write_json("occupancy-truth", o.json,
                      {{"log", o.log},
                       {"trajectory", o.trajectory},
                       {"truth", o.truth},
                       {"world", o.world},
                       {"map", o.map},
                       {"poses", n},
                       {"occupied_cells", precision.of},
                       {"occupied_near_true_wall", precision.n},
                       {"precision", precision.ratio()},
                       {"true_wall_cells_hit", recall.of},
                       {"true_wall_cells_found", recall.n},
                       {"end_points_without_true_wall", no_wall},
                       {"recall", recall.ratio()}});
  } catch (const std::exception& e) {
    return fail("occupancy-truth", e);
  }
}

}  // namespace esfleet::bench
