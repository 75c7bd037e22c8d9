#pragma once
// Map files: the ROS map_server format (a PGM image plus a YAML file), a colour PNG of the map
// with a trajectory drawn over it, and the atomic file write they (and stats.json) use.
//
// ROS map_server / nav2_map_server read a grey level x (0..255, negate 0) as the occupancy
// p = 1 - x / 255: occupied if p > occupied_thresh, free if p < free_thresh, else unknown
// (mode trinary). save_ros_map picks, for each cell, a grey level that reads back in the class
// the counters give it, so a saved map loads in map_server with the same free / occupied /
// unknown cells (see save_ros_map for the exact levels).
//
// Image layout (PGM and PNG alike): the crop is exactly GridMap::known_bounds(), no margin,
// one pixel per cell; pixel column c is cell x = min.x + c and pixel row r (row 0 = the top of
// the file) is cell y = max.y - r, so north (+y) is up. The YAML origin is the world position
// of the lower-left corner of the bottom-left pixel: (min.x * cell_size, min.y * cell_size).

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "esfleet/core/geometry.hpp"
#include "esfleet/core/grid_map.hpp"

namespace esfleet {

/// Largest image (width * height) that load_ros_map reads and save_ros_map / save_map_png write.
inline constexpr std::uint64_t kMaxMapImagePixels = 100'000'000;

/// Occupancy thresholds on p = hit / (hit + err), written to the YAML as map_server's
/// occupied_thresh / free_thresh. Need 0 < free < occupied < 1.
struct OccupancyThresholds {
  double occupied = 0.65;  ///< p >= occupied is an occupied cell (ROS occupied_thresh)
  double free = 0.196;     ///< p <= free is a free cell (ROS free_thresh)
};

/// Writes <dir>/<name>.pgm (binary P5, maxval 255) and <dir>/<name>.yaml in ROS map_server
/// format (mode trinary, negate 0, origin [x, y, 0.0], the thresholds of `th`), creating `dir`
/// if missing. Each file is written atomically (write_file_atomically), the PGM first; the pair
/// as a whole is not.
///
/// Grey levels, with the default thresholds in brackets:
///  - unknown cell (hit + err == 0): the level closest to 205 that map_server reads as unknown
///    [205];
///  - p >= th.occupied: 0 (black);
///  - p <= th.free: 254 (white), or 255 if the free threshold is below 1/255;
///  - in between: round(255 * (1 - p)), clamped into the levels map_server reads as unknown
///    [90, 205] and kept off the unknown level when another level is left [so 205 -> 204].
/// Levels are chosen with a 1e-9 margin on the thresholds, so the classes survive the small
/// rounding differences between map_server implementations.
///
/// An empty map writes a 1x1 unknown image at origin (0, 0). `name` must be non-empty and use
/// only [A-Za-z0-9._-] (it is written unquoted into the YAML). Throws std::invalid_argument
/// for a bad name or thresholds (not 0 < free < occupied < 1, or no grey level between them),
/// std::runtime_error naming the path on an I/O failure or when the image would exceed
/// kMaxMapImagePixels (load_ros_map would refuse it).
void save_ros_map(const GridMap& map, const std::string& dir, const std::string& name = "map",
                  const OccupancyThresholds& th = {});

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
///    (OpenCV, grey / grey+alpha / RGB / RGBA, 8 or 16 bit); 16-bit and maxval != 255 samples
///    are scaled to 8 bits first. Other formats are refused.
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

/// Writes a colour PNG of the map to `path` (atomically), same crop and pixel layout as
/// save_ros_map: known cells in their PGM grey level, unknown cells light blue-grey
/// (RGB u-15, u, u+15 for the unknown grey level u, so RGB 190,205,220 by default: the channel
/// mean is u and map_server still reads them as unknown). The trajectory is drawn over it as a
/// 1-pixel red (255,0,0) polyline through the pixels containing the poses, segments clipped to
/// the image and non-finite poses skipped; then a green (0,255,0) filled disc of radius 3 px at
/// the first pose and a blue (0,0,255) one at the last (discs only when the pose lies inside
/// the image). Throws as save_ros_map does (std::runtime_error naming the path on failure).
void save_map_png(const GridMap& map, const std::vector<TimedPose>& trajectory,
                  const std::string& path, const OccupancyThresholds& th = {});

/// Writes `contents` to `path` so that a reader sees the old file or the complete new one,
/// never a partial file: writes "<path>.tmp.<pid>.<n>" in the same directory (n counts calls
/// in this process), flushes and closes it, then renames it over `path`. No fsync: this
/// protects against crashes of the writer and concurrent readers, not against power loss.
/// The directory must exist. Throws std::runtime_error naming `path` on failure, after
/// removing the temporary file.
void write_file_atomically(const std::string& path, const std::string& contents);

}  // namespace esfleet
