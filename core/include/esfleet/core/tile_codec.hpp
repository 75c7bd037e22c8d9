#pragma once
// Tile codec: turns the hit/err counters of one map tile into bytes for the wire and back, and
// the digests leader and followers compare to check that they hold the same map. Pure C++ and
// zlib, no DDS: the leader encodes each dirty tile, followers decode and GridMap::set_tile it.
//
// Encodings (TileEncoding):
//  - kRaw: little-endian uint32 hit[0..cells) then err[0..cells): 8 bytes per cell.
//  - kVarintZlib: for each cell in order, the LEB128 varint of hit then of err (7 bits per byte,
//    least significant group first, high bit = more bytes follow; 1 to 5 bytes per uint32), the
//    whole stream deflated as one zlib stream (RFC 1950). Most counters are small and most cells
//    of a tile are unknown (0, 0), so this is a fraction of kRaw.
//  - kMedZlib (the default): the hit plane, then the err plane; each cell is predicted from its
//    left, upper and upper-left neighbours with LOCO-I's median edge detector, and the residual
//    (value - prediction, modulo 2^32, zigzag-mapped) is written as a LEB128 varint; the whole
//    stream deflated. Counters are smooth along walls and free space, so the residuals are
//    mostly 0: on an MIT CSAIL map 28 % smaller than kVarintZlib. Needs square tiles.
//
// Payloads come from the network and may be hostile: decode_tile checks everything, never reads
// outside the payload, and never inflates more than kMaxVarintBytes * 2 * cells bytes whatever
// the payload claims (a zlib bomb is rejected after that many bytes).

#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "esfleet/core/grid_map.hpp"

namespace esfleet {

/// How a tile payload is encoded; the value travels on the wire.
enum class TileEncoding : std::uint8_t {
  kRaw = 0,         ///< little-endian uint32 hit[] then err[]
  kVarintZlib = 1,  ///< LEB128 varints hit, err per cell, deflated (zlib)
  kMedZlib = 2,     ///< planes of MED-predicted zigzag varint residuals, deflated (zlib)
};

/// Largest tile encode_tile / decode_tile accept, in cells (a 1024 x 1024 tile).
inline constexpr std::size_t kMaxTileCells = std::size_t{1} << 20;

/// Longest LEB128 varint of a uint32 (5 x 7 bits >= 32). decode_tile inflates at most
/// 2 * kMaxVarintBytes bytes per cell.
inline constexpr std::size_t kMaxVarintBytes = 5;

/// A malformed tile payload. what() is the precise reason, e.g. "unknown encoding 7",
/// "raw payload is 100 bytes, expected 32768", "zlib: incorrect header check",
/// "varint stream ends after 1234 of 4096 cells", "varint overflows uint32 (cell 17, hit)".
class TileDecodeError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The encoded counters of one tile: what goes on the wire next to the tile key and version.
struct EncodedTile {
  TileEncoding encoding = TileEncoding::kMedZlib;
  std::vector<std::uint8_t> payload;
};

/// Encodes one tile's counters (`hit` and `err` of the same size, the tile's cell count, row
/// major as in Tile). `zlib_level` (0 = store .. 9 = smallest) is used by the zlib encodings.
/// Throws std::invalid_argument when the sizes differ, exceed kMaxTileCells, or `enc` or
/// `zlib_level` (outside [0, 9]) is invalid; std::bad_alloc if zlib runs out of memory.
EncodedTile encode_tile(std::span<const std::uint32_t> hit, std::span<const std::uint32_t> err,
                        TileEncoding enc = TileEncoding::kMedZlib, int zlib_level = 6);

/// Decodes a payload of `cells` cells into `hit` and `err` (both resized to `cells`). Throws
/// TileDecodeError naming the reason for anything malformed: `cells` > kMaxTileCells, an unknown
/// `enc` ("unknown encoding 7"), a raw payload of the wrong size, a zlib error ("zlib: ..."
/// including a truncated stream), bytes after the end of the zlib stream or after the last
/// cell ("trailing bytes ..."), too few varints ("varint stream ends after N of M cells"), a
/// varint longer than kMaxVarintBytes or above UINT32_MAX ("varint overflows uint32 ..."), or
/// more inflated data than any valid payload has ("inflated data exceeds the bound ...").
/// Memory: at most 2 * kMaxVarintBytes * cells bytes of inflate output (plus zlib's fixed
/// ~40 KiB of state), whatever the payload. Non-minimal varints (e.g. 0x80 0x00 for 0) are
/// accepted. On a throw the contents of `hit` and `err` are unspecified.
void decode_tile(TileEncoding enc, std::span<const std::uint8_t> payload, std::size_t cells,
                 std::vector<std::uint32_t>& hit, std::vector<std::uint32_t>& err);

/// 64-bit FNV-1a over the little-endian bytes of hit[] then err[]: the per-tile digest leader
/// and followers compare. Throws std::invalid_argument when the sizes differ.
std::uint64_t tile_digest(std::span<const std::uint32_t> hit, std::span<const std::uint32_t> err);

/// One line per tile of `map` with any counter set, sorted by key: "tx ty digest\n" with tx, ty
/// in decimal and the tile_digest as 16 lowercase hex digits. Written by the leader and by
/// followers to compare maps; "" for a map without observations. An all-zero tile (all cells
/// unknown) is left out: it is the same map as no tile, and whether one exists depends on
/// timing (a loop closure applied late takes back scans that had opened it).
std::string map_digest(const GridMap& map);

}  // namespace esfleet
