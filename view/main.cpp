// esfleet-view: the fleet in a browser (view_app.hpp).

#include "app/program.hpp"
#include "view_app.hpp"
#include "view_options.hpp"

namespace {
constexpr const char* kDescription =
    "esfleet-view: a read-only DDS participant that shows the shared map and every robot in a "
    "web browser. It serves one page over HTTP on --port (open http://HOST:PORT/), streams the "
    "map to it over a WebSocket as tiles (the whole map on connect, then only the tiles that "
    "change), with every robot's pose, state and trail, the fleet's table and the leader's "
    "presence; the map downloads as ROS map.yaml + map.pgm and as PNG. It never writes to DDS. "
    "Protocol, limits and figures: docs/view.md.";
}  // namespace

int main(int argc, char** argv) {
  using namespace esfleet;
  app::Program program("esfleet-view", "view", kDescription,
                       "130 stopped by SIGINT/SIGTERM (0 at --timeout)");
  view::ViewOptions options;
  view::add_view_flags(program.cli(), options);
  if (const auto code = program.parse(argc, argv)) return *code;
  return program.run([&] {
    view::ViewApp app(std::move(options), program.stop_flag());
    return app.run();
  });
}
