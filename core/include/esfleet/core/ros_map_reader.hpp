#pragma once
// Loading a ROS map_server map (ros_map_format.hpp) as nav2_map_server reads it: from files or
// from bytes in memory. Hostile input never crashes it.

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "esfleet/core/ros_map_format.hpp"

namespace esfleet {

/// A map loaded from a ROS map_server pair: what the simulator and tools need (not counters).
struct OccupancyImage {
  double resolution = 0.05;   ///< metres per pixel
  double origin_x = 0.0;      ///< world x of the lower-left corner of the bottom-left pixel
  double origin_y = 0.0;      ///< world y of that corner
  double origin_theta = 0.0;  ///< YAML origin yaw (rad), as given; most ROS tools ignore it
  int width = 0;              ///< pixels
  int height = 0;             ///< pixels
  /// Row-major from the BOTTOM row (y up, like the grid): -1 unknown, 0..100 occupancy percent
  /// as nav2_map_server computes it.
  std::vector<std::int8_t> cells;

  /// Cell value at pixel column `col`, row `row_from_bottom`; -1 (unknown) outside the image.
  std::int8_t at(int col, int row_from_bottom) const {
    if (col < 0 || row_from_bottom < 0 || col >= width || row_from_bottom >= height) return -1;
    return cells[static_cast<std::size_t>(row_from_bottom) * static_cast<std::size_t>(width) +
                 static_cast<std::size_t>(col)];
  }
};

/// Loads a ROS map_server YAML file and the image it names (relative to the YAML file's
/// directory unless absolute), computing cells as nav2_map_server does:
///  - YAML (yaml-cpp): required image, resolution (finite, > 0), origin (3 finite numbers),
///    negate (int, non-zero = true, or bool), occupied_thresh and free_thresh (finite,
///    0 <= free < occupied <= 1); optional mode: trinary (default) | scale | raw. Other keys
///    are ignored, as map_server does.
///  - image: PGM (P5 binary or P2 ascii, maxval 1..65535, '#' comments in the header) or PNG
///    (libpng, grey / grey+alpha / RGB / RGBA / palette, 1 to 16 bit; a tRNS chunk gives RGB and
///    palette images an alpha channel); 16-bit and maxval != 255 samples are scaled to 8 bits
///    first. Other formats are refused.
///  - shade = mean of the colour channels / 255 (in trinary mode alpha joins the mean);
///    occ = negate ? shade : 1 - shade. trinary: occ > occupied_thresh -> 100,
///    occ < free_thresh -> 0, else -1. scale: a not fully opaque pixel -> -1, then as trinary
///    but in between -> rint(100 * (occ - free) / (occupied - free)). raw: round(255 * shade)
///    if in 0..100, else -1 (negate ignored, as in nav2).
/// Throws std::runtime_error naming the file (and line / field where known) on any problem:
/// unreadable or non-regular file, YAML syntax ("map.yaml:3: yaml parse error: ..."), a missing
/// or invalid field ("map.yaml: field 'resolution' missing"), an unreadable, truncated or
/// malformed image, or one over kMaxMapImagePixels. Hostile input never crashes it.
OccupancyImage load_ros_map(const std::string& yaml_path);

/// load_ros_map over files already in memory, never touching the filesystem: `yaml_text` is the
/// YAML document and `image_bytes` the contents of the image file it names (its `image` field
/// is still required and validated, and names the image in messages). `yaml_name` stands for
/// the YAML file in messages. Same checks, limits and errors as load_ros_map (a YAML text over
/// 1 MiB or an image over 512 MiB is refused).
OccupancyImage parse_ros_map(std::string_view yaml_text, std::string_view image_bytes,
                             const std::string& yaml_name = "map.yaml");

}  // namespace esfleet
