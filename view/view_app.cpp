#include "view_app.hpp"

#include <spdlog/spdlog.h>
#include <stdlib.h>

#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <thread>

#include "app/program.hpp"
#include "app/summary.hpp"
#include "esfleet/core/clock.hpp"
#include "esfleet/core/map_png.hpp"
#include "esfleet/core/ros_map_writer.hpp"
#include "foxglove.hpp"
#include "send_queue.hpp"
#include "status_table.hpp"
#include "tile_frame.hpp"

namespace esfleet::view {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

static_assert(fleet::kStatusMapping == msg::kStatusMapping);
static_assert(fleet::kStatusTracking == msg::kStatusTracking);
static_assert(fleet::kStatusLost == msg::kStatusLost);

/// Positions kept per robot for its trail, and the leader's path (the page draws them).
constexpr std::size_t kTrailPoints = 300;
constexpr std::size_t kLeaderPathPoints = 20000;
/// A new trail point only when the robot moved this far (metres).
constexpr double kTrailStep = 0.05;

json optional_number(const std::optional<double>& v) { return v ? json(*v) : json(nullptr); }

double round3(double v) { return std::round(v * 1000.0) / 1000.0; }

std::string read_whole(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  if (!in) throw std::runtime_error("cannot read " + p.string());
  return s.str();
}

}  // namespace

ViewApp::ViewApp(ViewOptions options, const std::atomic<bool>& stop)
    : o_(std::move(options)), stop_(stop), watch_(o_.leader_timeout) {
  app::setup_step("", [&] { o_.validate(); });
  start_ = Clock::now();
  std::signal(SIGPIPE, SIG_IGN);
  app::setup_step("DDS", [&] {
    node_ = std::make_unique<dds::Node>(
        dds::NodeOptions{o_.domain, o_.profile, "esfleet-view", o_.secure});
  });
  app::setup_step("DDS map readers", [&] {
    map_ = std::make_unique<follower::MapSubscriber>(*node_, o_.map_id);
    map_->record_applied();
  });
  app::setup_step("DDS pose and truth readers", [&] {
    poses_ = std::make_unique<dds::PoseReader>(
        *node_,
        [this](const msg::RobotPose& m, const dds::SampleMeta&) {
          std::lock_guard lock(mutex_);
          if (pose_queue_.size() < 100000) {  // bounded: a flood of poses cannot grow it
            pose_queue_.push_back(
                {{m.robot_id().to_string(), m.stamp(), m.x(), m.y(), m.theta(), m.status()},
                 m.fitness()});
          }
        },
        dds::kAllPartitions);
    truths_ = std::make_unique<dds::TruthReader>(
        *node_,
        [this](const msg::TruthPose& m, const dds::SampleMeta&) {
          std::lock_guard lock(mutex_);
          if (truth_queue_.size() < 100000) {
            truth_queue_.push_back({m.robot_id().to_string(), m.stamp(), m.x(), m.y(), m.theta()});
          }
        },
        dds::kAllPartitions);
  });
  app::setup_step(
      "web server (--bind " + o_.bind + " --port " + std::to_string(o_.port) + ")", [&] {
        server_ = std::make_unique<WebServer>(
            o_.bind, static_cast<std::uint16_t>(o_.port), o_.limits,
            [this](const std::string& name, std::function<void(HttpResponse)> done) {
              std::lock_guard lock(mutex_);
              if (downloads_.size() >= 16) {  // a flood of downloads waits for nobody
                done({503, "text/plain; charset=utf-8", "busy: too many downloads waiting\n", ""});
                return;
              }
              downloads_.push_back({name, std::move(done)});
            });
      });
  spdlog::info("serving the fleet's view on http://{}:{}/ (DDS domain {}, map '{}'){}", o_.bind,
               server_->port(), o_.domain, o_.map_id.empty() ? "(any)" : o_.map_id,
               o_.secure.empty() ? "" : "; DDS Security on");
  spdlog::info(
      "limits: {} connections, {} header bytes, {} message bytes, {} queued bytes per "
      "browser; robots every {} s",
      o_.limits.max_connections, o_.limits.header_limit, o_.limits.ws_message_max,
      o_.limits.client_queue_bytes, o_.robots_period);
}

ViewApp::~ViewApp() {
  server_.reset();
  truths_.reset();
  poses_.reset();
  map_.reset();
  node_.reset();
}

double ViewApp::now_s() const {
  return std::chrono::duration<double>(Clock::now() - start_).count();
}

int ViewApp::run() {
  double next_robots = 0.0, next_status = 0.0, next_trails = 0.0, next_foxglove = 0.0;
  while (!stop_) {
    map_->spin_once(std::chrono::milliseconds(20));
    const double now = now_s();
    forward_tiles();
    count_whole_map();
    drain_poses(now);
    const auto& meta = map_->replica().meta();
    watch_.update(now, map_->stats().meta_received, map_->matched_leaders(),
                  meta && !meta->complete);
    serve_downloads();
    if (now >= next_robots) {
      send_robots(now);
      const bool map_too = now >= next_foxglove;
      send_foxglove(map_too);
      if (map_too) next_foxglove = now + 1.0;
      next_robots = now + o_.robots_period;
    }
    if (now >= next_trails) {
      send_trails();
      next_trails = now + 2.0;
    }
    if (now >= next_status) {
      send_status(now);
      next_status = now + 0.5;
    }
    if (o_.timeout > 0 && now >= o_.timeout) {
      spdlog::info("--timeout {} s reached", o_.timeout);
      return app::kExitOk;
    }
  }
  spdlog::info("stopped: {} tiles forwarded ({} bytes), {} browsers seen", tiles_forwarded_,
               tile_bytes_forwarded_, server_->stats().accepted);
  return app::kExitInterrupted;
}

void ViewApp::forward_tiles() {
  std::vector<follower::MapSubscriber::AppliedTile> applied = map_->take_applied();
  const mapshare::MapReplica& replica = map_->replica();
  if (!replica.has_map()) return;
  const GridMap& map = replica.map();
  if (!map_shown_ || replica.epoch() != epoch_shown_) {
    map_shown_ = true;
    epoch_shown_ = replica.epoch();
    server_->reset_map(json{
        {"type", "map"},
        {"map_id", replica.map_id()},
        {"epoch", replica.epoch()},
        {"cell_size", map.cell_size()},
        {"tile_edge",
         map.tile_edge()}}.dump());
    leader_path_.clear();
    frame_bytes_.clear();
    spdlog::info("map '{}' epoch {}: shown", replica.map_id(), replica.epoch());
    // Whatever the replica already holds (tiles applied before this summary of the epoch).
    for (const TileKey& k : map.tile_keys()) applied.push_back({k, 0});
  }
  if (applied.empty()) return;
  // The newest stamp of each changed tile; the frame carries the tile as it is now.
  std::map<TileKey, std::uint64_t> changed;
  const auto now_ns = static_cast<std::uint64_t>(realtime_ns());
  for (const auto& a : applied) {
    if (a.stamp_ns > 0 && a.stamp_ns <= now_ns) {
      // Leader publish -> forwarded here: the last kLatencyKept tiles, for /stats.json.
      if (forward_latency_ms_.size() >= kLatencyKept) forward_latency_ms_.pop_front();
      forward_latency_ms_.push_back(static_cast<double>(now_ns - a.stamp_ns) / 1e6);
    }
    auto& stamp = changed[a.key];
    stamp = std::max(stamp, a.stamp_ns);
  }
  std::vector<std::pair<std::string, std::shared_ptr<const std::string>>> frames;
  frames.reserve(changed.size());
  for (const auto& [key, stamp] : changed) {
    const Tile* tile = map.find_tile(key);
    if (tile == nullptr) continue;  // of an older epoch
    TileFrameHeader h;
    h.epoch = replica.epoch();
    h.tx = key.tx;
    h.ty = key.ty;
    h.version = tile->version;
    h.stamp_ns = stamp;
    h.tile_edge = static_cast<std::uint32_t>(map.tile_edge());
    auto frame = std::make_shared<const std::string>(
        encode_tile_frame(h, tile_classes(*tile, map.tile_edge())));
    tile_bytes_forwarded_ += frame->size();
    frame_bytes_[key] = frame->size();
    frames.emplace_back(tile_key(key.tx, key.ty), std::move(frame));
  }
  tiles_forwarded_ += frames.size();
  server_->send_tiles(std::move(frames));
}

void ViewApp::count_whole_map() {
  // What sending the whole map instead would have cost, once per leader publish that changed
  // the map (a new map_version in its summary; publishes between two of our spins count once,
  // so this is a lower bound): every tile's newest frame, and a grid of one byte per cell over
  // the summary's tile bounds (as a nav_msgs/OccupancyGrid would).
  const auto& meta = map_->replica().meta();
  if (!meta || frame_bytes_.empty() || meta->map_version == version_counted_) return;
  version_counted_ = meta->map_version;
  ++publishes_seen_;
  for (const auto& [k, bytes] : frame_bytes_) whole_map_frame_bytes_ += bytes;
  whole_map_grid_bytes_ +=
      static_cast<std::uint64_t>(std::max(0, meta->max_tx - meta->min_tx + 1)) *
      static_cast<std::uint64_t>(std::max(0, meta->max_ty - meta->min_ty + 1)) *
      map_->replica().map().cells_per_tile();
}

void ViewApp::drain_poses(double now) {
  std::vector<std::pair<fleet::PoseSample, float>> poses;
  std::vector<fleet::TruthSample> truths;
  {
    std::lock_guard lock(mutex_);
    poses.swap(pose_queue_);
    truths.swap(truth_queue_);
  }
  for (const fleet::TruthSample& t : truths) monitor_.on_truth(t);
  for (const auto& [p, fitness] : poses) {
    if (p.robot_id.empty() || !std::isfinite(p.x) || !std::isfinite(p.y) ||
        !std::isfinite(p.theta)) {
      continue;
    }
    const bool leader = p.status == fleet::kStatusMapping;
    if (robots_.size() >= kMaxRobots && robots_.find(p.robot_id) == robots_.end()) {
      // A flood of new robot ids (a misbehaving or hostile peer) must not grow the view.
      if (!robots_full_logged_) {
        spdlog::warn("more than {} robot ids: poses of new ids are ignored", kMaxRobots);
        robots_full_logged_ = true;
      }
      continue;
    }
    auto [it, inserted] = robots_.try_emplace(p.robot_id);
    Robot& r = it->second;
    if (inserted && !leader) monitor_.add_robot(p.robot_id);
    r.pose = p;
    r.fitness = fitness;
    r.leader = r.leader || leader;
    r.last_s = now;
    monitor_.on_pose(p, now);
    auto& trail = r.trail;
    if (trail.empty() ||
        std::hypot(trail.back().first - p.x, trail.back().second - p.y) >= kTrailStep) {
      trail.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y));
      if (trail.size() > kTrailPoints) trail.pop_front();
    }
    if (leader) {
      if (leader_path_.size() >= kLeaderPathPoints) {
        leader_path_.erase(leader_path_.begin(), leader_path_.begin() + kLeaderPathPoints / 2);
      }
      leader_path_.push_back({p.stamp, Pose2{p.x, p.y, p.theta}});
    }
  }
}

void ViewApp::send_robots(double now) {
  json list = json::array();
  for (auto& [id, r] : robots_) {
    json j = {{"id", id},
              {"x", round3(r.pose.x)},
              {"y", round3(r.pose.y)},
              {"th", round3(r.pose.theta)},
              {"stamp", r.pose.stamp},
              {"status", fleet::status_name(r.pose.status)},
              {"fitness", round3(r.fitness)},
              {"leader", r.leader},
              {"age_s", round3(now - r.last_s)}};
    if (const auto it = monitor_.robots().find(id); it != monitor_.robots().end()) {
      const fleet::RobotReport& rep = it->second;
      j["localised_s"] = rep.localised_s && rep.first_pose_s
                             ? json(round3(*rep.localised_s - *rep.first_pose_s))
                             : json(nullptr);
      j["err_m"] = optional_number(rep.last_error_xy_m);
      j["med_m"] =
          rep.error_xy_m.empty() ? json(nullptr) : json(app::summarize(rep.error_xy_m).median);
      j["wrong"] = rep.wrong_declarations;
      // Poses per second, over windows of at least 2 s (the table's figure stays readable).
      if (now - r.rate_since_s >= 2.0) {
        r.rate = static_cast<double>(rep.poses - r.poses_at_rate) / (now - r.rate_since_s);
        r.poses_at_rate = rep.poses;
        r.rate_since_s = now;
      }
      j["poses_per_s"] = round3(r.rate);
    }
    list.push_back(std::move(j));
  }
  server_->send_state("robots", json{{"type", "robots"}, {"robots", list}}.dump(), true);
}

void ViewApp::send_trails() {
  json trails = json::object();
  for (const auto& [id, r] : robots_) {
    json pts = json::array();
    for (const auto& [x, y] : r.trail) pts.push_back({round3(x), round3(y)});
    trails[id] = std::move(pts);
  }
  json path = json::array();
  for (const TimedPose& p : leader_path_) path.push_back({round3(p.pose.x), round3(p.pose.y)});
  // For newcomers only: the browsers already connected extend their trails from "robots".
  server_->send_state(
      "trails", json{{"type", "trails"}, {"trails", trails}, {"leader_path", path}}.dump(), false);
}

void ViewApp::send_status(double now) {
  const mapshare::MapReplica& replica = map_->replica();
  const auto& meta = replica.meta();
  const follower::FollowStats& st = map_->stats();
  const ServerStats s = server_->stats();
  json status = {
      {"type", "status"},
      {"time_s", round3(now)},
      {"map_id", replica.map_id()},
      {"epoch", replica.epoch()},
      {"tiles", replica.has_map() ? replica.map().tile_count() : 0},
      {"scans", meta ? meta->scans : 0},
      {"complete", meta ? meta->complete : false},
      {"leader",
       {{"present", watch_.present()}, {"reason", watch_.reason()}, {"lost", watch_.lost()}}},
      {"dds",
       {{"bytes_received", st.bytes_received},
        {"tiles_applied", st.tiles_applied},
        {"deltas_applied", st.deltas_applied},
        {"rejected", st.tiles_rejected + st.deltas_rejected + st.meta_rejected}}},
      {"server",
       {{"clients", s.clients},
        {"connections", s.connections},
        {"refused", s.refused},
        {"dropped", s.dropped},
        {"coalesced", s.coalesced},
        {"bytes_sent", s.bytes_sent}}}};
  server_->send_state("status", status.dump(), true);
  json stats = status;
  stats["type"] = "stats";
  stats["server"] = {{"connections", s.connections}, {"clients", s.clients},
                     {"accepted", s.accepted},       {"refused", s.refused},
                     {"requests", s.requests},       {"bad_requests", s.bad_requests},
                     {"dropped", s.dropped},         {"ws_errors", s.ws_errors},
                     {"coalesced", s.coalesced},     {"bytes_sent", s.bytes_sent},
                     {"frames_sent", s.frames_sent}};
  stats["forwarded"] = {{"tiles", tiles_forwarded_},
                        {"bytes", tile_bytes_forwarded_},
                        {"leader_publishes", publishes_seen_},
                        {"whole_map_frame_bytes", whole_map_frame_bytes_},
                        {"whole_map_grid_bytes", whole_map_grid_bytes_}};
  if (!forward_latency_ms_.empty()) {
    const app::Summary l =
        app::summarize(std::vector<double>(forward_latency_ms_.begin(), forward_latency_ms_.end()));
    stats["forwarded"]["latency_ms"] = {
        {"median", l.median}, {"p99", l.p99}, {"max", l.max}, {"n", forward_latency_ms_.size()}};
  }
  server_->send_state("stats", stats.dump(), false);
}

void ViewApp::send_foxglove(bool map_too) {
  // Only while a Foxglove client listens. The robots every call; the whole map at most once a
  // second and only when it changed (Foxglove has no tiled map updates).
  const mapshare::MapReplica& replica = map_->replica();
  if (server_->stats().foxglove == 0) return;
  const std::int64_t now_ns = realtime_ns();
  const double now = static_cast<double>(now_ns) / 1e9;
  std::vector<PlanarPose> poses;
  poses.reserve(robots_.size());
  for (const auto& [id, r] : robots_) poses.push_back({r.pose.x, r.pose.y, r.pose.theta});
  server_->send_foxglove(kFoxgloveRobotsChannel, pose_array_cdr(poses, now),
                         static_cast<std::uint64_t>(now_ns));
  if (!map_too || !replica.has_map()) return;
  const std::pair<std::uint32_t, std::uint64_t> version{epoch_shown_, tiles_forwarded_};
  if (version == foxglove_version_) return;
  foxglove_version_ = version;
  server_->send_foxglove(kFoxgloveMapChannel, occupancy_grid_cdr(replica.map(), now),
                         static_cast<std::uint64_t>(now_ns));
}

void ViewApp::serve_downloads() {
  std::vector<DownloadRequest> requests;
  {
    std::lock_guard lock(mutex_);
    requests.swap(downloads_);
  }
  for (DownloadRequest& r : requests) {
    HttpResponse res;
    try {
      res = make_download(r.name);
    } catch (const std::exception& e) {
      spdlog::warn("download {}: {}", r.name, e.what());
      res = {500, "text/plain; charset=utf-8", std::string("cannot make ") + r.name + "\n", ""};
    }
    r.done(std::move(res));
  }
}

HttpResponse ViewApp::make_download(const std::string& name) const {
  const mapshare::MapReplica& replica = map_->replica();
  if (!replica.has_map()) return {503, "text/plain; charset=utf-8", "no map yet\n", ""};
  // Core's writers write files: into a private scratch directory, read back, removed.
  std::string dir_template = (fs::temp_directory_path() / "esfleet-view.XXXXXX").string();
  if (mkdtemp(dir_template.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
  const fs::path dir = dir_template;
  struct Remove {
    fs::path dir;
    ~Remove() {
      std::error_code ignored;
      fs::remove_all(dir, ignored);
    }
  } remove{dir};
  HttpResponse res;
  res.filename = name;
  if (name == "map.png") {
    save_map_png(replica.map(), leader_path_, (dir / "map.png").string());
    res.content_type = "image/png";
    res.body = read_whole(dir / "map.png");
  } else {
    save_ros_map(replica.map(), dir.string(), "map");
    res.content_type = name == "map.pgm" ? "image/x-portable-graymap" : "text/yaml; charset=utf-8";
    res.body = read_whole(dir / name);
  }
  return res;
}

}  // namespace esfleet::view
