#include "esfleet/core/tile_codec.hpp"

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <new>
#include <optional>
#include <string>

#include "fnv1a.hpp"

namespace esfleet {
namespace {

constexpr std::size_t kInflateChunk = 64 * 1024;           // output bytes per inflate() call
constexpr std::size_t kInputSlice = std::size_t{1} << 30;  // input bytes per refill (uInt)

/// Bytes of the largest valid varint stream of `cells` cells.
std::size_t varint_bound(std::size_t cells) { return 2 * kMaxVarintBytes * cells; }

void check_encode_args(std::span<const std::uint32_t> hit, std::span<const std::uint32_t> err,
                       int zlib_level) {
  if (hit.size() != err.size()) {
    throw std::invalid_argument("encode_tile: hit has " + std::to_string(hit.size()) +
                                " cells, err " + std::to_string(err.size()));
  }
  if (hit.size() > kMaxTileCells) {
    throw std::invalid_argument("encode_tile: " + std::to_string(hit.size()) +
                                " cells, more than " + std::to_string(kMaxTileCells));
  }
  if (zlib_level < 0 || zlib_level > 9) {
    throw std::invalid_argument("encode_tile: zlib_level " + std::to_string(zlib_level) +
                                " is outside [0, 9]");
  }
}

void store_le32(std::uint32_t v, std::uint8_t* out) {
  out[0] = static_cast<std::uint8_t>(v);
  out[1] = static_cast<std::uint8_t>(v >> 8);
  out[2] = static_cast<std::uint8_t>(v >> 16);
  out[3] = static_cast<std::uint8_t>(v >> 24);
}

std::uint32_t load_le32(const std::uint8_t* in) {
  return static_cast<std::uint32_t>(in[0]) | (static_cast<std::uint32_t>(in[1]) << 8) |
         (static_cast<std::uint32_t>(in[2]) << 16) | (static_cast<std::uint32_t>(in[3]) << 24);
}

/// Writes the LEB128 varint of `v` (1 to kMaxVarintBytes bytes); returns the byte count.
std::size_t put_varint(std::uint32_t v, std::uint8_t* out) {
  std::size_t n = 0;
  while (v >= 0x80u) {
    out[n++] = static_cast<std::uint8_t>(v | 0x80u);
    v >>= 7;
  }
  out[n++] = static_cast<std::uint8_t>(v);
  return n;
}

std::vector<std::uint8_t> encode_raw(std::span<const std::uint32_t> hit,
                                     std::span<const std::uint32_t> err) {
  const std::size_t cells = hit.size();
  std::vector<std::uint8_t> out(8 * cells);
  for (std::size_t i = 0; i < cells; ++i) {
    store_le32(hit[i], out.data() + 4 * i);
    store_le32(err[i], out.data() + 4 * (cells + i));
  }
  return out;
}

std::vector<std::uint8_t> deflate_bytes(const std::uint8_t* data, std::size_t n, int level);

std::vector<std::uint8_t> encode_varint_zlib(std::span<const std::uint32_t> hit,
                                             std::span<const std::uint32_t> err, int level) {
  const std::size_t cells = hit.size();
  const auto varints = std::make_unique_for_overwrite<std::uint8_t[]>(varint_bound(cells));
  std::size_t n = 0;
  for (std::size_t i = 0; i < cells; ++i) {
    n += put_varint(hit[i], varints.get() + n);
    n += put_varint(err[i], varints.get() + n);
  }
  return deflate_bytes(varints.get(), n, level);
}

/// Cells per edge of a square tile of `cells` cells, or nothing if `cells` is not a square.
std::optional<std::size_t> square_edge(std::size_t cells) {
  auto edge = static_cast<std::size_t>(std::sqrt(static_cast<double>(cells)));
  while (edge * edge > cells) --edge;
  while ((edge + 1) * (edge + 1) <= cells) ++edge;
  if (edge * edge != cells) return std::nullopt;
  return edge;
}

/// LOCO-I's median edge detector: predicts cell i of a row-major edge x edge plane from its
/// left (a), upper (b) and upper-left (c) neighbours, already known to the decoder.
std::uint32_t med_predict(const std::uint32_t* v, std::size_t i, std::size_t edge) {
  const std::size_t x = i % edge, y = i / edge;
  const std::int64_t a = x > 0 ? v[i - 1] : (y > 0 ? v[i - edge] : 0);
  const std::int64_t b = y > 0 ? v[i - edge] : a;
  const std::int64_t c = (x > 0 && y > 0) ? v[i - edge - 1] : b;
  const std::int64_t hi = std::max(a, b), lo = std::min(a, b);
  // a + b - c lies in [lo, hi] in the last case, so the prediction is a valid uint32.
  return static_cast<std::uint32_t>(c >= hi ? lo : c <= lo ? hi : a + b - c);
}

/// Residuals wrap modulo 2^32, so every (value, prediction) pair has one and the decoder's
/// prediction + residual is always a valid uint32.
std::uint32_t zigzag(std::uint32_t value, std::uint32_t prediction) {
  const auto d = static_cast<std::int32_t>(value - prediction);
  return (static_cast<std::uint32_t>(d) << 1) ^ static_cast<std::uint32_t>(d >> 31);
}
std::uint32_t unzigzag(std::uint32_t z, std::uint32_t prediction) {
  return prediction + ((z >> 1) ^ (0u - (z & 1u)));
}

std::vector<std::uint8_t> deflate_bytes(const std::uint8_t* data, std::size_t n, int level) {
  // n <= 10 * kMaxTileCells, so it fits zlib's uLong.
  uLongf packed_size = compressBound(static_cast<uLong>(n));
  const auto packed = std::make_unique_for_overwrite<std::uint8_t[]>(packed_size);
  const int rc = compress2(packed.get(), &packed_size, data, static_cast<uLong>(n), level);
  if (rc == Z_MEM_ERROR) throw std::bad_alloc();
  if (rc != Z_OK) throw std::runtime_error(std::string("encode_tile: zlib: ") + zError(rc));
  // Copied out so the payload's capacity is its size, not compressBound(n).
  return std::vector<std::uint8_t>(packed.get(), packed.get() + packed_size);
}

std::vector<std::uint8_t> encode_med_zlib(std::span<const std::uint32_t> hit,
                                          std::span<const std::uint32_t> err, int level) {
  const std::size_t cells = hit.size();
  const auto square = square_edge(cells);
  if (!square) {
    throw std::invalid_argument("encode_tile: " + std::to_string(cells) +
                                " cells is not a square tile (needed by the MED encoding)");
  }
  const std::size_t edge = *square;
  const auto varints = std::make_unique_for_overwrite<std::uint8_t[]>(varint_bound(cells));
  std::size_t n = 0;
  for (const std::span<const std::uint32_t> plane : {hit, err}) {
    for (std::size_t i = 0; i < cells; ++i) {
      n += put_varint(zigzag(plane[i], med_predict(plane.data(), i, edge)), varints.get() + n);
    }
  }
  return deflate_bytes(varints.get(), n, level);
}

void decode_raw(std::span<const std::uint8_t> payload, std::size_t cells,
                std::vector<std::uint32_t>& hit, std::vector<std::uint32_t>& err) {
  if (payload.size() != 8 * cells) {
    throw TileDecodeError("raw payload is " + std::to_string(payload.size()) + " bytes, expected " +
                          std::to_string(8 * cells));
  }
  hit.resize(cells);
  err.resize(cells);
  const std::uint8_t* in = payload.data();
  for (std::size_t i = 0; i < cells; ++i) {
    hit[i] = load_le32(in + 4 * i);
    err[i] = load_le32(in + 4 * (cells + i));
  }
}

/// Inflates the zlib stream `payload` into out[0, bound); returns the inflated size. Throws
/// TileDecodeError on a zlib error, a truncated stream, bytes after the stream's end, or when
/// the stream inflates to more than `bound` bytes (found by asking for one byte more, so no
/// more than `bound` bytes are ever written or allocated).
std::size_t inflate_bounded(std::span<const std::uint8_t> payload, std::uint8_t* out,
                            std::size_t bound, std::size_t cells) {
  z_stream zs{};
  int rc = inflateInit(&zs);
  if (rc == Z_MEM_ERROR) throw std::bad_alloc();
  if (rc != Z_OK) throw TileDecodeError(std::string("zlib: inflateInit: ") + zError(rc));
  struct InflateEnd {
    z_stream* zs;
    ~InflateEnd() { inflateEnd(zs); }
  } end{&zs};

  std::size_t in_pos = 0;    // payload bytes handed to zlib so far
  std::size_t produced = 0;  // bytes written to out
  std::uint8_t probe = 0;
  for (;;) {
    if (zs.avail_in == 0 && in_pos < payload.size()) {
      const std::size_t slice = std::min(payload.size() - in_pos, kInputSlice);
      // zlib never writes through next_in; the non-const pointer is its old C interface.
      zs.next_in = const_cast<Bytef*>(payload.data() + in_pos);
      zs.avail_in = static_cast<uInt>(slice);
      in_pos += slice;
    }
    const bool probing = produced == bound;
    zs.next_out = probing ? &probe : out + produced;
    zs.avail_out = probing ? 1u : static_cast<uInt>(std::min(kInflateChunk, bound - produced));
    const uInt room = zs.avail_out;
    rc = inflate(&zs, Z_NO_FLUSH);
    const std::size_t got = room - zs.avail_out;
    if (probing && got > 0) {
      throw TileDecodeError("inflated data exceeds the bound of " + std::to_string(bound) +
                            " bytes for " + std::to_string(cells) + " cells");
    }
    produced += got;
    switch (rc) {
      case Z_OK:
        break;
      case Z_STREAM_END: {
        const std::size_t rest = zs.avail_in + (payload.size() - in_pos);
        if (rest > 0) {
          throw TileDecodeError("trailing bytes: " + std::to_string(rest) +
                                " after the end of the zlib stream");
        }
        return produced;
      }
      case Z_BUF_ERROR:
        // No progress possible although there is output room: the input ended mid-stream.
        if (zs.avail_in == 0 && in_pos == payload.size()) {
          throw TileDecodeError("zlib: stream is truncated (input ends after " +
                                std::to_string(payload.size()) + " bytes)");
        }
        throw TileDecodeError("zlib: inflate made no progress");
      case Z_NEED_DICT:
        throw TileDecodeError("zlib: stream needs a preset dictionary");
      case Z_MEM_ERROR:
        throw std::bad_alloc();
      default:
        throw TileDecodeError(std::string("zlib: ") + (zs.msg != nullptr ? zs.msg : zError(rc)));
    }
  }
}

/// Reads one varint from [p, end) into v. Returns false if the stream ends first; throws when it
/// is longer than kMaxVarintBytes or its value exceeds UINT32_MAX.
bool read_varint(const std::uint8_t*& p, const std::uint8_t* end, std::uint32_t& v,
                 std::size_t cell, const char* field) {
  std::uint32_t value = 0;
  for (std::size_t k = 0; k < kMaxVarintBytes; ++k) {
    if (p == end) return false;
    const std::uint32_t b = *p++;
    // The 5th byte carries bits 28..31: anything above 0x0F is a 33rd+ bit or a 6th byte.
    if (k == kMaxVarintBytes - 1 && b > 0x0Fu) {
      throw TileDecodeError("varint overflows uint32 (cell " + std::to_string(cell) + ", " + field +
                            ")");
    }
    value |= (b & 0x7Fu) << (7 * k);
    if ((b & 0x80u) == 0) break;
  }
  v = value;
  return true;
}

void decode_varint_zlib(std::span<const std::uint8_t> payload, std::size_t cells,
                        std::vector<std::uint32_t>& hit, std::vector<std::uint32_t>& err) {
  const std::size_t bound = varint_bound(cells);
  const auto buffer = std::make_unique_for_overwrite<std::uint8_t[]>(bound);
  const std::size_t size = inflate_bounded(payload, buffer.get(), bound, cells);
  hit.resize(cells);
  err.resize(cells);
  const std::uint8_t* p = buffer.get();
  const std::uint8_t* const end = p + size;
  for (std::size_t i = 0; i < cells; ++i) {
    // Fast path: both counters below 128, one byte each.
    if (end - p >= 2 && ((p[0] | p[1]) & 0x80u) == 0) {
      hit[i] = p[0];
      err[i] = p[1];
      p += 2;
      continue;
    }
    if (!read_varint(p, end, hit[i], i, "hit") || !read_varint(p, end, err[i], i, "err")) {
      throw TileDecodeError("varint stream ends after " + std::to_string(i) + " of " +
                            std::to_string(cells) + " cells");
    }
  }
  if (p != end) {
    throw TileDecodeError("trailing bytes: " + std::to_string(end - p) + " after the last of " +
                          std::to_string(cells) + " cells");
  }
}

void decode_med_zlib(std::span<const std::uint8_t> payload, std::size_t cells,
                     std::vector<std::uint32_t>& hit, std::vector<std::uint32_t>& err) {
  const auto square = square_edge(cells);
  if (!square) throw TileDecodeError(std::to_string(cells) + " cells is not a square tile");
  const std::size_t edge = *square;
  const std::size_t bound = varint_bound(cells);
  const auto buffer = std::make_unique_for_overwrite<std::uint8_t[]>(bound);
  const std::size_t size = inflate_bounded(payload, buffer.get(), bound, cells);
  hit.resize(cells);
  err.resize(cells);
  const std::uint8_t* p = buffer.get();
  const std::uint8_t* const end = p + size;
  std::size_t plane_index = 0;
  for (std::vector<std::uint32_t>* plane : {&hit, &err}) {
    std::uint32_t* v = plane->data();
    const char* field = plane_index++ == 0 ? "hit" : "err";
    for (std::size_t i = 0; i < cells; ++i) {
      std::uint32_t z = 0;
      if (!read_varint(p, end, z, i, field)) {
        throw TileDecodeError("varint stream ends after " + std::to_string(i) + " of " +
                              std::to_string(cells) + " " + field + " cells");
      }
      v[i] = unzigzag(z, med_predict(v, i, edge));
    }
  }
  if (p != end) {
    throw TileDecodeError("trailing bytes: " + std::to_string(end - p) + " after the last of " +
                          std::to_string(cells) + " cells");
  }
}

}  // namespace

EncodedTile encode_tile(std::span<const std::uint32_t> hit, std::span<const std::uint32_t> err,
                        TileEncoding enc, int zlib_level) {
  check_encode_args(hit, err, zlib_level);
  switch (enc) {
    case TileEncoding::kRaw:
      return {enc, encode_raw(hit, err)};
    case TileEncoding::kVarintZlib:
      return {enc, encode_varint_zlib(hit, err, zlib_level)};
    case TileEncoding::kMedZlib:
      return {enc, encode_med_zlib(hit, err, zlib_level)};
  }
  throw std::invalid_argument("encode_tile: unknown encoding " +
                              std::to_string(static_cast<unsigned>(enc)));
}

void decode_tile(TileEncoding enc, std::span<const std::uint8_t> payload, std::size_t cells,
                 std::vector<std::uint32_t>& hit, std::vector<std::uint32_t>& err) {
  if (cells > kMaxTileCells) {
    throw TileDecodeError("tile of " + std::to_string(cells) + " cells, more than " +
                          std::to_string(kMaxTileCells));
  }
  switch (enc) {
    case TileEncoding::kRaw:
      decode_raw(payload, cells, hit, err);
      return;
    case TileEncoding::kVarintZlib:
      decode_varint_zlib(payload, cells, hit, err);
      return;
    case TileEncoding::kMedZlib:
      decode_med_zlib(payload, cells, hit, err);
      return;
  }
  throw TileDecodeError("unknown encoding " + std::to_string(static_cast<unsigned>(enc)));
}

std::uint64_t tile_digest(std::span<const std::uint32_t> hit, std::span<const std::uint32_t> err) {
  if (hit.size() != err.size()) {
    throw std::invalid_argument("tile_digest: hit has " + std::to_string(hit.size()) +
                                " cells, err " + std::to_string(err.size()));
  }
  detail::Fnv1a h;
  for (const std::uint32_t v : hit) h.add_le32(v);
  for (const std::uint32_t v : err) h.add_le32(v);
  return h.value();
}

std::string map_digest(const GridMap& map) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  for (const TileKey& key : map.tile_keys()) {
    const Tile* tile = map.find_tile(key);
    const auto zero = [](std::uint32_t v) { return v == 0; };
    if (std::all_of(tile->hit.begin(), tile->hit.end(), zero) &&
        std::all_of(tile->err.begin(), tile->err.end(), zero)) {
      continue;  // an all-unknown tile is the same map as no tile
    }
    const std::uint64_t d = tile_digest(tile->hit, tile->err);
    out += std::to_string(key.tx);
    out += ' ';
    out += std::to_string(key.ty);
    out += ' ';
    for (int shift = 60; shift >= 0; shift -= 4) out += kHex[(d >> shift) & 0xFu];
    out += '\n';
  }
  return out;
}

}  // namespace esfleet
