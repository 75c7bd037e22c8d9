// security_cost: one side of the DDS Security cost measurement (security_cost.sh,
// docs/security.md). Map tiles of --bytes payload go from a writer process to a reader process.
//   --role reader: subscribes to the tile topic, exits after --count tiles or 60 s.
//   --role writer: reports the discovery time (Node creation until the reader is matched), then
//     writes --count tiles over 100 keys, waiting for the acknowledgments after every 40 (as
//     esfleet-replay does: reliable throughput, nothing overwritten), and reports tiles/s and MB/s.
// Output (writer): one line "discovery_ms X tiles_per_s Y mb_per_s Z".
//
// usage: security_cost --role reader|writer --domain N [--profile FILE] [--secure DIR]
//                      [--count N] [--bytes B]

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <thread>
#include <vector>

#include <esfleet/msg/esfleet.h>

#include "esfleet/dds/node.hpp"
#include "esfleet/dds/reader.hpp"
#include "esfleet/dds/to_msg.hpp"
#include "esfleet/dds/topics.hpp"
#include "esfleet/dds/writer.hpp"

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

}  // namespace

int main(int argc, char** argv) {
  esfleet::dds::NodeOptions options;
  options.name = "security_cost";
  std::string role;
  int count = 5000;
  std::size_t bytes = esfleet::dds::kTilePartBytes;  // the most one tile part holds
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i], value = argv[i + 1];
    if (flag == "--role")
      role = value;
    else if (flag == "--domain")
      options.domain = std::atoi(value.c_str());
    else if (flag == "--profile")
      options.profile_file = value;
    else if (flag == "--secure")
      options.secure_dir = value;
    else if (flag == "--count")
      count = std::atoi(value.c_str());
    else if (flag == "--bytes")
      bytes = static_cast<std::size_t>(std::atol(value.c_str()));
    else {
      std::fprintf(stderr, "security_cost: unknown flag %s\n", flag.c_str());
      return 2;
    }
  }
  if (bytes > esfleet::dds::kTilePartBytes) {
    // Protocol 3 bounds a part's payload; the writer would refuse every sample.
    std::fprintf(stderr, "security_cost: --bytes at most %zu (one tile part)\n",
                 esfleet::dds::kTilePartBytes);
    return 2;
  }
  try {
    const auto start = Clock::now();
    esfleet::dds::Node node(options);
    if (role == "reader") {
      std::atomic<int> received{0};
      esfleet::dds::TileReader reader(
          node, [&](const esfleet::msg::MapTile&, const esfleet::dds::SampleMeta&) { ++received; });
      while (received.load() < count && ms_since(start) < 60'000) {
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
      std::printf("received %d\n", received.load());
      return received.load() >= count ? 0 : 1;
    }
    if (role != "writer") {
      std::fprintf(stderr, "security_cost: --role reader|writer\n");
      return 2;
    }
    esfleet::dds::TileWriter writer(node);
    if (!writer.wait_for_matched(1, std::chrono::seconds(30))) {
      std::fprintf(stderr, "security_cost: no reader matched in 30 s\n");
      return 1;
    }
    const double discovery_ms = ms_since(start);
    esfleet::msg::MapTile tile;
    tile.map_id("cost");
    tile.protocol(esfleet::dds::kProtocolVersion);
    tile.payload(std::vector<std::uint8_t>(bytes, 0x5a));
    tile.parts(1);
    tile.payload_size(static_cast<std::uint32_t>(bytes));
    const auto t0 = Clock::now();
    for (int i = 0; i < count; ++i) {
      tile.tx(i % 10);
      tile.ty((i / 10) % 10);
      tile.version(static_cast<std::uint64_t>(i));
      writer.write(tile);
      if ((i + 1) % 40 == 0) writer.wait_for_acknowledgments(std::chrono::seconds(10));
    }
    writer.wait_for_acknowledgments(std::chrono::seconds(10));
    const double s = ms_since(t0) / 1e3;
    std::printf("discovery_ms %.1f tiles_per_s %.0f mb_per_s %.1f\n", discovery_ms, count / s,
                static_cast<double>(count) * static_cast<double>(bytes) / s / 1e6);
    std::fflush(stdout);
    // Let the reader take the last samples before this participant goes away.
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "security_cost: %s\n", e.what());
    return 2;
  }
}
