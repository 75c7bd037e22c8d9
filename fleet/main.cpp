// esfleet-fleet: one command for a whole simulated fleet on this host. Starts a leader that maps
// a recorded log and shares the map, the scan simulator (esfleet-sim) with N virtual robots in
// the world that log maps, and one follower per robot that localises from the simulated scans
// in the leader's map and tracks itself. Shows who is localised, the error against the
// simulator's truth and CPU/memory live; stops everything cleanly on Ctrl-C or after
// --duration, and writes a per-robot summary (--summary). The work is in fleet_app.hpp.

#include "app/program.hpp"
#include "fleet_app.hpp"
#include "fleet_options.hpp"

namespace {
constexpr const char* kDescription =
    "esfleet-fleet: simulates a fleet on this host. Starts esfleet-leader (maps --log and "
    "shares the map), esfleet-sim (N virtual robots in --world, scans at --rate Hz over "
    "DDS, true poses on the truth topic) and one esfleet-follower per robot (localises in the "
    "shared map with no hint, then tracks). Shows each robot's state, error against the "
    "truth and CPU live; stops all on Ctrl-C or after --duration; writes --summary.\n"
    "--world must be the map of --log made by the leader with the same parameters (so both "
    "share one frame): the defaults are the bundled MIT CSAIL log and its world "
    "(data/worlds/README.md).";
}  // namespace

int main(int argc, char** argv) {
  using namespace esfleet;
  // Exit 1 also when a program could not start or exited early (the summary says which).
  app::Program program("esfleet-fleet", "fleet", kDescription);
  fleet::FleetOptions o;
  fleet::add_fleet_flags(program.cli(), o);
  if (auto code = program.parse(argc, argv)) return *code;
  return program.run([&] {
    o.validate();
    fleet::FleetApp app(o, program.stop_flag());
    return app.run();
  });
}
