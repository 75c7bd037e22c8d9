#include "esfleet/core/slam_snapshot.hpp"

#include <bit>
#include <cstring>
#include <functional>
#include <memory>
#include <type_traits>
#include <utility>
#include <vector>

#include "esfleet/core/tile_codec.hpp"
#include "fnv1a.hpp"

namespace esfleet {

static_assert(std::endian::native == std::endian::little, "snapshots assume little-endian");

namespace {

constexpr std::string_view kMapMagic = "ESFMAP01";
constexpr std::string_view kSlamMagic = "ESFSLAM1";

/// The bytes of a blob, then their FNV-1a. Without a sink they collect in memory and finish()
/// returns them; with one they go to it in pieces of about kPiece bytes, in order (the sink
/// sees the same bytes, finish() returns nothing).
class Out {
 public:
  using Sink = std::function<void(std::string_view)>;
  explicit Out(std::string_view magic, Sink sink = {}) : sink_(std::move(sink)) { append(magic); }
  template <class T>
  void put(T v) {
    static_assert(std::is_trivially_copyable_v<T>);
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    append({b, sizeof(T)});
  }
  void put(const Pose2& p) {
    put(p.x);
    put(p.y);
    put(p.theta);
  }
  void put(const std::optional<Pose2>& p) {
    put<std::uint8_t>(p ? 1 : 0);
    if (p) put(*p);
  }
  void put(const std::vector<float>& v) {
    put<std::uint64_t>(v.size());
    append({reinterpret_cast<const char*>(v.data()), v.size() * sizeof(float)});
  }
  void put_bytes(const std::vector<std::uint8_t>& v) {
    put<std::uint64_t>(v.size());
    append({reinterpret_cast<const char*>(v.data()), v.size()});
  }
  void reserve(std::size_t n) { bytes_.reserve(sink_ ? kPiece + 64 : n); }
  std::string finish() {
    hash_.add(bytes_);
    const std::uint64_t checksum = hash_.value();
    char b[sizeof checksum];
    std::memcpy(b, &checksum, sizeof checksum);
    bytes_.append(b, sizeof checksum);
    if (!sink_) return std::move(bytes_);
    sink_(bytes_);
    bytes_.clear();
    return {};
  }

 private:
  static constexpr std::size_t kPiece = 1 << 16;

  void append(std::string_view b) {
    bytes_.append(b);
    if (sink_ && bytes_.size() >= kPiece) {
      hash_.add(bytes_);
      sink_(bytes_);
      bytes_.clear();
    }
  }

  Sink sink_;
  std::string bytes_;  ///< not yet hashed (with a sink: not yet handed over)
  detail::Fnv1a hash_;
};

class In {
 public:
  In(std::string_view bytes, std::string_view magic, const char* what) : what_(what) {
    if (bytes.size() < magic.size() + 8) fail("file", "shorter than magic and checksum");
    if (bytes.substr(0, magic.size()) != magic)
      fail("magic", "not a " + std::string(what) + " snapshot");
    std::uint64_t stored = 0;
    std::memcpy(&stored, bytes.data() + bytes.size() - 8, 8);
    if (stored != detail::fnv1a(bytes.substr(0, bytes.size() - 8))) {
      fail("checksum", "does not match the contents (corrupt or truncated)");
    }
    rest_ = bytes.substr(magic.size(), bytes.size() - magic.size() - 8);
  }
  [[noreturn]] void fail(const std::string& field, const std::string& why) const {
    throw SnapshotError(std::string(what_) + " snapshot: " + field + ": " + why);
  }
  template <class T>
  T get(const std::string& field) {
    T v;
    take(&v, sizeof(T), field);
    return v;
  }
  Pose2 pose(const std::string& field) {
    Pose2 p;
    p.x = get<double>(field + ".x");
    p.y = get<double>(field + ".y");
    p.theta = get<double>(field + ".theta");
    return p;
  }
  std::optional<Pose2> opt_pose(const std::string& field) {
    const auto has = get<std::uint8_t>(field);
    if (has > 1) fail(field, "bad presence flag");
    if (has == 0) return std::nullopt;
    return pose(field);
  }
  /// A count of items of at least `item_bytes` each: checked against the bytes left.
  std::size_t count(const std::string& field, std::size_t item_bytes) {
    const auto n = get<std::uint64_t>(field);
    if (item_bytes > 0 && n > rest_.size() / item_bytes) fail(field, "count larger than the file");
    return static_cast<std::size_t>(n);
  }
  std::vector<float> floats(const std::string& field) {
    std::vector<float> v(count(field, sizeof(float)));
    take(v.data(), v.size() * sizeof(float), field);
    return v;
  }
  std::vector<std::uint8_t> bytes(const std::string& field) {
    std::vector<std::uint8_t> v(count(field, 1));
    take(v.data(), v.size(), field);
    return v;
  }
  bool at_end() const { return rest_.empty(); }
  void done() const {
    if (!rest_.empty()) fail("end", std::to_string(rest_.size()) + " trailing bytes");
  }

 private:
  void take(void* dst, std::size_t n, const std::string& field) {
    if (rest_.size() < n) fail(field, "truncated");
    if (n > 0) std::memcpy(dst, rest_.data(), n);
    rest_.remove_prefix(n);
  }
  const char* what_;
  std::string_view rest_;
};

}  // namespace

std::string encode_map_snapshot(const GridMap& map) {
  const std::vector<TileKey> keys = map.tile_keys();
  std::vector<EncodedTile> encoded;
  std::vector<SnapshotTile> tiles;
  encoded.reserve(keys.size());
  tiles.reserve(keys.size());
  for (const TileKey k : keys) {
    const Tile& t = *map.find_tile(k);
    encoded.push_back(encode_tile(t.hit, t.err, TileEncoding::kMedZlib));
    tiles.push_back({k, t.version, &encoded.back()});
  }
  return encode_map_snapshot(map.cell_size(), map.tile_edge(), tiles);
}

std::string encode_map_snapshot(double cell_size, int tile_edge,
                                const std::vector<SnapshotTile>& tiles) {
  Out out(kMapMagic);
  out.put(cell_size);
  out.put<std::uint32_t>(static_cast<std::uint32_t>(tile_edge));
  out.put<std::uint64_t>(tiles.size());
  for (const SnapshotTile& t : tiles) {
    out.put(t.key.tx);
    out.put(t.key.ty);
    out.put(t.version);
    out.put(static_cast<std::uint8_t>(t.encoded->encoding));
    out.put_bytes(t.encoded->payload);
  }
  return out.finish();
}

void decode_map_snapshot(std::string_view bytes, GridMap& map) {
  In in(bytes, kMapMagic, "map");
  const auto cell_size = in.get<double>("cell_size");
  if (cell_size != map.cell_size()) {
    in.fail("cell_size", std::to_string(cell_size) + " but the map has " +
                             std::to_string(map.cell_size()) + " (--cell-size differs)");
  }
  const auto edge = in.get<std::uint32_t>("tile_edge");
  if (edge != static_cast<std::uint32_t>(map.tile_edge())) {
    in.fail("tile_edge",
            std::to_string(edge) + " but the map has " + std::to_string(map.tile_edge()));
  }
  const std::size_t n = in.count("tiles", 8 + 8 + 1 + 8);
  std::vector<std::uint32_t> hit, err;
  for (std::size_t i = 0; i < n; ++i) {
    const std::string f = "tiles[" + std::to_string(i) + "]";
    TileKey k;
    k.tx = in.get<std::int32_t>(f + ".tx");
    k.ty = in.get<std::int32_t>(f + ".ty");
    const auto version = in.get<std::uint64_t>(f + ".version");
    const auto enc = static_cast<TileEncoding>(in.get<std::uint8_t>(f + ".encoding"));
    const std::vector<std::uint8_t> payload = in.bytes(f + ".payload");
    try {
      decode_tile(enc, payload, map.cells_per_tile(), hit, err);
      map.set_tile(k, version, hit, err);
    } catch (const std::exception& e) {
      in.fail(f, e.what());
    }
  }
  in.done();
}

namespace {

/// Open the trailing sections (never a key index): contributed key scans; "the last pose was a
/// recovery jump" (the tag alone).
constexpr std::uint64_t kContributorsTag = 0xC0417B1D00000001ULL;
constexpr std::uint64_t kLastJumpedTag = 0xC0417B1D00000002ULL;

void put_slam_state(const SlamState& s, Out& out) {
  // Sized up front: growing by doubling would hold up to three times the key scans' bytes.
  std::size_t size = 256 + 32 * s.trajectory.size() + 24 * s.graph_nodes.size() +
                     64 * s.graph_edges.size() + 32 * s.anchors.size();
  for (const KeyScan& k : s.keys) {
    size += 96 + 4 * (3 * k.points->size() + k.points->no_return_angles.size());
  }
  out.reserve(size);
  for (const std::uint64_t w : s.rng.s) out.put(w);
  out.put(s.rng.spare);
  out.put<std::uint8_t>(s.rng.has_spare ? 1 : 0);
  out.put<std::uint64_t>(s.trajectory.size());
  for (const TimedPose& p : s.trajectory) {
    out.put(p.stamp);
    out.put(p.pose);
  }
  out.put(s.last_odometry);
  out.put(s.last_inserted);
  out.put(s.path_length);
  out.put<std::uint64_t>(s.keys.size());
  for (const KeyScan& k : s.keys) {
    out.put(k.stamp);
    out.put(k.mapped_pose);
    out.put(k.path_length);
    out.put(k.points->x);
    out.put(k.points->y);
    out.put(k.points->range);
    out.put(k.points->no_return_angles);
  }
  out.put<std::uint64_t>(s.graph_nodes.size());
  for (const Pose2& p : s.graph_nodes) out.put(p);
  out.put<std::uint64_t>(s.graph_edges.size());
  for (const PoseGraphEdge& e : s.graph_edges) {
    out.put<std::uint64_t>(e.from);
    out.put<std::uint64_t>(e.to);
    out.put(e.measurement);
    out.put(e.info_xy);
    out.put(e.info_theta);
    out.put(e.huber);
  }
  out.put<std::uint64_t>(s.anchors.size());
  for (const auto& [k, rel] : s.anchors) {
    out.put<std::uint64_t>(k);
    out.put(rel);
  }
  out.put<std::uint64_t>(s.loop_closures);
  out.put<std::uint64_t>(s.loop_rejected);
  out.put<std::uint8_t>(s.last_loop ? 1 : 0);
  if (s.last_loop) {
    out.put<std::uint64_t>(s.last_loop->key);
    out.put<std::uint64_t>(s.last_loop->anchor);
    out.put(s.last_loop->correction);
    out.put(s.last_loop->agreement);
    out.put(s.last_loop->ambiguity);
  }
  // Appended only when present, so that a state without one has the layout of before.
  if (s.pending_loop_key) out.put<std::uint64_t>(*s.pending_loop_key);
  if (!s.contributors.empty()) {
    out.put<std::uint64_t>(kContributorsTag);
    out.put<std::uint64_t>(s.contributors.size());
    for (const std::string& name : s.contributors) {
      out.put_bytes(std::vector<std::uint8_t>(name.begin(), name.end()));
    }
    for (const KeyScan& k : s.keys) out.put(k.contributor);
  }
  if (s.last_jumped) out.put<std::uint64_t>(kLastJumpedTag);
}

}  // namespace

std::string encode_slam_state(const SlamState& s) {
  Out out(kSlamMagic);
  put_slam_state(s, out);
  return out.finish();
}

std::uint64_t write_slam_state(const SlamState& s,
                               const std::function<void(std::string_view)>& sink) {
  std::uint64_t bytes = 0;
  Out out(kSlamMagic, [&](std::string_view piece) {
    bytes += piece.size();
    sink(piece);
  });
  put_slam_state(s, out);
  out.finish();
  return bytes;
}

SlamState decode_slam_state(std::string_view bytes) {
  In in(bytes, kSlamMagic, "slam");
  SlamState s;
  for (std::size_t i = 0; i < 4; ++i) s.rng.s[i] = in.get<std::uint64_t>("rng.s");
  s.rng.spare = in.get<double>("rng.spare");
  s.rng.has_spare = in.get<std::uint8_t>("rng.has_spare") != 0;
  s.trajectory.resize(in.count("trajectory", 32));
  for (std::size_t i = 0; i < s.trajectory.size(); ++i) {
    const std::string f = "trajectory[" + std::to_string(i) + "]";
    s.trajectory[i].stamp = in.get<double>(f + ".stamp");
    s.trajectory[i].pose = in.pose(f);
  }
  s.last_odometry = in.opt_pose("last_odometry");
  s.last_inserted = in.opt_pose("last_inserted");
  s.path_length = in.get<double>("path_length");
  s.keys.resize(in.count("keys", 40 + 32));
  for (std::size_t i = 0; i < s.keys.size(); ++i) {
    const std::string f = "keys[" + std::to_string(i) + "]";
    KeyScan& k = s.keys[i];
    k.stamp = in.get<double>(f + ".stamp");
    k.mapped_pose = in.pose(f + ".mapped_pose");
    k.path_length = in.get<double>(f + ".path_length");
    ScanPoints points;
    points.x = in.floats(f + ".points.x");
    points.y = in.floats(f + ".points.y");
    points.range = in.floats(f + ".points.range");
    points.no_return_angles = in.floats(f + ".points.no_return_angles");
    if (points.y.size() != points.x.size() || points.range.size() != points.x.size()) {
      in.fail(f + ".points", "x, y and range differ in length");
    }
    k.points = std::make_shared<const ScanPoints>(std::move(points));
  }
  s.graph_nodes.resize(in.count("graph_nodes", 24));
  for (std::size_t i = 0; i < s.graph_nodes.size(); ++i) {
    s.graph_nodes[i] = in.pose("graph_nodes[" + std::to_string(i) + "]");
  }
  s.graph_edges.resize(in.count("graph_edges", 64));
  for (std::size_t i = 0; i < s.graph_edges.size(); ++i) {
    const std::string f = "graph_edges[" + std::to_string(i) + "]";
    PoseGraphEdge& e = s.graph_edges[i];
    e.from = static_cast<std::size_t>(in.get<std::uint64_t>(f + ".from"));
    e.to = static_cast<std::size_t>(in.get<std::uint64_t>(f + ".to"));
    e.measurement = in.pose(f + ".measurement");
    e.info_xy = in.get<double>(f + ".info_xy");
    e.info_theta = in.get<double>(f + ".info_theta");
    e.huber = in.get<double>(f + ".huber");
  }
  s.anchors.resize(in.count("anchors", 32));
  for (std::size_t i = 0; i < s.anchors.size(); ++i) {
    const std::string f = "anchors[" + std::to_string(i) + "]";
    s.anchors[i].first = static_cast<std::size_t>(in.get<std::uint64_t>(f + ".key"));
    s.anchors[i].second = in.pose(f + ".relative");
  }
  s.loop_closures = static_cast<std::size_t>(in.get<std::uint64_t>("loop_closures"));
  s.loop_rejected = static_cast<std::size_t>(in.get<std::uint64_t>("loop_rejected"));
  if (in.get<std::uint8_t>("last_loop") != 0) {
    LoopEvent e;
    e.key = static_cast<std::size_t>(in.get<std::uint64_t>("last_loop.key"));
    e.anchor = static_cast<std::size_t>(in.get<std::uint64_t>("last_loop.anchor"));
    e.correction = in.pose("last_loop.correction");
    e.agreement = in.get<float>("last_loop.agreement");
    e.ambiguity = in.get<double>("last_loop.ambiguity");
    s.last_loop = e;
  }
  // What follows the fixed part: each read is a section's tag (or the untagged pending key).
  auto read = [&in](const char* field) {
    return in.at_end() ? std::optional<std::uint64_t>() : in.get<std::uint64_t>(field);
  };
  std::optional<std::uint64_t> next = read("pending_loop_key");
  if (next && *next != kContributorsTag && *next != kLastJumpedTag) {
    s.pending_loop_key = static_cast<std::size_t>(*next);
    next = read("section.tag");
  }
  if (next && *next == kContributorsTag) {
    s.contributors.resize(in.count("contributors", 8));
    for (std::size_t i = 0; i < s.contributors.size(); ++i) {
      const std::vector<std::uint8_t> name = in.bytes("contributors[" + std::to_string(i) + "]");
      s.contributors[i].assign(name.begin(), name.end());
    }
    for (std::size_t i = 0; i < s.keys.size(); ++i) {
      s.keys[i].contributor = in.get<std::uint32_t>("keys[" + std::to_string(i) + "].contributor");
    }
    next = read("section.tag");
  }
  if (next && *next == kLastJumpedTag) {
    s.last_jumped = true;
    next = read("section.tag");
  }
  if (next) in.fail("section.tag", "unknown section");
  in.done();
  return s;
}

}  // namespace esfleet
