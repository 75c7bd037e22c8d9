// esfleet-leader: maps with the (mu+1)-ES SLAM and shares the map over DDS (leader_app.hpp).

#include <malloc.h>

#include "app/param_table.hpp"
#include "app/program.hpp"
#include "leader_app.hpp"
#include "leader_options.hpp"

namespace {
constexpr const char* kDescription =
    "esfleet-leader: 2D laser SLAM with the (mu+1)-Evolution Strategy of Toda & Kubota, sharing "
    "its map over DDS.\n"
    "Maps a CARMEN log (--log) or the scans a robot publishes on esfleet/robots/scan "
    "(--scan-topic) and publishes changed map tiles (whole or as deltas), the map summary and "
    "its pose (topics esfleet/map/tiles, esfleet/map/tile_deltas, esfleet/map/meta, "
    "esfleet/robots/pose); late joiners get the whole map. With --offline it maps a log without "
    "DDS. All write DIR/map.pgm, map.yaml (ROS map_server), map.png (map with trajectory), "
    "trajectory.txt (t x y theta per scan), map.digest (per-tile counter digests) and "
    "stats.json.";
}  // namespace

int main(int argc, char** argv) {
  using namespace esfleet;
  // One malloc arena for all threads: the loop-closure worker's submaps would otherwise stay
  // in an arena of their own next to the mapping thread's peak (CSAIL: 52.2 -> 48.x MB peak
  // RSS; docs/benchmarks.md).
  mallopt(M_ARENA_MAX, 1);
  app::Program program("esfleet-leader", "leader", kDescription,
                       "130 stopped by SIGINT/SIGTERM (results written)");
  leader::LeaderOptions options;
  app::ParamTable params;
  leader::add_leader_flags(program.cli(), options, params);
  if (const auto code = program.parse(argc, argv)) return *code;
  return program.run([&] {
    leader::finish_leader_options(options, params);
    leader::LeaderApp app(std::move(options), program.stop_flag());
    return app.run();
  });
}
