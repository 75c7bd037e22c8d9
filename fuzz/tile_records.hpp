#pragma once
// The byte layout fuzz_tile reads its messages from, and make_tile_seeds writes its seeds in.
//
// Input: one flags byte (bit 0 set: the replica follows the first map it sees, as a follower
// started without --map-id; clear: it follows map "fuzz"), then records until the bytes run
// out. Each record is a kind byte (modulo 4) and fixed-width little-endian fields:
//   0 decode: encoding u8, cells u32, payload_len u32, payload
//   1 MapTile: map_id u8 (modulo 3: "fuzz", "other", ""), tx i32, ty i32, protocol u16,
//     epoch u32, version u64, cell_size f32, tile_edge u16, encoding u8, cells u32,
//     payload_len u32, payload
//   2 MapTileDelta: as MapTile with base_version u64 after version
//   3 MapMeta: map_id u8, protocol u16, epoch u32, cell_size f32, tile_edge u16, min_tx i32,
//     min_ty i32, max_tx i32, max_ty i32, tile_count u32, map_version u64, complete u8,
//     scans u32
// A record cut short ends the input; a payload_len beyond the input takes what is left.

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include <esfleet/msg/esfleet.h>

namespace esfleet::fuzz {

/// kPart: [delta u8][writer u8][part u16][parts u16][payload_size u32] then a tile or delta
/// record's fields: one part for dds::TilePartAssembler (protocol 2).
enum class RecordKind : std::uint8_t { kDecode = 0, kTile = 1, kDelta = 2, kMeta = 3, kPart = 4 };
inline constexpr std::uint8_t kRecordKinds = 5;

inline const char* map_id_of(std::uint8_t selector) {
  static constexpr const char* kIds[] = {"fuzz", "other", ""};
  return kIds[selector % 3];
}

inline std::uint8_t selector_of(const std::string& map_id) {
  return map_id == "fuzz" ? 0 : map_id == "other" ? 1 : 2;
}

/// Reads fields off the front of the input.
class RecordReader {
 public:
  explicit RecordReader(std::span<const std::uint8_t> data) : data_(data) {}

  template <typename T>
  bool take(T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    if (data_.size() < sizeof(T)) return false;
    std::memcpy(&value, data_.data(), sizeof(T));
    data_ = data_.subspan(sizeof(T));
    return true;
  }

  /// payload_len u32, then that many bytes (or all that is left).
  bool take_payload(std::vector<std::uint8_t>& out) {
    std::uint32_t n = 0;
    if (!take(n)) return false;
    const std::size_t got = std::min<std::size_t>(n, data_.size());
    out.assign(data_.begin(), data_.begin() + static_cast<std::ptrdiff_t>(got));
    data_ = data_.subspan(got);
    return true;
  }

  bool empty() const { return data_.empty(); }

 private:
  std::span<const std::uint8_t> data_;
};

/// Appends fields to a record stream.
class RecordWriter {
 public:
  template <typename T>
  void put(T value) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* p = reinterpret_cast<const std::uint8_t*>(&value);
    bytes_.insert(bytes_.end(), p, p + sizeof(T));
  }
  void put_payload(const std::vector<std::uint8_t>& payload) {
    put(static_cast<std::uint32_t>(payload.size()));
    bytes_.insert(bytes_.end(), payload.begin(), payload.end());
  }
  const std::vector<std::uint8_t>& bytes() const { return bytes_; }

 private:
  std::vector<std::uint8_t> bytes_;
};

/// The fields MapTile and MapTileDelta share, in record order; `base` reads base_version.
template <typename Msg>
bool read_tile_fields(RecordReader& in, Msg& m, std::uint64_t* base) {
  std::uint8_t id = 0, encoding = 0;
  std::int32_t tx = 0, ty = 0;
  std::uint16_t protocol = 0, tile_edge = 0;
  std::uint32_t epoch = 0, cells = 0;
  std::uint64_t version = 0;
  float cell_size = 0.0f;
  std::vector<std::uint8_t> payload;
  if (!in.take(id) || !in.take(tx) || !in.take(ty) || !in.take(protocol) || !in.take(epoch) ||
      !in.take(version) || (base != nullptr && !in.take(*base)) || !in.take(cell_size) ||
      !in.take(tile_edge) || !in.take(encoding) || !in.take(cells) || !in.take_payload(payload)) {
    return false;
  }
  m.map_id(map_id_of(id));
  m.tx(tx);
  m.ty(ty);
  m.protocol(protocol);
  m.epoch(epoch);
  m.version(version);
  m.cell_size(cell_size);
  m.tile_edge(tile_edge);
  m.encoding(encoding);
  m.cells(cells);
  m.payload(std::move(payload));
  return true;
}

template <typename Msg>
void write_tile_fields(RecordWriter& out, const Msg& m, const std::uint64_t* base) {
  out.put(selector_of(m.map_id().to_string()));
  out.put(m.tx());
  out.put(m.ty());
  out.put(m.protocol());
  out.put(m.epoch());
  out.put(m.version());
  if (base != nullptr) out.put(*base);
  out.put(m.cell_size());
  out.put(m.tile_edge());
  out.put(m.encoding());
  out.put(m.cells());
  out.put_payload(m.payload());
}

/// A kPart record (after its kind byte) of part `m` from writer `writer`.
template <typename Msg>
void write_part_record(RecordWriter& out, const Msg& m, const std::uint64_t* base,
                       std::uint8_t writer) {
  out.put(static_cast<std::uint8_t>(base != nullptr ? 1 : 0));
  out.put(writer);
  out.put(m.part());
  out.put(m.parts());
  out.put(m.payload_size());
  write_tile_fields(out, m, base);
}

inline bool read_meta(RecordReader& in, msg::MapMeta& m) {
  std::uint8_t id = 0, complete = 0;
  std::uint16_t protocol = 0, tile_edge = 0;
  std::uint32_t epoch = 0, tile_count = 0, scans = 0;
  float cell_size = 0.0f;
  std::int32_t min_tx = 0, min_ty = 0, max_tx = 0, max_ty = 0;
  std::uint64_t map_version = 0;
  if (!in.take(id) || !in.take(protocol) || !in.take(epoch) || !in.take(cell_size) ||
      !in.take(tile_edge) || !in.take(min_tx) || !in.take(min_ty) || !in.take(max_tx) ||
      !in.take(max_ty) || !in.take(tile_count) || !in.take(map_version) || !in.take(complete) ||
      !in.take(scans)) {
    return false;
  }
  m.map_id(map_id_of(id));
  m.protocol(protocol);
  m.epoch(epoch);
  m.cell_size(cell_size);
  m.tile_edge(tile_edge);
  m.min_tx(min_tx);
  m.min_ty(min_ty);
  m.max_tx(max_tx);
  m.max_ty(max_ty);
  m.tile_count(tile_count);
  m.map_version(map_version);
  m.complete(complete != 0);
  m.scans(scans);
  return true;
}

inline void write_meta(RecordWriter& out, const msg::MapMeta& m) {
  out.put(selector_of(m.map_id().to_string()));
  out.put(m.protocol());
  out.put(m.epoch());
  out.put(m.cell_size());
  out.put(m.tile_edge());
  out.put(m.min_tx());
  out.put(m.min_ty());
  out.put(m.max_tx());
  out.put(m.max_ty());
  out.put(m.tile_count());
  out.put(m.map_version());
  out.put(static_cast<std::uint8_t>(m.complete() ? 1 : 0));
  out.put(m.scans());
}

}  // namespace esfleet::fuzz
