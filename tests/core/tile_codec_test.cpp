#include "esfleet/core/tile_codec.hpp"

#include <gtest/gtest.h>
#include <zlib.h>  // linked through esfleet_core (static, zlib private): crafts hostile payloads

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <new>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

// Counts operator new while armed, to show that decoding a zlib bomb allocates no more than the
// bound (zlib's own fixed-size state comes from malloc and is not counted).
namespace {
std::atomic<bool> g_count_allocations{false};
std::atomic<std::size_t> g_allocated_bytes{0};
std::atomic<std::size_t> g_largest_allocation{0};
}  // namespace

void* operator new(std::size_t size) {
  if (g_count_allocations.load(std::memory_order_relaxed)) {
    g_allocated_bytes += size;
    std::size_t largest = g_largest_allocation.load();
    while (size > largest && !g_largest_allocation.compare_exchange_weak(largest, size)) {
    }
  }
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
// Not inlined: GCC 12 would see free() of an operator new pointer and warn
// (-Wmismatched-new-delete), although both halves are replaced together here.
[[gnu::noinline]] void operator delete(void* p) noexcept { std::free(p); }
[[gnu::noinline]] void operator delete(void* p, std::size_t) noexcept { std::free(p); }

namespace esfleet {
namespace {

constexpr std::size_t kCells = 64 * 64;

struct Counters {
  std::vector<std::uint32_t> hit;
  std::vector<std::uint32_t> err;
};

/// Half the cells unknown (0), the rest of uniformly random bit length 1..32, so varints of
/// every length from 1 to 5 bytes occur.
Counters random_counters(std::size_t cells, std::uint32_t seed) {
  std::mt19937 rng(seed);
  const auto draw = [&rng]() -> std::uint32_t {
    if (rng() % 2 == 0) return 0;
    const unsigned bits = 1 + rng() % 32;
    const std::uint32_t v = static_cast<std::uint32_t>(rng());
    return bits == 32 ? v : v & ((std::uint32_t{1} << bits) - 1);
  };
  Counters c;
  for (std::size_t i = 0; i < cells; ++i) {
    c.hit.push_back(draw());
    c.err.push_back(draw());
  }
  return c;
}

Counters decode(const EncodedTile& t, std::size_t cells) {
  Counters c;
  decode_tile(t.encoding, t.payload, cells, c.hit, c.err);
  return c;
}

/// what() of the TileDecodeError decode_tile throws, or "<no error>".
std::string decode_error(TileEncoding enc, const std::vector<std::uint8_t>& payload,
                         std::size_t cells) {
  std::vector<std::uint32_t> hit, err;
  try {
    decode_tile(enc, payload, cells, hit, err);
  } catch (const TileDecodeError& e) {
    return e.what();
  }
  return "<no error>";
}

bool starts_with(const std::string& s, const std::string& prefix) {
  return s.compare(0, prefix.size(), prefix) == 0;
}

/// One zlib stream of `bytes` (compress2, level 9).
std::vector<std::uint8_t> deflate_bytes(const std::vector<std::uint8_t>& bytes) {
  uLongf size = compressBound(static_cast<uLong>(bytes.size()));
  std::vector<std::uint8_t> out(size);
  EXPECT_EQ(compress2(out.data(), &size, bytes.data(), static_cast<uLong>(bytes.size()), 9), Z_OK);
  out.resize(size);
  return out;
}

/// The zlib stream of `zeros` zero bytes, deflated chunk by chunk (never holding them all).
std::vector<std::uint8_t> deflate_zeros(std::size_t zeros) {
  z_stream zs{};
  EXPECT_EQ(deflateInit(&zs, 9), Z_OK);
  std::vector<std::uint8_t> in(1 << 20, 0), out;
  std::vector<std::uint8_t> chunk(1 << 16);
  std::size_t left = zeros;
  int rc = Z_OK;
  do {
    const std::size_t n = std::min(left, in.size());
    zs.next_in = in.data();
    zs.avail_in = static_cast<uInt>(n);
    left -= n;
    const int flush = left == 0 ? Z_FINISH : Z_NO_FLUSH;
    do {
      zs.next_out = chunk.data();
      zs.avail_out = static_cast<uInt>(chunk.size());
      rc = deflate(&zs, flush);
      out.insert(out.end(), chunk.data(), chunk.data() + (chunk.size() - zs.avail_out));
    } while (zs.avail_out == 0);
  } while (left > 0);
  EXPECT_EQ(rc, Z_STREAM_END);
  EXPECT_EQ(zs.total_in, zeros);
  deflateEnd(&zs);
  return out;
}

/// Inflates a payload with zlib's one-shot uncompress (independent of decode_tile).
std::vector<std::uint8_t> inflate_all(const std::vector<std::uint8_t>& payload,
                                      std::size_t capacity) {
  std::vector<std::uint8_t> out(capacity);
  uLongf size = static_cast<uLongf>(capacity);
  EXPECT_EQ(uncompress(out.data(), &size, payload.data(), static_cast<uLong>(payload.size())),
            Z_OK);
  out.resize(size);
  return out;
}

/// FNV-1a 64 written out byte by byte from the specification, for comparison with tile_digest.
std::uint64_t reference_fnv1a(const Counters& c) {
  std::vector<std::uint8_t> bytes;
  for (const auto* values : {&c.hit, &c.err}) {
    for (const std::uint32_t v : *values) {
      bytes.push_back(static_cast<std::uint8_t>(v & 0xFF));
      bytes.push_back(static_cast<std::uint8_t>((v >> 8) & 0xFF));
      bytes.push_back(static_cast<std::uint8_t>((v >> 16) & 0xFF));
      bytes.push_back(static_cast<std::uint8_t>(v >> 24));
    }
  }
  std::uint64_t h = 14695981039346656037ull;
  for (const std::uint8_t b : bytes) {
    h ^= b;
    h *= 1099511628211ull;
  }
  return h;
}

constexpr TileEncoding kEncodings[] = {TileEncoding::kRaw, TileEncoding::kVarintZlib,
                                       TileEncoding::kMedZlib};

bool is_square(std::size_t cells) {
  for (std::size_t e = 0; e * e <= cells; ++e) {
    if (e * e == cells) return true;
  }
  return false;
}

// ---------------------------------------------------------------------------------------------
// Round trips and sizes

TEST(TileCodecTest, RoundTripsRandomCountersWithEveryEncoding) {
  for (const std::uint32_t seed : {1u, 20240611u, 4242424242u}) {
    for (const std::size_t cells :
         {kCells, std::size_t{1}, std::size_t{0}, std::size_t{1000}, std::size_t{1024}}) {
      const Counters in = random_counters(cells, seed);
      for (const TileEncoding enc : kEncodings) {
        if (enc == TileEncoding::kMedZlib && !is_square(cells)) continue;
        SCOPED_TRACE("seed " + std::to_string(seed) + ", cells " + std::to_string(cells) +
                     ", encoding " + std::to_string(static_cast<int>(enc)));
        const EncodedTile tile = encode_tile(in.hit, in.err, enc);
        EXPECT_EQ(tile.encoding, enc);
        const Counters out = decode(tile, cells);
        EXPECT_EQ(out.hit, in.hit);
        EXPECT_EQ(out.err, in.err);
      }
    }
  }
}

TEST(TileCodecTest, RoundTripsEveryZlibLevel) {
  const std::uint32_t seed = 7;
  const Counters in = random_counters(kCells, seed);
  for (int level = 0; level <= 9; ++level) {
    SCOPED_TRACE("seed " + std::to_string(seed) + ", level " + std::to_string(level));
    for (const TileEncoding enc : {TileEncoding::kVarintZlib, TileEncoding::kMedZlib}) {
      const Counters out = decode(encode_tile(in.hit, in.err, enc, level), kCells);
      EXPECT_EQ(out.hit, in.hit);
      EXPECT_EQ(out.err, in.err);
    }
  }
}

TEST(TileCodecTest, RoundTripsAllZeroTile) {
  const std::vector<std::uint32_t> zeros(kCells, 0);
  for (const TileEncoding enc : kEncodings) {
    const Counters out = decode(encode_tile(zeros, zeros, enc), kCells);
    EXPECT_EQ(out.hit, zeros);
    EXPECT_EQ(out.err, zeros);
  }
}

TEST(TileCodecTest, RoundTripsMaxValueCounters) {
  const std::vector<std::uint32_t> max(kCells, 0xFFFFFFFFu);
  for (const TileEncoding enc : kEncodings) {
    const Counters out = decode(encode_tile(max, max, enc), kCells);
    EXPECT_EQ(out.hit, max);
    EXPECT_EQ(out.err, max);
  }
}

TEST(TileCodecTest, AllZeroTileEncodesToUnder64Bytes) {
  const std::vector<std::uint32_t> zeros(kCells, 0);
  const EncodedTile tile = encode_tile(zeros, zeros);
  EXPECT_EQ(tile.encoding, TileEncoding::kMedZlib);
  EXPECT_LT(tile.payload.size(), 64u);
  EXPECT_LT(encode_tile(zeros, zeros, TileEncoding::kVarintZlib).payload.size(), 64u);
  EXPECT_EQ(encode_tile(zeros, zeros, TileEncoding::kRaw).payload.size(), 8 * kCells);
}

TEST(TileCodecTest, MedPredictionShrinksSmoothTiles) {
  // A wall of hits along a row and a free-space ramp of err counts: smooth, as real tiles are.
  std::vector<std::uint32_t> hit(kCells, 0), err(kCells, 0);
  for (std::size_t i = 0; i < kCells; ++i) {
    const std::size_t x = i % 64, y = i / 64;
    if (y == 40) hit[i] = 30;
    if (y < 40) err[i] = static_cast<std::uint32_t>(200 + 3 * x + y);
  }
  const auto med = encode_tile(hit, err, TileEncoding::kMedZlib);
  const auto varint = encode_tile(hit, err, TileEncoding::kVarintZlib);
  EXPECT_LT(med.payload.size(), varint.payload.size());
  const Counters out = decode(med, kCells);
  EXPECT_EQ(out.hit, hit);
  EXPECT_EQ(out.err, err);
}

TEST(TileCodecTest, MedNeedsSquareTiles) {
  const std::vector<std::uint32_t> five(5, 1);
  EXPECT_THROW(encode_tile(five, five, TileEncoding::kMedZlib), std::invalid_argument);
  const std::vector<std::uint32_t> four(4, 1);
  const auto tile = encode_tile(four, four, TileEncoding::kMedZlib);
  EXPECT_EQ(decode_error(TileEncoding::kMedZlib, tile.payload, 5), "5 cells is not a square tile");
  EXPECT_EQ(decode_error(TileEncoding::kMedZlib, tile.payload, 9),
            "varint stream ends after 8 of 9 hit cells");
}

TEST(TileCodecTest, RawIsLittleEndianHitThenErr) {
  const std::vector<std::uint32_t> hit{0x04030201u, 0xFFFFFFFFu};
  const std::vector<std::uint32_t> err{0x00000005u, 0x80000000u};
  const EncodedTile tile = encode_tile(hit, err, TileEncoding::kRaw);
  const std::vector<std::uint8_t> expected{1, 2, 3, 4, 0xFF, 0xFF, 0xFF, 0xFF,  // hit
                                           5, 0, 0, 0, 0,    0,    0,    0x80};
  EXPECT_EQ(tile.payload, expected);
}

TEST(TileCodecTest, VarintZlibIsDeflatedLeb128HitThenErrPerCell) {
  const std::vector<std::uint32_t> hit{0, 300, 0xFFFFFFFFu};
  const std::vector<std::uint32_t> err{127, 128, 1};
  const EncodedTile tile = encode_tile(hit, err, TileEncoding::kVarintZlib);
  const std::vector<std::uint8_t> expected{
      0x00, 0x7F,                          // cell 0: hit 0, err 127
      0xAC, 0x02, 0x80, 0x01,              // cell 1: hit 300, err 128
      0xFF, 0xFF, 0xFF, 0xFF, 0x0F, 0x01,  // cell 2: hit 2^32 - 1, err 1
  };
  EXPECT_EQ(inflate_all(tile.payload, 64), expected);
}

// ---------------------------------------------------------------------------------------------
// Hostile payloads: every error has its crafted payload

TEST(TileCodecTest, TruncatedZlibStreamIsRejected) {
  const Counters in = random_counters(kCells, 99);
  const EncodedTile tile = encode_tile(in.hit, in.err);
  for (const std::size_t cut : {std::size_t{1}, std::size_t{4}, tile.payload.size() / 2,
                                tile.payload.size() - 1, tile.payload.size()}) {
    SCOPED_TRACE("seed 99, cutting " + std::to_string(cut) + " of " +
                 std::to_string(tile.payload.size()) + " bytes");
    std::vector<std::uint8_t> payload(tile.payload.begin(), tile.payload.end() - cut);
    const std::string what = decode_error(TileEncoding::kVarintZlib, payload, kCells);
    EXPECT_TRUE(starts_with(what, "zlib: stream is truncated")) << what;
  }
}

TEST(TileCodecTest, CorruptZlibStreamIsRejected) {
  const Counters in = random_counters(kCells, 5);
  const EncodedTile tile = encode_tile(in.hit, in.err);
  std::vector<std::uint8_t> bad_header = tile.payload;
  bad_header[0] ^= 0xFF;
  EXPECT_EQ(decode_error(TileEncoding::kVarintZlib, bad_header, kCells),
            "zlib: incorrect header check");
  std::vector<std::uint8_t> bad_checksum = tile.payload;
  bad_checksum.back() ^= 0x01;  // last byte of the Adler-32
  EXPECT_EQ(decode_error(TileEncoding::kVarintZlib, bad_checksum, kCells),
            "zlib: incorrect data check");
}

TEST(TileCodecTest, ZlibBombIsRejectedWithoutAllocatingIt) {
  constexpr std::size_t kBombBytes = 100'000'000;
  const std::vector<std::uint8_t> bomb = deflate_zeros(kBombBytes);
  ASSERT_LT(bomb.size(), 200'000u);  // 100 MB in ~100 kB

  const std::size_t bound = 2 * kMaxVarintBytes * kCells;
  std::vector<std::uint32_t> hit, err;
  std::string what = "<no error>";
  g_allocated_bytes = 0;
  g_largest_allocation = 0;
  g_count_allocations = true;
  try {
    decode_tile(TileEncoding::kVarintZlib, bomb, kCells, hit, err);
  } catch (const TileDecodeError& e) {
    g_count_allocations = false;
    what = e.what();
  }
  g_count_allocations = false;
  EXPECT_EQ(what, "inflated data exceeds the bound of 40960 bytes for 4096 cells");
  EXPECT_GT(g_allocated_bytes.load(), 0u);  // the counting did run
  EXPECT_LE(g_largest_allocation.load(), bound);
  EXPECT_LT(g_allocated_bytes.load(), bound + 4096);  // the buffer plus the message
}

TEST(TileCodecTest, WrongRawSizeIsRejected) {
  EXPECT_EQ(decode_error(TileEncoding::kRaw, std::vector<std::uint8_t>(100), kCells),
            "raw payload is 100 bytes, expected 32768");
  EXPECT_EQ(decode_error(TileEncoding::kRaw, std::vector<std::uint8_t>(8 * kCells + 1), kCells),
            "raw payload is 32769 bytes, expected 32768");
  EXPECT_EQ(decode_error(TileEncoding::kRaw, {}, kCells), "raw payload is 0 bytes, expected 32768");
}

TEST(TileCodecTest, UnknownEncodingIsRejected) {
  const auto seven = static_cast<TileEncoding>(7);
  const EncodedTile tile =
      encode_tile(std::vector<std::uint32_t>(kCells, 0), std::vector<std::uint32_t>(kCells, 0));
  EXPECT_EQ(decode_error(seven, tile.payload, kCells), "unknown encoding 7");
  const std::vector<std::uint32_t> one{1};
  EXPECT_THROW(encode_tile(one, one, seven), std::invalid_argument);
}

TEST(TileCodecTest, OverlongVarintIsRejected) {
  // Cell 0 fine; cell 1's hit is a 6-byte varint (of the value 1).
  const std::vector<std::uint8_t> six_bytes{0x00, 0x00, 0x81, 0x80, 0x80, 0x80, 0x80, 0x00, 0x00};
  EXPECT_EQ(decode_error(TileEncoding::kVarintZlib, deflate_bytes(six_bytes), 2),
            "varint overflows uint32 (cell 1, hit)");
  // 5 bytes whose last one carries a 33rd bit: 2^32.
  const std::vector<std::uint8_t> bit_33{0x00, 0x80, 0x80, 0x80, 0x80, 0x10};
  EXPECT_EQ(decode_error(TileEncoding::kVarintZlib, deflate_bytes(bit_33), 1),
            "varint overflows uint32 (cell 0, err)");
  // The longest valid varint, 2^32 - 1, and a non-minimal 5-byte 0 decode.
  const std::vector<std::uint8_t> max{0xFF, 0xFF, 0xFF, 0xFF, 0x0F, 0x80, 0x80, 0x80, 0x80, 0x00};
  std::vector<std::uint32_t> hit, err;
  decode_tile(TileEncoding::kVarintZlib, deflate_bytes(max), 1, hit, err);
  EXPECT_EQ(hit, std::vector<std::uint32_t>{0xFFFFFFFFu});
  EXPECT_EQ(err, std::vector<std::uint32_t>{0u});
}

TEST(TileCodecTest, ShortVarintStreamIsRejected) {
  const Counters in = random_counters(4000, 11);
  SCOPED_TRACE("seed 11");
  EXPECT_EQ(decode_error(TileEncoding::kVarintZlib,
                         encode_tile(in.hit, in.err, TileEncoding::kVarintZlib).payload, kCells),
            "varint stream ends after 4000 of 4096 cells");
  // Ends inside cell 1: its hit is complete, its err varint is cut after a continuation byte.
  const std::vector<std::uint8_t> cut{0x05, 0x06, 0x07, 0x80};
  EXPECT_EQ(decode_error(TileEncoding::kVarintZlib, deflate_bytes(cut), 2),
            "varint stream ends after 1 of 2 cells");
  EXPECT_EQ(decode_error(TileEncoding::kVarintZlib, deflate_bytes({}), 1),
            "varint stream ends after 0 of 1 cells");
}

TEST(TileCodecTest, TrailingDataIsRejected) {
  // After the last cell, inside the zlib stream.
  const Counters in = random_counters(kCells + 1, 12);
  SCOPED_TRACE("seed 12");
  const std::vector<std::uint8_t> extra_cell =
      encode_tile(in.hit, in.err, TileEncoding::kVarintZlib).payload;
  const std::string what = decode_error(TileEncoding::kVarintZlib, extra_cell, kCells);
  EXPECT_TRUE(starts_with(what, "trailing bytes: ")) << what;
  EXPECT_EQ(decode_error(TileEncoding::kVarintZlib, deflate_bytes({0x01, 0x02, 0x03}), 1),
            "trailing bytes: 1 after the last of 1 cells");
  // After the end of the zlib stream.
  std::vector<std::uint8_t> appended =
      encode_tile(in.hit, in.err, TileEncoding::kVarintZlib).payload;
  appended.push_back(0x00);
  appended.push_back(0x00);
  EXPECT_EQ(decode_error(TileEncoding::kVarintZlib, appended, kCells + 1),
            "trailing bytes: 2 after the end of the zlib stream");
}

TEST(TileCodecTest, TooManyCellsIsRejected) {
  const std::size_t too_many = kMaxTileCells + 1;
  EXPECT_EQ(kMaxTileCells, std::size_t{1} << 20);
  EXPECT_EQ(decode_error(TileEncoding::kRaw, std::vector<std::uint8_t>(8), too_many),
            "tile of 1048577 cells, more than 1048576");
  EXPECT_EQ(decode_error(TileEncoding::kVarintZlib, deflate_bytes({0, 0}), too_many),
            "tile of 1048577 cells, more than 1048576");
  // The limit itself (a 1024 x 1024 tile) is fine.
  const std::vector<std::uint32_t> zeros(kMaxTileCells, 0);
  const Counters out = decode(encode_tile(zeros, zeros), kMaxTileCells);
  EXPECT_EQ(out.hit, zeros);
  EXPECT_EQ(out.err, zeros);
  const std::vector<std::uint32_t> over(too_many, 0);
  EXPECT_THROW(encode_tile(over, over), std::invalid_argument);
}

TEST(TileCodecTest, EncodeRejectsBadArguments) {
  const std::vector<std::uint32_t> two(2, 1), three(3, 1);
  EXPECT_THROW(encode_tile(two, three), std::invalid_argument);
  EXPECT_THROW(encode_tile(two, two, TileEncoding::kVarintZlib, 10), std::invalid_argument);
  EXPECT_THROW(encode_tile(two, two, TileEncoding::kVarintZlib, -1), std::invalid_argument);
  EXPECT_THROW(tile_digest(two, three), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------
// Digests

TEST(TileCodecTest, DigestIsFnv1aOfLittleEndianHitThenErr) {
  EXPECT_EQ(tile_digest({}, {}), 0xcbf29ce484222325ull);  // FNV-1a 64 offset basis
  for (const std::uint32_t seed : {3u, 31u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const Counters c = random_counters(kCells, seed);
    EXPECT_EQ(tile_digest(c.hit, c.err), reference_fnv1a(c));
  }
}

TEST(TileCodecTest, DigestChangesWhenOneCounterChangesByOne) {
  const std::uint32_t seed = 77;
  SCOPED_TRACE("seed 77");
  const Counters base = random_counters(kCells, seed);
  const std::uint64_t d = tile_digest(base.hit, base.err);
  std::mt19937 rng(seed);
  for (int trial = 0; trial < 50; ++trial) {
    const std::size_t i = rng() % kCells;
    Counters c = base;
    ++c.hit[i];
    EXPECT_NE(tile_digest(c.hit, c.err), d) << "hit[" << i << "] + 1";
    c = base;
    --c.err[i];
    EXPECT_NE(tile_digest(c.hit, c.err), d) << "err[" << i << "] - 1";
  }
  // Swapping hit and err is a different tile, too.
  EXPECT_NE(tile_digest(base.err, base.hit), d);
}

/// Applies the same map updates to `map`: cells over several tiles, negative keys included.
void build_map(GridMap& map) {
  for (int i = -100; i < 100; i += 3) {
    map.add_hit({i, 2 * i});
    map.add_err({i, 2 * i + 1});
    map.add_err({i + 1, 2 * i});
  }
  map.commit_update();
}

TEST(TileCodecTest, MapDigestEqualForSameUpdatesAndDiffersAfterOneMoreHit) {
  GridMap a, b;
  build_map(a);
  build_map(b);
  ASSERT_GT(a.tile_count(), 4u);
  EXPECT_EQ(map_digest(a), map_digest(b));
  const std::string before = map_digest(b);
  b.add_hit({0, 0});
  EXPECT_NE(map_digest(b), before);
  EXPECT_NE(map_digest(a), map_digest(b));
  EXPECT_EQ(map_digest(GridMap{}), "");
}

TEST(TileCodecTest, MapDigestLeavesOutATileWhoseObservationsWereAllTakenBack) {
  // A loop closure applied late removes the scans written after its key scan; a tile only they
  // had opened stays, all unknown. The digest is the same as without it.
  GridMap a, b;
  build_map(a);
  build_map(b);
  const CellIndex far{5000, -3000};
  b.add_hit(far);
  b.add_err(far);
  b.commit_update();
  ASSERT_EQ(b.tile_count(), a.tile_count() + 1);
  EXPECT_NE(map_digest(b), map_digest(a));
  ASSERT_TRUE(b.remove_hit(far));
  ASSERT_TRUE(b.remove_err(far));
  b.commit_update();
  ASSERT_EQ(b.tile_count(), a.tile_count() + 1);  // the tile is still there, all zero
  EXPECT_EQ(map_digest(b), map_digest(a));
}

TEST(TileCodecTest, MapDigestListsSortedTilesWithHexDigests) {
  GridMap map;
  build_map(map);
  std::istringstream lines(map_digest(map));
  std::string line;
  std::vector<TileKey> keys;
  while (std::getline(lines, line)) {
    std::istringstream fields(line);
    TileKey k;
    std::string hex;
    fields >> k.tx >> k.ty >> hex;
    ASSERT_FALSE(fields.fail()) << line;
    EXPECT_EQ(hex.size(), 16u) << line;
    EXPECT_EQ(hex.find_first_not_of("0123456789abcdef"), std::string::npos) << line;
    const Tile* tile = map.find_tile(k);
    ASSERT_NE(tile, nullptr) << line;
    EXPECT_EQ(std::stoull(hex, nullptr, 16), tile_digest(tile->hit, tile->err)) << line;
    keys.push_back(k);
  }
  EXPECT_EQ(keys, map.tile_keys());
  EXPECT_TRUE(std::is_sorted(keys.begin(), keys.end()));
}

TEST(TileCodecTest, FollowerRebuildsMapWithSameDigest) {
  GridMap leader;
  build_map(leader);
  for (const TileEncoding enc : kEncodings) {
    GridMap follower;
    for (const TileKey& k : leader.tile_keys()) {
      const Tile* t = leader.find_tile(k);
      const EncodedTile wire = encode_tile(t->hit, t->err, enc);
      std::vector<std::uint32_t> hit, err;
      decode_tile(wire.encoding, wire.payload, follower.cells_per_tile(), hit, err);
      follower.set_tile(k, t->version, hit, err);
    }
    EXPECT_EQ(map_digest(follower), map_digest(leader));
  }
}

}  // namespace
}  // namespace esfleet
