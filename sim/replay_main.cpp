// esfleet-replay: publishes the laser scans of a recorded CARMEN log on the DDS scan topic
// (esfleet/robots/scan) as robot --robot-id, the way a robot's laser driver would: at the
// recorded speed, a multiple of it, or as fast as the subscribers take them. Feeds
// `esfleet-leader --scan-topic ID`.
//
// No scan is lost, whatever the rate: the scan topic is RELIABLE with KEEP_LAST 50, so a writer
// that ran more than 50 scans ahead of a reader's acknowledgments would drop scans from its
// history before the reader had them (and a reader missing one scan holds the ones after it
// until the repair, in a history of 50 too). The replay therefore never has more than
// kAckWindow scans unacknowledged: after every kAckWindow scans it waits until every matched
// reader has acknowledged all of them. The writer heartbeats every 100 ms, so the pace at
// --rate 0 is about kAckWindow scans per heartbeat round trip.
//
// Exit codes: 0 done (also when a reader did not acknowledge the last scans in time: a warning
// says so); 2 usage error, unreadable or malformed log (the message names file and line), or
// DDS refused to start; 130 stopped by SIGINT/SIGTERM.

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "app/dds_flags.hpp"
#include "esfleet/core/carmen_reader.hpp"
#include "esfleet/dds/map_convert.hpp"
#include "esfleet/dds/node.hpp"
#include "esfleet/dds/writer.hpp"

namespace {

using Clock = std::chrono::steady_clock;

constexpr int kExitError = 2;
constexpr int kExitInterrupted = 130;
/// Most scans in flight without acknowledgment; below the topic's KEEP_LAST depth of 50.
constexpr std::size_t kAckWindow = 40;
/// How often blocked waits look at the stop flag.
constexpr std::chrono::milliseconds kPoll{100};
/// At the end, how long to wait for the readers to acknowledge the last scans.
constexpr std::chrono::seconds kFinalAckTimeout{10};

std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) { g_stop.store(true); }

struct ReplayOptions {
  std::string log;             ///< CARMEN log to publish
  std::string robot_id;        ///< key of the scans on the topic
  double rate = 1.0;           ///< 1 = recorded speed, 2 = twice as fast, 0 = as fast as possible
  int domain = 0;              ///< DDS domain id
  std::string profile;         ///< Fast DDS XML profile; empty = Fast DDS defaults
  std::string secure;          ///< DDS Security directory (docs/security.md); empty = off
  std::size_t max_scans = 0;   ///< publish only the first N scans; 0 = all
  std::size_t first_scan = 0;  ///< skip the scans before this one
  int wait_subscribers = 1;    ///< before the first scan, wait for this many scan readers
  double wait_timeout = 30.0;  ///< ... at most this many seconds (then start anyway)
  bool odometry = true;        ///< send the log's odometry with each scan

  /// Throws std::invalid_argument naming the flag.
  void validate() const {
    if (robot_id.empty()) throw std::invalid_argument("--robot-id must not be empty");
    if (robot_id.size() > 64) throw std::invalid_argument("--robot-id: at most 64 characters");
    if (!(rate >= 0.0) || rate > 1e6) throw std::invalid_argument("--rate must be in [0, 1e6]");
    if (domain < 0 || domain > esfleet::dds::kMaxDomain) {
      throw std::invalid_argument("--domain must be in [0, 232]");
    }
    if (wait_subscribers < 0) throw std::invalid_argument("--wait-subscribers must be >= 0");
    if (!(wait_timeout >= 0.0)) throw std::invalid_argument("--wait-timeout must be >= 0");
  }
};

/// Waits until every matched reader acknowledged every scan written, checking the stop flag;
/// warns once if that takes long. Returns the seconds waited.
double wait_for_acks(const esfleet::dds::ScanWriter& writer, std::uint32_t seq) {
  const auto start = Clock::now();
  bool warned = false;
  while (!writer.wait_for_acknowledgments(kPoll) && !g_stop.load()) {
    if (!warned && Clock::now() - start > std::chrono::seconds(5)) {
      spdlog::warn("scans up to seq {} not acknowledged for 5 s by {} reader(s); waiting", seq,
                   writer.matched_readers());
      warned = true;
    }
  }
  return std::chrono::duration<double>(Clock::now() - start).count();
}

}  // namespace

int main(int argc, char** argv) {
  using namespace esfleet;
  spdlog::set_default_logger(spdlog::stderr_color_st("replay"));
  spdlog::set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");

  CLI::App cli{
      "esfleet-replay: publishes the laser scans of a CARMEN log (.log/.clf, plain or .gz) on "
      "the DDS topic esfleet/robots/scan as robot --robot-id, for `esfleet-leader --scan-topic "
      "ID`. Reliable and lossless at any --rate: it never runs more than 40 scans ahead of the "
      "readers' acknowledgments.\n"
      "Exit codes: 0 done, 2 usage error or bad log, 130 stopped by a signal.",
      "esfleet-replay"};
  ReplayOptions o;
  std::string odometry = "on";
  cli.add_option("--log", o.log, "CARMEN log to publish")->required();
  cli.add_option("--robot-id", o.robot_id, "robot id the scans are published under")->required();
  cli.add_option("--rate", o.rate,
                 "speed: 1 = as recorded, 2 = twice as fast, 0 = as fast as the readers "
                 "acknowledge")
      ->capture_default_str();
  esfleet::app::add_dds_flags(cli, o.domain, o.profile, o.secure);
  cli.add_option("--first-scan", o.first_scan,
                 "start at this scan of the log (counted from 0, before --max-scans applies)")
      ->capture_default_str();
  cli.add_option("--max-scans", o.max_scans, "publish only the first N scans (0 = all)")
      ->capture_default_str();
  cli.add_option("--wait-subscribers", o.wait_subscribers,
                 "before the first scan, wait until N scan readers are matched (0 = start at "
                 "once)")
      ->capture_default_str();
  cli.add_option("--wait-timeout", o.wait_timeout,
                 "wait at most S seconds for them, then start anyway")
      ->capture_default_str();
  cli.add_option("--odometry", odometry, "send the log's odometry with each scan")
      ->check(CLI::IsMember({"on", "off"}))
      ->capture_default_str();
  try {
    cli.parse(argc, argv);
    o.odometry = odometry == "on";
    o.validate();
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return cli.exit(e);  // --help
    spdlog::error("{} (run with --help for usage)", e.what());
    return kExitError;
  } catch (const std::exception& e) {
    spdlog::error("{} (run with --help for usage)", e.what());
    return kExitError;
  }

  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);

  std::vector<LaserScan> scans;
  try {
    scans = read_carmen_log(o.log, {}, o.max_scans, &g_stop);
    if (o.first_scan >= scans.size()) {
      throw std::invalid_argument("--first-scan " + std::to_string(o.first_scan) + ": " + o.log +
                                  " has only " + std::to_string(scans.size()) + " scans" +
                                  (o.max_scans > 0 ? " (with --max-scans)" : ""));
    }
    scans.erase(scans.begin(), scans.begin() + static_cast<std::ptrdiff_t>(o.first_scan));
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return kExitError;
  }
  const double log_s = scans.back().stamp - scans.front().stamp;
  spdlog::info("{}: {} scans over {:.1f} s of log; robot '{}', rate {}{}, odometry {}", o.log,
               scans.size(), log_s, o.robot_id, o.rate,
               o.rate == 0.0 ? " (as fast as acknowledged)" : "", odometry);

  std::unique_ptr<dds::Node> node;
  std::unique_ptr<dds::ScanWriter> writer;
  try {
    node = std::make_unique<dds::Node>(
        dds::NodeOptions{o.domain, o.profile, "esfleet-replay", o.secure});
    // In the robot's partition: readers of this robot get only its scans (docs/security.md).
    writer = std::make_unique<dds::ScanWriter>(*node, o.robot_id);
  } catch (const std::exception& e) {
    spdlog::error("DDS: {}", e.what());
    return kExitError;
  }

  if (o.wait_subscribers > 0) {
    spdlog::info("waiting up to {} s for {} reader(s) of {} on domain {}", o.wait_timeout,
                 o.wait_subscribers, writer->topic_name(), o.domain);
    const auto deadline = Clock::now() + std::chrono::duration<double>(o.wait_timeout);
    while (!g_stop.load() && Clock::now() < deadline &&
           !writer->wait_for_matched(o.wait_subscribers, kPoll)) {
    }
    if (g_stop.load()) {
      // Stopped before the first scan: nothing was sent.
    } else if (writer->matched_readers() < o.wait_subscribers) {
      spdlog::warn("only {} of {} reader(s) matched after {} s: starting anyway",
                   writer->matched_readers(), o.wait_subscribers, o.wait_timeout);
    } else {
      spdlog::info("{} reader(s) matched: starting", writer->matched_readers());
    }
  }

  const auto start = Clock::now();
  const std::size_t every = std::max<std::size_t>(1, scans.size() / 10);
  double ack_wait_s = 0.0;
  std::uint32_t seq = 0;
  for (std::size_t i = 0; i < scans.size() && !g_stop.load(); ++i) {
    if (o.rate > 0.0) {
      const auto due =
          start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(
                      (scans[i].stamp - scans.front().stamp) / o.rate));
      while (Clock::now() < due && !g_stop.load()) {
        std::this_thread::sleep_until(std::min(due, Clock::now() + kPoll));
      }
      if (g_stop.load()) break;
    }
    if (!o.odometry) scans[i].odometry.reset();
    if (!writer->write(dds::scan_to_msg(o.robot_id, seq, scans[i]))) {
      spdlog::warn("DDS refused scan seq {}", seq);
    }
    ++seq;
    if (seq % kAckWindow == 0) ack_wait_s += wait_for_acks(*writer, seq - 1);
    if (seq % every == 0 || seq == scans.size()) {
      spdlog::info("scan {}/{} (log time {:.1f} s), {} reader(s)", seq, scans.size(),
                   scans[i].stamp - scans.front().stamp, writer->matched_readers());
    }
  }
  const double send_s = std::chrono::duration<double>(Clock::now() - start).count();
  const bool interrupted = g_stop.load();

  // Scans still in flight die with the process unless the readers have them; bounded wait.
  const auto final_timeout =
      interrupted ? std::chrono::milliseconds(1000) : std::chrono::milliseconds(kFinalAckTimeout);
  const bool acked = writer->wait_for_acknowledgments(final_timeout);
  if (!acked) {
    spdlog::warn("{} reader(s) did not acknowledge every scan within {} s",
                 writer->matched_readers(), final_timeout.count() / 1000);
  }
  const std::uint64_t sent = writer->samples_written();
  spdlog::info(
      "{}sent {} scans{} in {:.2f} s: {:.0f} scans/s, {:.1f} kB; {:.2f} s waiting for "
      "acknowledgments; {} write failures; {} reader(s), {}",
      interrupted ? "interrupted: " : "", sent,
      seq > 0 ? fmt::format(" (seq 0..{})", seq - 1) : std::string(), send_s,
      send_s > 0 ? static_cast<double>(sent) / send_s : 0.0,
      static_cast<double>(writer->bytes_written()) / 1e3, ack_wait_s, writer->write_failures(),
      writer->matched_readers(), acked ? "all acknowledged" : "NOT all acknowledged");
  writer.reset();  // before the node (node.hpp)
  return interrupted ? kExitInterrupted : 0;
}
