// esfleet-follower: rebuilds the leader's shared map and localises itself in it
// (follower_app.hpp).

#include "app/param_table.hpp"
#include "app/program.hpp"
#include "follower_app.hpp"
#include "follower_options.hpp"

namespace {
constexpr const char* kDescription =
    "esfleet-follower: receives the leader's shared map over DDS (topics esfleet/map/tiles, "
    "esfleet/map/tile_deltas, esfleet/map/meta) and keeps a copy whose counters equal the "
    "leader's. Given its own scans (--log or --scan-topic) it finds its pose in that map with "
    "the (mu+1)-ES, globally (no hint) or around --hint, then tracks it, relocalises when "
    "lost, and publishes pose and status on esfleet/robots/pose.\n"
    "With --save-map DIR it writes DIR/map.pgm, map.yaml (ROS map_server), map.png, "
    "map.digest (per-tile counter digests) and stats.json at exit, and on SIGUSR1.";
}  // namespace

int main(int argc, char** argv) {
  using namespace esfleet;
  app::Program program("esfleet-follower", "follower", kDescription,
                       "3 --timeout reached (map saved)");
  follower::FollowerOptions options;
  app::ParamTable params;
  follower::add_follower_flags(program.cli(), options, params);
  if (const auto code = program.parse(argc, argv)) return *code;
  return program.run([&] {
    follower::finish_follower_options(options, params);
    follower::FollowerApp app(std::move(options), program.stop_flag());
    return app.run();
  });
}
