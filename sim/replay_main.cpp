// esfleet-replay: publishes the laser scans of a recorded CARMEN log on the DDS scan topic
// (esfleet/robots/scan) as robot --robot-id, the way a robot's laser driver would: at the
// recorded speed, a multiple of it, or as fast as the subscribers take them. Feeds
// `esfleet-leader --scan-topic ID`. How no scan is lost: replay_app.hpp. With --ros it
// publishes what a ROS 2 robot (or `ros2 bag play`) would instead: sensor_msgs/LaserScan,
// nav_msgs/Odometry and /tf under a ROS namespace, /tf_static once (ros_replay_writer.hpp).
//
// Exit codes: 0 done (also when a reader did not acknowledge the last scans in time: a warning
// says so); 2 usage error, unreadable or malformed log (the message names file and line), or
// DDS refused to start; 130 stopped by SIGINT/SIGTERM.

#include "app/program.hpp"
#include "replay_app.hpp"
#include "replay_options.hpp"

namespace {
constexpr const char* kDescription =
    "esfleet-replay: publishes the laser scans of a CARMEN log (.log/.clf, plain or .gz) on "
    "the DDS topic esfleet/robots/scan as robot --robot-id, for `esfleet-leader --scan-topic "
    "ID`. Reliable and lossless at any --rate: it never runs more than 40 scans ahead of the "
    "readers' acknowledgments. With --ros it publishes what a ROS 2 robot would instead: per "
    "scan nav_msgs/Odometry on <ns>/odom, the odom -> base transform on /tf and the "
    "sensor_msgs/LaserScan on <ns>/scan, all stamped with the log's time; the laser mount on "
    "/tf_static once.";
}  // namespace

int main(int argc, char** argv) {
  using namespace esfleet;
  app::Program program("esfleet-replay", "replay", kDescription, "130 stopped by SIGINT/SIGTERM");
  sim::ReplayOptions o;
  sim::add_replay_flags(program.cli(), o);
  if (auto code = program.parse(argc, argv)) return *code;
  return program.run([&] {
    o.validate();
    sim::ReplayApp app(o, program.stop_flag());
    return app.run();
  });
}
