// esfleet-sim: a fleet scan simulator. Loads a world map (ROS map_server YAML + image), drives N
// virtual robots through its free space, ray-casts their laser scans and publishes each robot's
// scans (with noisy odometry) on esfleet/robots/scan and its true pose on esfleet/sim/truth, in
// real time at the sensor rate; or writes CARMEN logs and true trajectories (--out-log), also
// as fast as possible without DDS (--offline). The model is in docs/sim.md, the program in
// sim_app.hpp.
//
// Exit codes: 0 done (--duration reached), 2 usage error, bad world file or DDS refused to
// start, 130 stopped by SIGINT/SIGTERM (outputs are complete up to the last tick either way).

#include "app/program.hpp"
#include "sim_app.hpp"
#include "sim_options.hpp"

namespace {
constexpr const char* kDescription =
    "esfleet-sim: simulates a fleet of robots driving through a world map (ROS map_server "
    "YAML + image) and publishes each robot's laser scans, with noisy odometry, on "
    "esfleet/robots/scan (robot ids <prefix>1..N) and its true pose on esfleet/sim/truth, in "
    "real time at --rate. --out-log also writes <dir>/<id>.log (CARMEN) and <dir>/<id>.truth; "
    "with --offline it only writes them, as fast as possible. Robots do not see or avoid each "
    "other. The model: docs/sim.md.";
}  // namespace

int main(int argc, char** argv) {
  using namespace esfleet;
  app::Program program("esfleet-sim", "sim", kDescription,
                       "130 stopped by SIGINT/SIGTERM (outputs complete up to the last tick)");
  sim::SimOptions o;
  sim::add_sim_flags(program.cli(), o);
  if (auto code = program.parse(argc, argv)) return *code;
  return program.run([&] {
    o.validate();
    sim::SimApp app(o, program.stop_flag());
    return app.run();
  });
}
