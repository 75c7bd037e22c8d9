// dds_roundtrip_peer: one side of a MapTile exchange between real processes, driven by
// dds_process_test.cpp (and usable by hand to try a Fast DDS profile between two shells).
//
//   dds_roundtrip_peer --role pub --domain 101 [--profile F] [--count 50] [--versions 3]
//       Writes `count` tiles, each in versions 1..`versions` (newest last), prints
//       "READY written=<n> bytes=<b> failures=<f>", then stays up (the transient-local history
//       serves late joiners) until SIGTERM/SIGINT or --linger-ms passes.
//   dds_roundtrip_peer --role sub --domain 101 [--profile F] [--count 50] [--versions 3]
//       Waits until `count` tiles arrived (or --timeout-ms), keeps listening --settle-ms more to
//       catch surplus samples, prints "RESULT received=.. distinct=.. newest=.. payload_ok=..
//       bytes=.. match_ms=.. first_ms=.. all_ms=..", exits 0 if it got exactly `count` samples,
//       one per tile, all at version `versions` with the right payload; else 1.
//
// Just before tearing the node down both print "UDP <ip:port>" for every UDP socket and
// "SHM <path>" for every /dev/shm/fastrtps* file the process has open or mapped, so the driver
// can check which transports the profile selected and that a clean exit removed the files.
// Exit codes: 0 success, 1 check failed or timed out, 2 bad arguments or configuration (e.g. a
// missing profile file; the message names it).

#include <arpa/inet.h>
#include <netinet/in.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "esfleet/core/clock.hpp"
#include "esfleet/dds/node.hpp"
#include "esfleet/dds/reader.hpp"
#include "esfleet/dds/writer.hpp"

namespace {

using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) { g_stop.store(true); }

struct Args {
  std::string role;
  int domain = -1;
  std::string profile;
  int count = 50;
  int versions = 3;
  int payload_bytes = 512;
  int timeout_ms = 10000;
  int settle_ms = 300;
  int linger_ms = 20000;
};

[[noreturn]] void usage(const std::string& why) {
  std::cerr << "dds_roundtrip_peer: " << why
            << "\nusage: dds_roundtrip_peer --role pub|sub --domain N [--profile FILE]"
               " [--count N] [--versions N] [--payload-bytes N] [--timeout-ms N]"
               " [--settle-ms N] [--linger-ms N]\n";
  std::exit(2);
}

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string key = argv[i];
    if (i + 1 >= argc) usage("missing value for " + key);
    const std::string value = argv[++i];
    auto number = [&] {
      try {
        return std::stoi(value);
      } catch (const std::exception&) {
        usage("not a number for " + key + ": " + value);
      }
    };
    if (key == "--role") {
      a.role = value;
    } else if (key == "--domain") {
      a.domain = number();
    } else if (key == "--profile") {
      a.profile = value;
    } else if (key == "--count") {
      a.count = number();
    } else if (key == "--versions") {
      a.versions = number();
    } else if (key == "--payload-bytes") {
      a.payload_bytes = number();
    } else if (key == "--timeout-ms") {
      a.timeout_ms = number();
    } else if (key == "--settle-ms") {
      a.settle_ms = number();
    } else if (key == "--linger-ms") {
      a.linger_ms = number();
    } else {
      usage("unknown option " + key);
    }
  }
  if (a.role != "pub" && a.role != "sub") usage("--role must be pub or sub");
  if (a.domain < 0) usage("--domain is required");
  if (a.count < 1 || a.versions < 1 || a.payload_bytes < 0) usage("bad count/versions/payload");
  return a;
}

/// Deterministic payload of tile `index` at `version`, so the subscriber can verify it.
std::vector<std::uint8_t> payload_of(int index, std::uint64_t version, int bytes) {
  std::vector<std::uint8_t> p(static_cast<std::size_t>(bytes));
  for (std::size_t i = 0; i < p.size(); ++i) {
    p[i] = static_cast<std::uint8_t>(
        (static_cast<std::uint64_t>(index) * 131u + version * 17u + i * 7u) & 0xffu);
  }
  return p;
}

/// Every /dev/shm/fastrtps* file this process has mapped or open.
std::set<std::string> own_shm_files() {
  std::set<std::string> files;
  auto consider = [&](const std::string& path) {
    if (path.rfind("/dev/shm/", 0) == 0 && path.find("fastrtps") != std::string::npos) {
      files.insert(path.substr(0, path.find(" (deleted)")));
    }
  };
  std::ifstream maps("/proc/self/maps");
  for (std::string line; std::getline(maps, line);) {
    if (auto slash = line.find('/'); slash != std::string::npos) consider(line.substr(slash));
  }
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator("/proc/self/fd", ec)) {
    std::error_code link_ec;
    const fs::path target = fs::read_symlink(entry.path(), link_ec);
    if (!link_ec) consider(target.string());
  }
  return files;
}

/// Local "ip:port" of every UDP socket (IPv4) this process has open: the inodes of its socket
/// fds looked up in /proc/self/net/udp, whose addresses are the raw s_addr in hex.
std::set<std::string> own_udp_sockets() {
  std::set<std::string> inodes;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator("/proc/self/fd", ec)) {
    std::error_code link_ec;
    const std::string target = fs::read_symlink(entry.path(), link_ec).string();
    if (!link_ec && target.rfind("socket:[", 0) == 0) {
      inodes.insert(target.substr(8, target.size() - 9));
    }
  }
  std::set<std::string> sockets;
  std::ifstream udp("/proc/self/net/udp");
  std::string line;
  std::getline(udp, line);  // header
  while (std::getline(udp, line)) {
    std::istringstream in(line);
    std::string slot, local, remote, state, queues, timer, retransmits, uid, timeout, inode;
    in >> slot >> local >> remote >> state >> queues >> timer >> retransmits >> uid >> timeout >>
        inode;
    const auto colon = local.find(':');
    if (!inodes.count(inode) || colon == std::string::npos) continue;
    in_addr addr{};
    addr.s_addr = static_cast<in_addr_t>(std::stoul(local.substr(0, colon), nullptr, 16));
    char ip[INET_ADDRSTRLEN] = {};
    inet_ntop(AF_INET, &addr, ip, sizeof ip);
    sockets.insert(std::string(ip) + ":" +
                   std::to_string(std::stoul(local.substr(colon + 1), nullptr, 16)));
  }
  return sockets;
}

/// Prints the transports in use: "UDP <ip:port>" and "SHM <path>" lines.
void report_transports() {
  for (const auto& s : own_udp_sockets()) std::cout << "UDP " << s << "\n";
  for (const auto& f : own_shm_files()) std::cout << "SHM " << f << "\n";
  std::cout << std::flush;
}

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

esfleet::msg::MapTile make_tile(int index, std::uint64_t version, int payload_bytes) {
  esfleet::msg::MapTile tile;
  tile.map_id("roundtrip");
  tile.tx(index % 10 - 5);
  tile.ty(index / 10);
  tile.protocol(esfleet::dds::kProtocolVersion);
  tile.epoch(1);
  tile.version(version);
  tile.cell_size(0.05f);
  tile.tile_edge(64);
  tile.encoding(esfleet::msg::kEncodingRaw);
  tile.cells(64 * 64);
  tile.payload(payload_of(index, version, payload_bytes));
  tile.leader_stamp_ns(static_cast<std::uint64_t>(esfleet::realtime_ns()));
  return tile;
}

int run_pub(const Args& a) {
  esfleet::dds::Node node({a.domain, a.profile, "roundtrip_pub"});
  std::uint64_t written = 0, bytes = 0, failures = 0;
  {
    esfleet::dds::TileWriter writer(node);
    for (int v = 1; v <= a.versions; ++v) {
      for (int i = 0; i < a.count; ++i) {
        writer.write(make_tile(i, static_cast<std::uint64_t>(v), a.payload_bytes));
      }
    }
    written = writer.samples_written();
    bytes = writer.bytes_written();
    failures = writer.write_failures();
    std::cout << "READY written=" << written << " bytes=" << bytes << " failures=" << failures
              << std::endl;
    const auto deadline = Clock::now() + std::chrono::milliseconds(a.linger_ms);
    while (!g_stop.load() && Clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    std::cout << "STOP matched_readers=" << writer.matched_readers() << std::endl;
    report_transports();
  }
  return failures == 0 ? 0 : 1;
}

int run_sub(const Args& a) {
  const auto t0 = Clock::now();
  esfleet::dds::Node node({a.domain, a.profile, "roundtrip_sub"});
  struct Seen {
    std::uint64_t version = 0;
    bool payload_ok = true;
  };
  std::mutex mutex;
  std::map<std::pair<int, int>, Seen> seen;
  std::uint64_t received = 0;
  bool payload_ok = true;
  double first_ms = -1;
  std::int64_t latency_sum_ns = 0;

  esfleet::dds::TileReader reader(
      node, [&](const esfleet::msg::MapTile& tile, const esfleet::dds::SampleMeta& meta) {
        std::lock_guard lock(mutex);
        if (first_ms < 0) first_ms = ms_since(t0);
        ++received;
        const int index = (tile.ty() * 10) + tile.tx() + 5;
        const bool ok = tile.payload() == payload_of(index, tile.version(), a.payload_bytes) &&
                        tile.map_id() == "roundtrip" && tile.cells() == 64 * 64 &&
                        !meta.writer_guid.empty();
        payload_ok = payload_ok && ok;
        latency_sum_ns += meta.reception_ns - meta.source_timestamp_ns;
        Seen& s = seen[{tile.tx(), tile.ty()}];
        s.version = std::max(s.version, tile.version());
        s.payload_ok = s.payload_ok && ok;
      });

  double match_ms = -1;
  double all_ms = -1;
  const auto deadline = t0 + std::chrono::milliseconds(a.timeout_ms);
  while (!g_stop.load() && Clock::now() < deadline) {
    if (match_ms < 0 && reader.matched_writers() > 0) match_ms = ms_since(t0);
    if (reader.samples_received() >= static_cast<std::uint64_t>(a.count)) {
      all_ms = ms_since(t0);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  // Surplus samples (older versions, duplicates) would arrive right after the first ones.
  std::this_thread::sleep_for(std::chrono::milliseconds(a.settle_ms));

  int result = 1;
  {
    std::lock_guard lock(mutex);
    int newest = 0;
    for (const auto& [key, s] : seen) {
      if (s.version == static_cast<std::uint64_t>(a.versions) && s.payload_ok) ++newest;
    }
    std::cout << "RESULT received=" << received << " distinct=" << seen.size()
              << " newest=" << newest << " payload_ok=" << (payload_ok ? 1 : 0)
              << " bytes=" << reader.bytes_received() << " match_ms=" << match_ms
              << " first_ms=" << first_ms << " all_ms=" << all_ms << " mean_latency_us="
              << (received > 0
                      ? static_cast<double>(latency_sum_ns) / 1e3 / static_cast<double>(received)
                      : 0.0)
              << std::endl;
    const auto n = static_cast<std::uint64_t>(a.count);
    if (received == n && seen.size() == n && newest == a.count && payload_ok) result = 0;
  }
  report_transports();
  return result;
}

}  // namespace

int main(int argc, char** argv) {
  const Args args = parse(argc, argv);
  std::signal(SIGTERM, on_signal);
  std::signal(SIGINT, on_signal);
  try {
    return args.role == "pub" ? run_pub(args) : run_sub(args);
  } catch (const std::exception& e) {
    std::cerr << "dds_roundtrip_peer: error: " << e.what() << std::endl;
    return 2;
  }
}
