#pragma once
// Binary snapshots of a running SLAM, for the leader's checkpoints (leader/checkpoint.hpp):
// the map's counters and tile versions, and the SlamState (pose history, motion state, key
// scans, pose graph, random generator). A Slam built with the same config, given both back,
// continues exactly as the one that was saved: same poses, same map, bit for bit.
//
// Format (both blobs): an 8-byte magic ("ESFMAP01" / "ESFSLAM1"), the fields in a fixed order as
// little-endian integers and IEEE doubles/floats, then the 64-bit FNV-1a of everything before
// it. The map stores every tile as key, version and its counters encoded with tile_codec
// (kMedZlib). Decoding checks the magic, every length against what is left, and the checksum,
// and throws SnapshotError naming the field ("keys[3].points.x: truncated"). The SLAM blob ends
// with the key of a pending loop-closure search when there is one (SlamState::pending_loop_key).

#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>
#include <string_view>

#include <vector>

#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/slam.hpp"
#include "esfleet/core/tile_codec.hpp"

namespace esfleet {

/// A snapshot that cannot be read back; what() names the field.
class SnapshotError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Every tile of `map`: key, version, encoded counters (plus the layout: cell size, tile edge).
std::string encode_map_snapshot(const GridMap& map);
/// One tile of a map snapshot, its counters already encoded (kMedZlib).
struct SnapshotTile {
  TileKey key;
  std::uint64_t version = 0;
  const EncodedTile* encoded = nullptr;
};
/// The same bytes as encode_map_snapshot of a map with these tiles (sorted by key), for a
/// writer that keeps the encoded tiles of earlier snapshots and encodes only the changed ones.
std::string encode_map_snapshot(double cell_size, int tile_edge,
                                const std::vector<SnapshotTile>& tiles);
/// Puts the tiles of a map snapshot into `map` (GridMap::set_tile, not marked dirty). The
/// snapshot's cell size and tile edge must equal the map's. Throws SnapshotError.
void decode_map_snapshot(std::string_view bytes, GridMap& map);

std::string encode_slam_state(const SlamState& state);
/// The bytes of encode_slam_state(state) handed to `sink` in pieces of about 64 kB, in order,
/// without holding them all (the leader's checkpoint writer streams them into the file: the
/// key scans make the blob 8 MB on CSAIL); returns their count.
std::uint64_t write_slam_state(const SlamState& state,
                               const std::function<void(std::string_view)>& sink);
/// Throws SnapshotError for a malformed or corrupt blob.
SlamState decode_slam_state(std::string_view bytes);

}  // namespace esfleet
