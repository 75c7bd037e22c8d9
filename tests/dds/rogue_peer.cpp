// A hostile participant for the rogue-peer test (tests/dds/rogue_peer_test.sh): joins a domain
// with plain Fast DDS (not esfleet's Writer, which refuses another protocol version), learns the
// leader's map from its tiles and summaries, then, until SIGINT/SIGTERM or --duration, publishes
// every --period-ms a round of bad samples for the leader's map id:
//   tiles:  undecodable zlib, raw payload of the wrong length, cells != tile_edge^2, another
//           tile_edge or cell_size than the map's, keys far out of range (plus --key-flood new
//           out-of-range keys per round, at most --flood-max in all, each also a delta key),
//           stale versions (below the leader's) with well-formed payloads, version 0, the old
//           protocol 2, unknown encoding, a newer epoch with an undecodable payload, and every
//           --oversized-every rounds a --oversized-mb payload (far beyond the bounded type: its
//           writers have dynamic payload pools, which serialize any size);
//   deltas: base_version >= version, a bogus base (the replica lacks it), undecodable payload,
//           another tile_edge;
//   summaries: absurd bounds, more tiles than the bounds hold, another tile_edge / cell_size in
//           the same epoch, an older epoch, another map id.
// Every bad sample is one the follower can tell from the leader's by validation alone; a
// well-formed newer tile cannot be (that takes DDS Security, docs/security.md).
// At the end it prints "rogue: sent N samples (T tiles, D deltas, M summaries, O oversized,
// F flood keys) in R rounds" and "rogue: leader's map: T tiles in K part keys" (the keys the
// leader's tile writer used, the measure of tile_topic's kMaxTileKeys). --passive: learn and
// report only, send nothing.
//
// usage: rogue_peer --domain N --profile FILE [--period-ms 100] [--duration S]
//                   [--key-flood K] [--flood-max N] [--oversized-every N] [--oversized-mb MB]
//                   [--passive 1]

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <mutex>
#include <optional>
#include <random>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <tuple>
#include <type_traits>
#include <vector>

#include <esfleet/msg/esfleetPubSubTypes.h>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

#include "esfleet/core/tile_codec.hpp"
#include "esfleet/dds/topics.hpp"

namespace {

namespace fdds = eprosima::fastdds::dds;
using eprosima::fastrtps::types::ReturnCode_t;
namespace msg = esfleet::msg;

std::atomic<bool> g_stop{false};
void on_signal(int) { g_stop = true; }

struct Options {
  int domain = 0;
  std::string profile;
  int period_ms = 100;
  double duration = 0.0;  ///< 0 = until a signal
  int key_flood = 10;
  long flood_max = 1'000'000'000;  ///< flood keys in all
  int oversized_every = 20;
  int oversized_mb = 16;
  bool passive = false;
};

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) throw std::invalid_argument("missing value for " + a);
    const std::string v = argv[++i];
    if (a == "--domain") {
      o.domain = std::stoi(v);
    } else if (a == "--profile") {
      o.profile = v;
    } else if (a == "--period-ms") {
      o.period_ms = std::stoi(v);
    } else if (a == "--duration") {
      o.duration = std::stod(v);
    } else if (a == "--key-flood") {
      o.key_flood = std::stoi(v);
    } else if (a == "--oversized-every") {
      o.oversized_every = std::stoi(v);
    } else if (a == "--oversized-mb") {
      o.oversized_mb = std::stoi(v);
    } else if (a == "--flood-max") {
      o.flood_max = std::stol(v);
    } else if (a == "--passive") {
      o.passive = v != "0";
    } else {
      throw std::invalid_argument("unknown option " + a);
    }
  }
  return o;
}

/// What the rogue learned of the leader's map.
struct Learned {
  std::string map_id;
  std::uint32_t epoch = 0;
  float cell_size = 0.0f;
  std::uint16_t tile_edge = 0;
  std::map<std::pair<std::int32_t, std::int32_t>, std::uint64_t> versions;  ///< key -> newest
  std::size_t part_keys = 0;  ///< (tx, ty, part) keys the leader's tiles used
  std::optional<msg::MapMeta> meta;
};

/// Learns the leader's map from its samples (never from the rogue's own, which its readers
/// also receive: they would teach it its own bogus layouts and versions).
class Spy : public fdds::DataReaderListener {
 public:
  void on_data_available(fdds::DataReader* reader) override {
    fdds::SampleInfo info;
    const auto own = [&] { return info.sample_identity.writer_guid().guidPrefix == self; };
    if (reader->type().get_type_name() == msg::MapTilePubSubType().getName()) {
      msg::MapTile t;
      while (reader->take_next_sample(&t, &info) == ReturnCode_t::RETCODE_OK) {
        if (!info.valid_data || own() || t.protocol() != msg::kProtocolVersion) continue;
        std::lock_guard lock(mutex);
        learned.map_id = t.map_id().to_string();
        learned.epoch = t.epoch();
        learned.cell_size = t.cell_size();
        learned.tile_edge = t.tile_edge();
        auto& v = learned.versions[{t.tx(), t.ty()}];
        v = std::max(v, t.version());
        parts.insert({t.tx(), t.ty(), t.part()});
        learned.part_keys = parts.size();
      }
    } else {
      msg::MapMeta m;
      while (reader->take_next_sample(&m, &info) == ReturnCode_t::RETCODE_OK) {
        if (!info.valid_data || own() || m.protocol() != msg::kProtocolVersion) continue;
        std::lock_guard lock(mutex);
        learned.meta = m;
      }
    }
  }
  eprosima::fastrtps::rtps::GuidPrefix_t self;  ///< the rogue's own participant
  std::mutex mutex;
  Learned learned;
  std::set<std::tuple<std::int32_t, std::int32_t, std::uint16_t>> parts;
};

template <class PubSub>
fdds::Topic* make_topic(fdds::DomainParticipant* p, std::string_view name) {
  fdds::TypeSupport type(new PubSub());
  if (type.register_type(p) != ReturnCode_t::RETCODE_OK) {
    throw std::runtime_error("register_type failed");
  }
  fdds::Topic* topic =
      p->create_topic(std::string(name), type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
  if (topic == nullptr) throw std::runtime_error("create_topic " + std::string(name) + " failed");
  return topic;
}

/// The QoS esfleet's endpoints use (dds/src/endpoints.cpp), so the follower matches; resource
/// limits unlimited, as a hostile peer would have them. A writer's pool is dynamic: with a
/// bounded type Fast DDS 2.9 turns the default PREALLOCATED_WITH_REALLOC into PREALLOCATED,
/// which cannot serialize more than the bound; a hostile writer does not care about the bound.
template <class Qos>
void esfleet_qos(Qos& q, bool transient_local, int depth) {
  if constexpr (std::is_same_v<Qos, fdds::DataWriterQos>) {
    q.endpoint().history_memory_policy = eprosima::fastrtps::rtps::DYNAMIC_RESERVE_MEMORY_MODE;
  }
  q.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
  q.durability().kind =
      transient_local ? fdds::TRANSIENT_LOCAL_DURABILITY_QOS : fdds::VOLATILE_DURABILITY_QOS;
  q.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
  q.history().depth = depth;
  q.resource_limits().max_samples = 0;
  q.resource_limits().max_instances = 0;
  q.resource_limits().max_samples_per_instance = 0;
}

std::vector<std::uint8_t> garbage(std::mt19937& rng, std::size_t n) {
  std::vector<std::uint8_t> out(n);
  for (auto& b : out) b = static_cast<std::uint8_t>(rng());
  return out;
}

}  // namespace

int main(int argc, char** argv) try {
  const Options o = parse(argc, argv);
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  if (!o.profile.empty()) setenv("FASTRTPS_DEFAULT_PROFILES_FILE", o.profile.c_str(), 1);

  auto* factory = fdds::DomainParticipantFactory::get_instance();
  factory->load_profiles();
  fdds::DomainParticipantQos pqos = factory->get_default_participant_qos();
  pqos.name("esfleet-rogue");
  fdds::DomainParticipant* participant = factory->create_participant(o.domain, pqos);
  if (participant == nullptr) throw std::runtime_error("create_participant failed");
  fdds::Topic* tiles = make_topic<msg::MapTilePubSubType>(participant, esfleet::dds::kTileTopic);
  fdds::Topic* deltas =
      make_topic<msg::MapTileDeltaPubSubType>(participant, esfleet::dds::kTileDeltaTopic);
  fdds::Topic* metas = make_topic<msg::MapMetaPubSubType>(participant, esfleet::dds::kMetaTopic);

  fdds::Publisher* pub = participant->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
  fdds::Subscriber* sub = participant->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
  if (pub == nullptr || sub == nullptr) throw std::runtime_error("publisher/subscriber failed");
  fdds::DataWriterQos wq = fdds::DATAWRITER_QOS_DEFAULT;
  esfleet_qos(wq, true, 1);
  fdds::DataWriter* tile_w = pub->create_datawriter(tiles, wq);
  fdds::DataWriter* meta_w = pub->create_datawriter(metas, wq);
  esfleet_qos(wq, false, 64);
  fdds::DataWriter* delta_w = pub->create_datawriter(deltas, wq);
  Spy spy;
  spy.self = participant->guid().guidPrefix;
  fdds::DataReaderQos rq = fdds::DATAREADER_QOS_DEFAULT;
  esfleet_qos(rq, true, 1);
  fdds::DataReader* tile_r = sub->create_datareader(tiles, rq, &spy);
  fdds::DataReader* meta_r = sub->create_datareader(metas, rq, &spy);
  if (!tile_w || !meta_w || !delta_w || !tile_r || !meta_r) {
    throw std::runtime_error("creating writers/readers failed");
  }

  // Wait for the leader's map, then a second more, so followers hold it before the attack.
  const auto start = std::chrono::steady_clock::now();
  const auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  auto done = [&] { return g_stop.load() || (o.duration > 0 && elapsed() > o.duration); };
  Learned l;
  while (!done()) {
    {
      std::lock_guard lock(spy.mutex);
      l = spy.learned;
    }
    if (!l.versions.empty()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  if (!done()) std::this_thread::sleep_for(std::chrono::seconds(1));
  std::fprintf(stderr, "rogue: %s map '%s' epoch %u (%zu tiles known)\n",
               o.passive ? "watching" : "attacking", l.map_id.c_str(), l.epoch, l.versions.size());

  std::mt19937 rng(213);
  std::uint64_t n_tiles = 0, n_deltas = 0, n_metas = 0, n_oversized = 0, n_flood = 0, rounds = 0;
  // Every bad sample as a message of one part (protocol 3), so that the follower judges its
  // content, not its part fields.
  const auto write_tile = [&](msg::MapTile t) {
    t.parts(1);
    t.payload_size(static_cast<std::uint32_t>(t.payload().size()));
    n_tiles += tile_w->write(&t) ? 1 : 0;
  };
  const auto write_delta = [&](msg::MapTileDelta d) {
    d.parts(1);
    d.payload_size(static_cast<std::uint32_t>(d.payload().size()));
    n_deltas += delta_w->write(&d) ? 1 : 0;
  };
  const auto write_meta = [&](msg::MapMeta m) { n_metas += meta_w->write(&m) ? 1 : 0; };
  std::int32_t flood_next = 1'000'000;
  std::vector<std::int32_t> flood_deltas;  ///< this round's flood keys, for the deltas
  while (o.passive && !done()) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  while (!done()) {
    {
      std::lock_guard lock(spy.mutex);
      l = spy.learned;
    }
    ++rounds;
    const std::uint32_t cells = static_cast<std::uint32_t>(l.tile_edge) * l.tile_edge;
    // A known key of the leader's and its newest version.
    auto it = l.versions.begin();
    std::advance(it, static_cast<long>(rng() % l.versions.size()));
    const auto [key, newest] = *it;
    // A well-formed tile of the map's layout (the payload of a valid tile).
    const auto base = [&](std::uint64_t version) {
      msg::MapTile t;
      t.map_id(l.map_id);
      t.tx(key.first);
      t.ty(key.second);
      t.protocol(msg::kProtocolVersion);
      t.epoch(l.epoch);
      t.version(version);
      t.cell_size(l.cell_size);
      t.tile_edge(l.tile_edge);
      t.cells(cells);
      const std::vector<std::uint32_t> hit(cells, 7), err(cells, 3);
      const esfleet::EncodedTile e = esfleet::encode_tile(hit, err);
      t.encoding(static_cast<std::uint8_t>(e.encoding));
      t.payload(e.payload);
      t.leader_stamp_ns(0);
      return t;
    };
    const std::uint64_t ahead = newest + 1000;
    msg::MapTile t = base(ahead);
    t.payload(garbage(rng, 300));  // undecodable zlib
    write_tile(t);
    t = base(ahead);
    t.encoding(msg::kEncodingRaw);
    t.payload(garbage(rng, 100));  // raw of the wrong length
    write_tile(t);
    t = base(ahead);
    t.cells(cells + 1);
    write_tile(t);
    t = base(ahead);
    t.tile_edge(static_cast<std::uint16_t>(l.tile_edge * 2));
    t.cells(cells * 4);
    t.payload(garbage(rng, 64));
    write_tile(t);
    t = base(ahead);
    t.cell_size(l.cell_size * 2.0f);
    t.payload(garbage(rng, 64));
    write_tile(t);
    t = base(ahead);
    t.tx(2'000'000'000);
    t.ty(-2'000'000'000);
    write_tile(t);
    // Each flood key on both keyed map topics: a tile and a delta at a new key.
    for (int k = 0; k < o.key_flood && static_cast<long>(n_flood) < o.flood_max; ++k, ++n_flood) {
      t = base(1);
      t.tx(flood_next++);
      write_tile(t);
      flood_deltas.push_back(t.tx());
    }
    if (newest > 1) write_tile(base(newest - 1));  // stale, well formed
    write_tile(base(0));                           // version 0
    t = base(ahead);
    t.protocol(2);  // a robot left on the release before the bounded types
    write_tile(t);
    t = base(ahead);
    t.encoding(7);
    write_tile(t);
    t = base(ahead);
    t.epoch(l.epoch + 1);  // a newer epoch, undecodable: must not reset the map
    t.payload(garbage(rng, 200));
    write_tile(t);
    if (o.oversized_every > 0 && rounds % static_cast<std::uint64_t>(o.oversized_every) == 1) {
      t = base(ahead);
      t.encoding(msg::kEncodingRaw);
      t.payload(std::vector<std::uint8_t>(static_cast<std::size_t>(o.oversized_mb) << 20, 0xAB));
      write_tile(t);
      ++n_oversized;
    }

    // Deltas.
    const auto delta = [&](std::uint64_t base_version, std::uint64_t version) {
      const msg::MapTile full = base(version);
      msg::MapTileDelta d;
      d.map_id(full.map_id());
      d.tx(full.tx());
      d.ty(full.ty());
      d.protocol(full.protocol());
      d.epoch(full.epoch());
      d.version(version);
      d.base_version(base_version);
      d.cell_size(full.cell_size());
      d.tile_edge(full.tile_edge());
      d.encoding(full.encoding());
      d.cells(full.cells());
      d.payload(full.payload());
      d.leader_stamp_ns(0);
      return d;
    };
    for (const std::int32_t tx : flood_deltas) {
      msg::MapTileDelta fd = delta(1, 2);
      fd.tx(tx);
      write_delta(fd);
    }
    flood_deltas.clear();
    write_delta(delta(ahead, ahead));          // base not older than version
    write_delta(delta(ahead + 1, ahead + 2));  // a base nobody holds
    msg::MapTileDelta d = delta(newest, ahead);
    d.payload(garbage(rng, 150));
    write_delta(d);
    d = delta(newest, ahead);
    d.tile_edge(static_cast<std::uint16_t>(l.tile_edge / 2));
    d.cells(cells / 4);
    write_delta(d);

    // Summaries.
    if (l.meta) {
      msg::MapMeta m = *l.meta;
      m.min_tx(-2'000'000'000);
      write_meta(m);
      m = *l.meta;
      m.tile_count(4'000'000'000u);
      write_meta(m);
      m = *l.meta;
      m.tile_edge(static_cast<std::uint16_t>(l.tile_edge * 2));
      m.map_version(l.meta->map_version() + 1'000'000);
      write_meta(m);
      m = *l.meta;
      m.cell_size(l.cell_size * 3.0f);
      m.map_version(l.meta->map_version() + 1'000'000);
      write_meta(m);
      m = *l.meta;
      m.epoch(l.epoch - 1);
      write_meta(m);
      m = *l.meta;
      m.map_id("rogue-map");
      m.epoch(l.epoch + 5);
      write_meta(m);
      m = *l.meta;
      m.protocol(0);
      write_meta(m);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(o.period_ms));
  }
  std::printf(
      "rogue: sent %llu samples (%llu tiles, %llu deltas, %llu summaries, %llu oversized, "
      "%llu flood keys) in %llu rounds\n",
      static_cast<unsigned long long>(n_tiles + n_deltas + n_metas),
      static_cast<unsigned long long>(n_tiles), static_cast<unsigned long long>(n_deltas),
      static_cast<unsigned long long>(n_metas), static_cast<unsigned long long>(n_oversized),
      static_cast<unsigned long long>(n_flood), static_cast<unsigned long long>(rounds));
  {
    std::lock_guard lock(spy.mutex);
    std::printf("rogue: leader's map: %zu tiles in %zu part keys\n", spy.learned.versions.size(),
                spy.learned.part_keys);
  }
  std::fflush(stdout);
  participant->delete_contained_entities();
  factory->delete_participant(participant);
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "rogue_peer: %s\n", e.what());
  return 2;
}
