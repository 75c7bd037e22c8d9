#pragma once
// Private to core: PNG reading and writing through libpng, for the map images (load_ros_map
// reads them, save_map_png writes them). libpng reports errors by longjmp; these calls turn
// them into exceptions and keep libpng's warnings off stderr.

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

#include "image_decoder.hpp"

namespace esfleet::detail {

/// Decodes the PNG file contents `data` into 8-bit samples, as OpenCV's imdecode with
/// IMREAD_UNCHANGED did before (same samples, so the same map cells): grey stays 1 channel (a
/// tRNS chunk ignored), grey+alpha 2, RGB 3 (4 with tRNS), palette images expand to RGB (RGBA
/// with tRNS), RGBA 4; grey below 8 bits is scaled up, 16-bit samples become round(v / 257).
/// Channel order R, G, B(, A). `path` names the file in errors. Throws std::runtime_error
/// "<path>: cannot decode PNG image: <libpng's reason>" on a malformed or truncated image.
/// Expects the caller to have checked the chunk structure and the dimensions (check_png).
Pixels read_png(const std::string& path, std::string_view data);

/// The PNG encoding of `image` (8-bit, 1 grey, 2 grey+alpha, 3 RGB or 4 RGBA channels),
/// compressed for speed (sub filter, zlib level 1, run-length strategy). Throws
/// std::runtime_error on failure (out of memory) or std::invalid_argument on a bad image.
std::string write_png(const Pixels& image);

/// The same for an image produced row by row, so that it need not be held whole:
/// `fill_row(r, out)` writes row r (from the top, width * channels bytes) into `out`; rows are
/// asked for in order. Throws std::invalid_argument for a bad size or channel count.
std::string write_png(int width, int height, int channels,
                      const std::function<void(int, std::uint8_t*)>& fill_row);

}  // namespace esfleet::detail
