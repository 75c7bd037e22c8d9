#pragma once
// The view's WebSocket messages that carry the map (docs/view.md, "Protocol"): one binary frame
// per tile, a fixed little-endian header and the tile's cells as one class byte each (what
// map.png shows: 0 unknown, 1 free, 2 occupied, ros_cell_value of the cell's counters),
// zlib-compressed (RFC 1950, what a browser's DecompressionStream("deflate") reads). Pure: no
// network, no DDS; the page decodes the same layout (view/web/view.js).

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "esfleet/core/grid_map.hpp"

namespace esfleet::view {

/// Cell classes in a tile frame (the map.png colours: unknown blue-grey, free white, occupied
/// black).
inline constexpr std::uint8_t kCellUnknown = 0;
inline constexpr std::uint8_t kCellFree = 1;
inline constexpr std::uint8_t kCellOccupied = 2;

/// Byte 0 of a tile frame, and the layout version in byte 1.
inline constexpr std::uint8_t kTileFrameType = 'T';
inline constexpr std::uint8_t kTileFrameVersion = 1;
/// Header bytes before the payload.
inline constexpr std::size_t kTileFrameHeaderBytes = 44;
/// Largest tile edge a frame may carry (the replica's own limit is lower).
inline constexpr std::uint32_t kMaxFrameTileEdge = 1024;

/// What a tile frame says besides its cells.
struct TileFrameHeader {
  std::uint32_t epoch = 0;  ///< the map's epoch (a new epoch replaces the whole map)
  std::int32_t tx = 0, ty = 0;
  std::uint64_t version = 0;    ///< the tile's version in the leader's map
  std::uint64_t stamp_ns = 0;   ///< when the leader published this version (realtime ns), 0 unknown
  std::uint32_t tile_edge = 0;  ///< cells per tile edge
  bool compressed = true;       ///< payload zlib-compressed (else raw class bytes)
};

/// A tile's cells as class bytes, row-major from its lower-left cell (index = ly * edge + lx),
/// each cell's class by ros_cell_value with the default thresholds (map.png's).
std::vector<std::uint8_t> tile_classes(const Tile& tile, int tile_edge);

/// The frame for one tile: the header, then the classes (zlib when header.compressed).
/// Throws std::invalid_argument naming the field when classes.size() != tile_edge^2 or
/// tile_edge is 0 or above kMaxFrameTileEdge.
std::string encode_tile_frame(const TileFrameHeader& header,
                              const std::vector<std::uint8_t>& classes);

/// A decoded tile frame (tests, benchmarks).
struct DecodedTileFrame {
  TileFrameHeader header;
  std::vector<std::uint8_t> classes;
};
/// Decodes a frame made by encode_tile_frame; std::nullopt with `error` naming the field when it
/// is not one (short, wrong type or version, sizes that disagree, bad zlib, a class above 2).
std::optional<DecodedTileFrame> decode_tile_frame(const std::string& frame,
                                                  std::string* error = nullptr);

}  // namespace esfleet::view
