// rogue_writer: a participant that tries to publish what its identity may not (tests/security).
// It creates a writer of --topic (tiles: map tiles under --map-id with a huge version, so a
// follower that accepted one would apply it; pose: a pose of --robot-id) in --partition, writes
// one sample every 100 ms for --seconds and prints how many readers matched at most:
//   "rogue: refused locally: <reason>"   exit 3 (its own permissions forbid the writer)
//   "rogue: matched at most N reader(s), wrote K sample(s)"   exit 0
// The test scripts require "refused locally" or "matched at most 0".
//
// usage: rogue_writer --domain N [--profile FILE] [--secure DIR] --topic tiles|pose
//                     [--partition P] [--map-id ID] [--robot-id ID] [--seconds S]

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <memory>
#include <string>
#include <thread>

#include <esfleet/msg/esfleet.h>

#include "esfleet/dds/node.hpp"
#include "esfleet/dds/to_msg.hpp"
#include "esfleet/dds/topics.hpp"
#include "esfleet/dds/writer.hpp"

namespace {

struct Options {
  esfleet::dds::NodeOptions node;
  std::string topic = "tiles";
  std::string partition;
  std::string map_id = "map";
  std::string robot_id = "robot-2";
  double seconds = 5.0;
};

int usage(const char* why) {
  std::fprintf(stderr,
               "rogue_writer: %s\nusage: rogue_writer --domain N [--profile FILE] [--secure DIR] "
               "--topic tiles|pose [--partition P] [--map-id ID] [--robot-id ID] [--seconds S]\n",
               why);
  return 2;
}

template <class Msg>
int run(esfleet::dds::Node& node, const Options& o, const Msg& sample) {
  std::unique_ptr<esfleet::dds::Writer<Msg>> writer;
  try {
    writer = std::make_unique<esfleet::dds::Writer<Msg>>(node, o.partition);
  } catch (const std::exception& e) {
    std::printf("rogue: refused locally: %s\n", e.what());
    return 3;
  }
  int matched = 0;
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(o.seconds);
  while (std::chrono::steady_clock::now() < end) {
    matched = std::max(matched, writer->matched_readers());
    writer->write(sample);
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  std::printf("rogue: matched at most %d reader(s), wrote %llu sample(s)\n", matched,
              static_cast<unsigned long long>(writer->samples_written()));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  o.node.name = "rogue_writer";
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if (i + 1 >= argc) return usage(("missing value of " + flag).c_str());
    const std::string value = argv[++i];
    if (flag == "--domain") {
      o.node.domain = std::atoi(value.c_str());
    } else if (flag == "--profile") {
      o.node.profile_file = value;
    } else if (flag == "--secure") {
      o.node.secure_dir = value;
    } else if (flag == "--topic") {
      o.topic = value;
    } else if (flag == "--partition") {
      o.partition = value;
    } else if (flag == "--map-id") {
      o.map_id = value;
    } else if (flag == "--robot-id") {
      o.robot_id = value;
    } else if (flag == "--seconds") {
      o.seconds = std::atof(value.c_str());
    } else {
      return usage(("unknown flag " + flag).c_str());
    }
  }
  if (o.topic != "tiles" && o.topic != "pose") return usage("--topic must be tiles or pose");

  std::unique_ptr<esfleet::dds::Node> node;
  try {
    node = std::make_unique<esfleet::dds::Node>(o.node);
  } catch (const std::exception& e) {
    std::printf("rogue: refused locally: %s\n", e.what());
    return 3;
  }
  if (o.topic == "tiles") {
    esfleet::msg::MapTile tile;
    tile.map_id(o.map_id);
    tile.protocol(esfleet::dds::kProtocolVersion);
    tile.epoch(0xffffffffu);
    tile.version(1'000'000'000);
    tile.cell_size(0.05f);
    tile.tile_edge(64);
    tile.encoding(0);
    tile.cells(64 * 64);
    // One part of the largest size the bounded type allows (protocol 3).
    tile.payload(std::vector<std::uint8_t>(esfleet::dds::kTilePartBytes, 0xab));
    tile.parts(1);
    tile.payload_size(static_cast<std::uint32_t>(esfleet::dds::kTilePartBytes));
    return run(*node, o, tile);
  }
  esfleet::msg::RobotPose pose;
  pose.robot_id(o.robot_id);
  pose.protocol(esfleet::dds::kProtocolVersion);
  pose.x(1234.0);
  pose.y(-1234.0);
  return run(*node, o, pose);
}
