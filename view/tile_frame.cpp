#include "tile_frame.hpp"

#include <zlib.h>

#include <bit>
#include <cstring>
#include <stdexcept>

#include "esfleet/core/ros_map_format.hpp"

namespace esfleet::view {

namespace {

template <class T>
void put(std::string& out, std::size_t at, T v) {
  // Little-endian on every host the view runs on (x86-64, arm64); memcpy keeps it well defined.
  static_assert(std::endian::native == std::endian::little, "the frame layout is little-endian");
  std::memcpy(out.data() + at, &v, sizeof v);
}

template <class T>
T get(const std::string& in, std::size_t at) {
  T v;
  std::memcpy(&v, in.data() + at, sizeof v);
  return v;
}

bool fail(std::string* error, const std::string& why) {
  if (error) *error = why;
  return false;
}

}  // namespace

std::vector<std::uint8_t> tile_classes(const Tile& tile, int tile_edge) {
  const std::size_t n = static_cast<std::size_t>(tile_edge) * static_cast<std::size_t>(tile_edge);
  std::vector<std::uint8_t> classes(n, kCellUnknown);
  if (tile.hit.size() < n || tile.err.size() < n) return classes;
  for (std::size_t i = 0; i < n; ++i) {
    switch (ros_cell_value(tile.hit[i], tile.err[i])) {
      case 100:
        classes[i] = kCellOccupied;
        break;
      case 0:
        classes[i] = kCellFree;
        break;
      default:
        break;
    }
  }
  return classes;
}

std::string encode_tile_frame(const TileFrameHeader& h, const std::vector<std::uint8_t>& classes) {
  if (h.tile_edge == 0 || h.tile_edge > kMaxFrameTileEdge) {
    throw std::invalid_argument("tile_edge " + std::to_string(h.tile_edge) + " not in [1, " +
                                std::to_string(kMaxFrameTileEdge) + "]");
  }
  if (classes.size() != static_cast<std::size_t>(h.tile_edge) * h.tile_edge) {
    throw std::invalid_argument("classes: " + std::to_string(classes.size()) +
                                " cells for a tile edge of " + std::to_string(h.tile_edge));
  }
  std::string payload;
  if (h.compressed) {
    uLongf size = compressBound(static_cast<uLong>(classes.size()));
    payload.resize(size);
    if (compress2(reinterpret_cast<Bytef*>(payload.data()), &size, classes.data(),
                  static_cast<uLong>(classes.size()), 6) != Z_OK) {
      throw std::runtime_error("zlib failed to compress a tile");
    }
    payload.resize(size);
  } else {
    payload.assign(classes.begin(), classes.end());
  }
  std::string out(kTileFrameHeaderBytes, '\0');
  out[0] = static_cast<char>(kTileFrameType);
  out[1] = static_cast<char>(kTileFrameVersion);
  out[2] = h.compressed ? 1 : 0;
  put<std::uint16_t>(out, 4, static_cast<std::uint16_t>(h.tile_edge));
  put<std::uint32_t>(out, 8, h.epoch);
  put<std::int32_t>(out, 12, h.tx);
  put<std::int32_t>(out, 16, h.ty);
  put<std::uint64_t>(out, 24, h.version);
  put<std::uint64_t>(out, 32, h.stamp_ns);
  put<std::uint32_t>(out, 40, static_cast<std::uint32_t>(payload.size()));
  out += payload;
  return out;
}

std::optional<DecodedTileFrame> decode_tile_frame(const std::string& f, std::string* error) {
  if (f.size() < kTileFrameHeaderBytes) {
    fail(error, "frame of " + std::to_string(f.size()) + " bytes is shorter than the header");
    return std::nullopt;
  }
  if (static_cast<std::uint8_t>(f[0]) != kTileFrameType) {
    fail(error, "type byte is not 'T'");
    return std::nullopt;
  }
  if (static_cast<std::uint8_t>(f[1]) != kTileFrameVersion) {
    fail(error, "layout version " + std::to_string(static_cast<int>(f[1])) + " is not 1");
    return std::nullopt;
  }
  DecodedTileFrame d;
  TileFrameHeader& h = d.header;
  const auto encoding = static_cast<std::uint8_t>(f[2]);
  if (encoding > 1) {
    fail(error, "encoding " + std::to_string(encoding) + " is neither 0 (raw) nor 1 (zlib)");
    return std::nullopt;
  }
  h.compressed = encoding == 1;
  h.tile_edge = get<std::uint16_t>(f, 4);
  h.epoch = get<std::uint32_t>(f, 8);
  h.tx = get<std::int32_t>(f, 12);
  h.ty = get<std::int32_t>(f, 16);
  h.version = get<std::uint64_t>(f, 24);
  h.stamp_ns = get<std::uint64_t>(f, 32);
  const std::uint32_t payload = get<std::uint32_t>(f, 40);
  if (h.tile_edge == 0 || h.tile_edge > kMaxFrameTileEdge) {
    fail(error, "tile_edge " + std::to_string(h.tile_edge) + " out of range");
    return std::nullopt;
  }
  if (payload != f.size() - kTileFrameHeaderBytes) {
    fail(error, "payload size " + std::to_string(payload) + " but " +
                    std::to_string(f.size() - kTileFrameHeaderBytes) + " bytes follow the header");
    return std::nullopt;
  }
  const std::size_t n = static_cast<std::size_t>(h.tile_edge) * h.tile_edge;
  const auto* src = reinterpret_cast<const Bytef*>(f.data() + kTileFrameHeaderBytes);
  d.classes.resize(n);
  if (h.compressed) {
    uLongf size = static_cast<uLongf>(n);
    if (uncompress(d.classes.data(), &size, src, payload) != Z_OK || size != n) {
      fail(error, "payload is not zlib data of " + std::to_string(n) + " cells");
      return std::nullopt;
    }
  } else {
    if (payload != n) {
      fail(error, "raw payload of " + std::to_string(payload) + " bytes for " + std::to_string(n) +
                      " cells");
      return std::nullopt;
    }
    std::memcpy(d.classes.data(), src, n);
  }
  for (std::uint8_t c : d.classes) {
    if (c > kCellOccupied) {
      fail(error, "cell class " + std::to_string(c) + " above 2");
      return std::nullopt;
    }
  }
  return d;
}

}  // namespace esfleet::view
