// Writes the committed seeds of fuzz_tile, fuzz_map_loader and fuzz_slam from a real map: the
// scans of a CARMEN excerpt inserted at their odometry poses, and the scans themselves.
//  - fuzz_tile (layout: tile_records.hpp): every tile encoded by tile_codec the way the leader
//    sends it (tile_to_msg, tile_delta_to_msg, meta_to_msg), in each encoding;
//  - fuzz_map_loader (YAML, NUL, image): the map saved by save_ros_map (P5 PGM) at a coarse cell
//    size, the same as a P2 PGM with a comment, and as save_map_png's colour PNG, in each mode;
//  - fuzz_slam: the excerpt's first four scans with their odometry, laser only and with
//    odometry and the final pass, in the layout fuzz_slam.cpp reads with FuzzedDataProvider.
//
// usage: make_seeds LOG CORPUS_DIR    (fuzz/corpus holds its output for
//        tests/data/carmen/mit-csail-excerpt.clf; run from the fuzz build: bin/make_seeds)

#include <fuzzer/FuzzedDataProvider.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "esfleet/core/carmen_reader.hpp"
#include "esfleet/core/map_png.hpp"
#include "esfleet/core/map_update.hpp"
#include "esfleet/core/ros_map_writer.hpp"
#include "esfleet/core/scan_points.hpp"
#include "esfleet/dds/to_msg.hpp"
#include "esfleet/mapshare/tile_sender.hpp"
#include "tile_records.hpp"

namespace {

using esfleet::fuzz::RecordKind;
using esfleet::fuzz::RecordWriter;

void save(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!out) throw std::runtime_error("cannot write " + path);
  std::printf("%s: %zu bytes\n", path.c_str(), bytes.size());
}

void save(const std::string& path, const RecordWriter& w) {
  save(path, std::string(w.bytes().begin(), w.bytes().end()));
}

std::string slurp(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The P5 image `pgm` (header "P5\n<w> <h>\n255\n", as save_ros_map writes it) as P2 text.
std::string to_p2(const std::string& pgm) {
  std::istringstream in(pgm);
  std::string magic;
  int w = 0, h = 0, maxval = 0;
  in >> magic >> w >> h >> maxval;
  in.get();
  std::string out = "P2\n# ascii copy\n" + std::to_string(w) + " " + std::to_string(h) + "\n255\n";
  for (int i = 0; i < w * h; ++i) {
    out += std::to_string(static_cast<unsigned char>(in.get()));
    out += (i + 1) % w == 0 ? '\n' : ' ';
  }
  return out;
}

/// fuzz_map_loader seeds: the map at 0.5 m per cell (small images) in every image format.
void map_loader_seeds(const std::vector<esfleet::LaserScan>& scans, const std::string& dir) {
  esfleet::GridMapConfig config;
  config.cell_size = 0.5;
  esfleet::GridMap map(config);
  for (const esfleet::LaserScan& s : scans) {
    esfleet::update_map(map, esfleet::prepare_scan(s), *s.odometry);
  }
  const auto tmp = std::filesystem::temp_directory_path() / "esfleet-make-seeds";
  std::filesystem::create_directories(tmp);
  esfleet::save_ros_map(map, tmp.string(), "map");
  esfleet::save_map_png(map, {}, (tmp / "map.png").string());
  const std::string yaml = slurp(tmp / "map.yaml");
  const std::string pgm = slurp(tmp / "map.pgm");
  const std::string png = slurp(tmp / "map.png");
  std::filesystem::remove_all(tmp);
  const auto edit = [](std::string text, const std::string& from, const std::string& to) {
    text.replace(text.find(from), from.size(), to);
    return text;
  };
  const std::string nul(1, '\0');
  const std::string png_yaml = edit(yaml, "map.pgm", "map.png");
  save(dir + "/pgm-p5", yaml + nul + pgm);
  save(dir + "/pgm-p2-scale", edit(yaml, "mode: trinary", "mode: scale") + nul + to_p2(pgm));
  save(dir + "/png-rgb-raw", edit(png_yaml, "mode: trinary", "mode: raw") + nul + png);
  save(dir + "/png-rgb-negate", edit(png_yaml, "negate: 0", "negate: 1") + nul + png);
}

/// Writes what FuzzedDataProvider reads back: its integers come from the end of the input, the
/// first one read from the last bytes, most significant byte first; its floating-point values are
/// a probability (an integer over its maximum) scaled into the range. Every value put is read back
/// by a FuzzedDataProvider at the end (check()), so the seed means what it says.
class ProviderWriter {
 public:
  template <class T>
  void integral(T value, T min, T max) {
    const std::uint64_t range = static_cast<std::uint64_t>(max) - static_cast<std::uint64_t>(min);
    const std::uint64_t v = static_cast<std::uint64_t>(value) - static_cast<std::uint64_t>(min);
    std::size_t n = 0;
    while (n < sizeof(T) && (range >> (8 * n)) > 0) ++n;
    for (std::size_t k = 0; k < n; ++k)
      read_order_.push_back(static_cast<std::uint8_t>(v >> (8 * (n - 1 - k))));
    checks_.push_back(
        [=](FuzzedDataProvider& in) { return in.ConsumeIntegralInRange<T>(min, max) == value; });
  }
  template <class T>
  void integral(T value) {
    integral<T>(value, std::numeric_limits<T>::min(), std::numeric_limits<T>::max());
  }
  void boolean(bool b) {
    integral<std::uint8_t>(b ? 1 : 0);
    checks_.back() = [=](FuzzedDataProvider& in) { return in.ConsumeBool() == b; };
  }
  /// `value` in [min, max] (a range that does not overflow T).
  template <class T>
  void floating(T value, T min, T max) {
    using U = std::conditional_t<sizeof(T) <= 4, std::uint32_t, std::uint64_t>;
    const long double p =
        (static_cast<long double>(value) - min) / (static_cast<long double>(max) - min);
    integral<U>(
        static_cast<U>(std::llroundl(p * static_cast<long double>(std::numeric_limits<U>::max()))));
    checks_.back() = [=](FuzzedDataProvider& in) {
      const T got = in.ConsumeFloatingPointInRange<T>(min, max);
      return std::abs(static_cast<double>(got) - static_cast<double>(value)) <=
             1e-5 * (static_cast<double>(max) - min);
    };
  }
  /// The input, after checking that FuzzedDataProvider reads every value back.
  std::string bytes() const {
    const std::string out(read_order_.rbegin(), read_order_.rend());
    FuzzedDataProvider in(reinterpret_cast<const std::uint8_t*>(out.data()), out.size());
    for (std::size_t i = 0; i < checks_.size(); ++i) {
      if (!checks_[i](in))
        throw std::runtime_error("fuzz_slam seed: value " + std::to_string(i) +
                                 " reads back differently");
    }
    return out;
  }

 private:
  std::vector<std::uint8_t> read_order_;
  std::vector<std::function<bool(FuzzedDataProvider&)>> checks_;
};

/// fuzz_slam seeds (its layout: fuzz_slam.cpp): the first four scans as LaserScan messages with
/// their odometry, laser only, and with odometry and the final pass.
void slam_seeds(const std::vector<esfleet::LaserScan>& scans, const std::string& dir) {
  const std::size_t count = std::min<std::size_t>(4, scans.size());
  for (const std::uint8_t switches : {std::uint8_t{0}, std::uint8_t{1 | 8}}) {
    ProviderWriter w;
    w.integral<std::uint8_t>(switches);
    w.integral<int>(static_cast<int>(count), 1, 4);
    for (std::size_t i = 0; i < count; ++i) {
      const esfleet::LaserScan& s = scans[i];
      w.integral<std::uint16_t>(static_cast<std::uint16_t>(s.ranges.size()), 2, 720);
      w.floating<float>(s.angle_min, -7.0f, 7.0f);
      w.floating<float>(s.angle_increment, -1.1f, 1.1f);
      w.floating<float>(0.0f, 0.0f, 5.0f);  // range_min
      w.boolean(true);
      w.floating<float>(s.max_range, 0.0f, 2000.0f);
      w.integral<int>(0, 0, 2);  // readings in centimetres
      for (const float r : s.ranges) {
        w.integral<std::uint16_t>(
            static_cast<std::uint16_t>(std::lround(std::min(r, 655.0f) * 100.0f)));
      }
      const esfleet::Pose2 odom = s.odometry->relative_to(*scans.front().odometry);
      w.boolean(false);  // not wild
      w.floating<double>(odom.x, -50.0, 50.0);
      w.floating<double>(odom.y, -50.0, 50.0);
      w.floating<double>(odom.theta, -4.0, 4.0);
    }
    save(dir + "/csail-4-scans-" + std::to_string(switches), w.bytes());
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: make_seeds LOG CORPUS_DIR\n");
    return 2;
  }
  const std::vector<esfleet::LaserScan> scans = esfleet::read_carmen_log(argv[1]);
  map_loader_seeds(scans, std::string(argv[2]) + "/fuzz_map_loader");
  slam_seeds(scans, std::string(argv[2]) + "/fuzz_slam");
  const std::string dir = std::string(argv[2]) + "/fuzz_tile";
  esfleet::GridMap map;
  const esfleet::mapshare::MapIdentity id{"fuzz", 1};
  // The first scan, a copy of its tiles (the bases of deltas), then the rest.
  esfleet::update_map(map, esfleet::prepare_scan(scans.front()), *scans.front().odometry);
  std::vector<esfleet::Tile> first;
  for (const esfleet::TileKey k : map.tile_keys()) first.push_back(*map.find_tile(k));
  for (std::size_t i = 1; i < scans.size(); ++i) {
    esfleet::update_map(map, esfleet::prepare_scan(scans[i]), *scans[i].odometry);
  }
  // A tile the later scans changed.
  const esfleet::Tile* changed = nullptr;
  for (const esfleet::Tile& t : first) {
    if (map.find_tile(t.key)->version > t.version) changed = &t;
  }
  if (changed == nullptr) throw std::runtime_error("no tile changed after the first scan");
  const esfleet::Tile& base = *changed;
  const esfleet::TileKey delta_key = base.key;
  const auto scan_count = static_cast<std::uint32_t>(scans.size());
  const esfleet::TileEncoding encodings[] = {esfleet::TileEncoding::kMedZlib,
                                             esfleet::TileEncoding::kVarintZlib,
                                             esfleet::TileEncoding::kRaw};
  for (const esfleet::TileEncoding enc : encodings) {
    const std::string name = std::to_string(static_cast<int>(enc));
    // What the leader's sender makes of the whole map (every tile whole, the summary).
    esfleet::mapshare::TileSender sender(id, enc);
    sender.republish_all(map);
    esfleet::mapshare::Publication all = sender.publish(map, 0.0, true, false, scan_count, "{}", 0);
    // The whole map as a follower receives it: summary, every tile.
    RecordWriter w;
    w.put(std::uint8_t{0});
    w.put(static_cast<std::uint8_t>(RecordKind::kMeta));
    esfleet::fuzz::write_meta(w, esfleet::dds::meta_to_msg(all.meta));
    // Raw tiles are 32 kB each: one is enough (fuzz/run.sh caps inputs at 70 kB).
    if (enc == esfleet::TileEncoding::kRaw) all.tiles.resize(1);
    for (esfleet::mapshare::TileMessage& t : all.tiles) {
      w.put(static_cast<std::uint8_t>(RecordKind::kTile));
      esfleet::fuzz::write_tile_fields(w, esfleet::dds::tile_to_msg(std::move(t)), nullptr);
    }
    save(dir + "/map-enc" + name, w);
    // The base tile, then its delta to the final version, as the sender makes them.
    esfleet::GridMap one;
    one.set_tile(delta_key, base.version, base.hit, base.err);
    esfleet::mapshare::TileSender chain(id, enc);
    chain.republish_all(one);
    esfleet::mapshare::Publication first_pub = chain.publish(one, 0.0, false, false, 1, "{}", 0);
    map.mark_all_dirty();
    esfleet::mapshare::Publication later = chain.publish(map, 1.0, false, false, 2, "{}", 0);
    RecordWriter d;
    d.put(std::uint8_t{1});
    d.put(static_cast<std::uint8_t>(RecordKind::kTile));
    esfleet::fuzz::write_tile_fields(d, esfleet::dds::tile_to_msg(std::move(first_pub.tiles.at(0))),
                                     nullptr);
    for (esfleet::mapshare::TileMessage& t : later.tiles) {
      if (!t.is_delta()) continue;
      const std::uint64_t base_version = *t.base_version;
      d.put(static_cast<std::uint8_t>(RecordKind::kDelta));
      esfleet::fuzz::write_tile_fields(d, esfleet::dds::delta_to_msg(std::move(t)), &base_version);
    }
    save(dir + "/delta-enc" + name, d);
    // The changed tile at its final version, raw (32 kB: 32 parts of 1 kB, protocol 2), in parts
    // as the leader sends it.
    if (enc == esfleet::TileEncoding::kRaw) {
      RecordWriter p;
      p.put(std::uint8_t{0});
      esfleet::GridMap whole;
      const esfleet::Tile& last = *map.find_tile(delta_key);
      whole.set_tile(delta_key, last.version, last.hit, last.err);
      esfleet::mapshare::TileSender parts_sender(id, enc);
      parts_sender.republish_all(whole);
      for (esfleet::mapshare::TileMessage& t :
           parts_sender.publish(whole, 0.0, true, false, 1, "{}", 0).tiles) {
        for (const auto& part : esfleet::dds::tile_to_msgs(std::move(t))) {
          p.put(static_cast<std::uint8_t>(RecordKind::kPart));
          esfleet::fuzz::write_part_record(p, part, nullptr, 0);
        }
      }
      save(dir + "/parts-enc" + name, p);
    }
    // The bare decoder on one tile (the changed one, at its final version).
    esfleet::GridMap only;
    const esfleet::Tile& final_tile = *map.find_tile(delta_key);
    only.set_tile(delta_key, final_tile.version, final_tile.hit, final_tile.err);
    esfleet::mapshare::TileSender single(id, enc);
    single.republish_all(only);
    const esfleet::mapshare::TileMessage t =
        single.publish(only, 0.0, true, false, 1, "{}", 0).tiles.at(0);
    RecordWriter c;
    c.put(std::uint8_t{0});
    c.put(static_cast<std::uint8_t>(RecordKind::kDecode));
    c.put(t.encoding);
    c.put(t.cells);
    c.put_payload(t.payload);
    save(dir + "/decode-enc" + name, c);
  }
  return 0;
}
