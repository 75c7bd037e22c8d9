#pragma once
// Private to core: decoding the map images load_ros_map reads (PGM P5/P2 by hand, PNG through
// libpng after a structural check), into 8-bit samples, refusing hostile input with a message
// instead of crashing or allocating for a lying header.

#include <cstdint>
#include <string>
#include <vector>

namespace esfleet::detail {

/// A decoded image, 8 bits per sample, interleaved, rows from the top. Channel orders: 1 grey,
/// 2 grey+alpha, 3 RGB, 4 RGBA.
struct Pixels {
  int width = 0;
  int height = 0;
  int channels = 1;
  std::vector<std::uint8_t> data;
};

/// The image file contents `data` (PGM or PNG, told apart by their magic bytes); `path` names
/// it in errors. 16-bit and maxval != 255 samples are scaled to 8 bits. Throws
/// std::runtime_error "<path>: ..." on anything else, a malformed or truncated image, or one
/// over kMaxMapImagePixels.
Pixels decode_image(const std::string& path, const std::string& data);

}  // namespace esfleet::detail
