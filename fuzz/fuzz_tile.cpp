// libFuzzer target: tile payload decoding (every encoding) and the follower's validation and
// apply path (dds/from_msg, then mapshare::MapReplica) for tiles, tile deltas and summaries
// built from the input bytes
// (layout: tile_records.hpp), and tile and delta parts joined by dds::TilePartAssembler first.
// Invariants checked after every record:
//  - decode_tile either throws TileDecodeError or yields `cells` counters that re-encode and
//    decode to the same counters;
//  - a message MapReplica does not apply leaves the map exactly as it was (same digest, epoch
//    and summary), and a rejection says why;
//  - an applied tile holds the message's version; every tile of the map lies in the allowed key
//    range and has tile_edge^2 cells;
//  - a refused part says why; a joined message's payload is as long as its parts declared; the
//    parts waiting stay within the assembler's bounds.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "esfleet/core/tile_codec.hpp"
#include "esfleet/dds/from_msg.hpp"
#include "esfleet/mapshare/map_replica.hpp"
#include "fuzz_check.hpp"
#include "tile_records.hpp"

using esfleet::fuzz::check;
namespace dds = esfleet::dds;
namespace mapshare = esfleet::mapshare;

namespace {

void fuzz_decode(esfleet::fuzz::RecordReader& in) {
  std::uint8_t enc = 0;
  std::uint32_t cells32 = 0;
  std::vector<std::uint8_t> payload;
  if (!in.take(enc) || !in.take(cells32) || !in.take_payload(payload)) return;
  // Mostly tiles up to 128 x 128 (fast); with the top bit set, any count, so the limit check
  // and the largest tiles are reached too.
  const std::size_t cells = (cells32 >> 31) != 0 ? (cells32 & 0x7fffffffu) : cells32 % 16385;
  const auto encoding = static_cast<esfleet::TileEncoding>(enc);
  std::vector<std::uint32_t> hit, err;
  try {
    esfleet::decode_tile(encoding, payload, cells, hit, err);
  } catch (const esfleet::TileDecodeError&) {
    return;
  }
  check(hit.size() == cells && err.size() == cells, "decoded sizes == cells");
  const esfleet::EncodedTile again = esfleet::encode_tile(hit, err, encoding);
  std::vector<std::uint32_t> hit2, err2;
  esfleet::decode_tile(encoding, again.payload, cells, hit2, err2);
  check(hit2 == hit && err2 == err, "decode(encode(x)) == x");
}

/// What a message may change in the replica: its layout, summary, tile set and the counters of
/// the one tile it addresses (MapReplica touches no other tile; hashing only that one keeps
/// the target fast with 1024 x 1024 tiles).
struct Snapshot {
  std::uint32_t epoch = 0;
  std::string map_id;
  bool has_map = false;
  double cell_size = 0.0;
  int tile_edge = 0;
  std::size_t tiles = 0;
  std::uint64_t version_sum = 0;
  std::uint64_t tile_version = 0;
  std::uint64_t tile_digest = 0;
  bool has_meta = false;
  std::uint64_t meta_version = 0;

  Snapshot(const mapshare::MapReplica& r, esfleet::TileKey key)
      : epoch(r.epoch()),
        map_id(r.map_id()),
        has_map(r.has_map()),
        has_meta(r.meta().has_value()),
        meta_version(r.meta() ? r.meta()->map_version : 0) {
    if (!has_map) return;
    cell_size = r.map().cell_size();
    tile_edge = r.map().tile_edge();
    tiles = r.map().tile_count();
    version_sum = mapshare::map_version(r.map());
    if (const esfleet::Tile* t = r.map().find_tile(key)) {
      tile_version = t->version;
      tile_digest = esfleet::tile_digest(t->hit, t->err);
    }
  }
  bool operator==(const Snapshot&) const = default;
};

void check_replica(const mapshare::MapReplica& r) {
  if (!r.has_map()) return;
  const esfleet::GridMap& map = r.map();
  if (map.tile_count() > 64) return;  // checked while the map is small (the target stays fast)
  for (const esfleet::TileKey k : map.tile_keys()) {
    check(map.key_in_range(k), "tile key in range");
    const esfleet::Tile* t = map.find_tile(k);
    check(t->hit.size() == map.cells_per_tile() && t->err.size() == map.cells_per_tile(),
          "tile has tile_edge^2 cells");
  }
  (void)r.complete();
}

void after_apply(mapshare::Applied a, const std::string& error, const Snapshot& before,
                 const mapshare::MapReplica& r, const mapshare::TileMessage* tile) {
  if (a == mapshare::Applied::kRejected) check(!error.empty(), "a rejection says why");
  if (a != mapshare::Applied::kApplied) {
    const esfleet::TileKey key = tile != nullptr ? tile->key() : esfleet::TileKey{};
    check(Snapshot(r, key) == before, "a message not applied changes nothing");
  } else if (tile != nullptr) {
    const esfleet::Tile* t = r.map().find_tile(tile->key());
    check(t != nullptr && t->version == tile->version, "an applied tile has its version");
  }
  check_replica(r);
}

/// One part from the input through `parts`; a joined message goes to the replica.
template <typename Msg>
bool fuzz_part(esfleet::fuzz::RecordReader& in, dds::TilePartAssembler& parts,
               mapshare::MapReplica& replica) {
  std::uint8_t writer = 0;
  std::uint16_t part = 0, count = 0;
  std::uint32_t payload_size = 0;
  if (!in.take(writer) || !in.take(part) || !in.take(count) || !in.take(payload_size)) {
    return false;
  }
  Msg m;
  std::uint64_t base = 0;
  constexpr bool kDelta = std::is_same_v<Msg, esfleet::msg::MapTileDelta>;
  if (!esfleet::fuzz::read_tile_fields(in, m, kDelta ? &base : nullptr)) return false;
  if constexpr (kDelta) m.base_version(base);
  m.part(part);
  m.parts(count);
  m.payload_size(payload_size);
  std::string error;
  const std::optional<mapshare::TileMessage> joined =
      parts.add(std::move(m), std::string("writer-") + std::to_string(writer % 3), &error);
  check(parts.pending_bytes() <= dds::TilePartAssembler::kMaxPendingBytes,
        "waiting parts within the byte bound");
  check(parts.pending_tiles() <= dds::TilePartAssembler::kMaxTiles,
        "waiting tiles within the tile bound");
  if (!joined) return true;
  check(error.empty(), "a joined message has no error");
  check(joined->payload.size() == payload_size, "a joined payload has the declared size");
  const Snapshot before(replica, joined->key());
  std::string apply_error;
  after_apply(replica.apply(*joined, &apply_error), apply_error, before, replica, &*joined);
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  esfleet::fuzz::RecordReader in({data, size});
  std::uint8_t flags = 0;
  if (!in.take(flags)) return 0;
  // Keys within +-64 tiles: the replica's tile directory spans the bounding box of its tiles
  // (up to 2049^2 slots with the default +-1024, ~70 MB per level), which would make every
  // input with two far-apart tiles slow; the range check itself is the same code.
  esfleet::GridMapConfig local;
  local.max_tile_coord = 64;
  mapshare::MapReplica replica((flags & 1) != 0 ? "" : "fuzz", local);
  dds::TilePartAssembler parts;
  for (int records = 0; records < 64 && !in.empty(); ++records) {
    std::uint8_t kind = 0;
    if (!in.take(kind)) break;
    std::string error;
    switch (static_cast<esfleet::fuzz::RecordKind>(kind % esfleet::fuzz::kRecordKinds)) {
      case esfleet::fuzz::RecordKind::kDecode:
        fuzz_decode(in);
        break;
      case esfleet::fuzz::RecordKind::kTile: {
        esfleet::msg::MapTile t;
        if (!esfleet::fuzz::read_tile_fields(in, t, nullptr)) return 0;
        const mapshare::TileMessage tile = dds::tile_from_msg(std::move(t));
        const Snapshot before(replica, tile.key());
        after_apply(replica.apply(tile, &error), error, before, replica, &tile);
        break;
      }
      case esfleet::fuzz::RecordKind::kDelta: {
        esfleet::msg::MapTileDelta d;
        std::uint64_t base = 0;
        if (!esfleet::fuzz::read_tile_fields(in, d, &base)) return 0;
        d.base_version(base);
        const mapshare::TileMessage delta = dds::delta_from_msg(std::move(d));
        const Snapshot before(replica, delta.key());
        after_apply(replica.apply(delta, &error), error, before, replica, &delta);
        break;
      }
      case esfleet::fuzz::RecordKind::kPart: {
        std::uint8_t delta = 0;
        if (!in.take(delta)) return 0;
        const bool ok = (delta & 1) != 0 ? fuzz_part<esfleet::msg::MapTileDelta>(in, parts, replica)
                                         : fuzz_part<esfleet::msg::MapTile>(in, parts, replica);
        if (!ok) return 0;
        break;
      }
      case esfleet::fuzz::RecordKind::kMeta: {
        esfleet::msg::MapMeta m;
        if (!esfleet::fuzz::read_meta(in, m)) return 0;
        const Snapshot before(replica, {});
        after_apply(replica.apply(dds::meta_from_msg(m), &error), error, before, replica, nullptr);
        break;
      }
    }
  }
  return 0;
}
