#include "checkpoint.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "app/summary.hpp"
#include "esfleet/core/file_io.hpp"
#include "esfleet/core/slam_snapshot.hpp"

namespace esfleet::leader {

namespace fs = std::filesystem;

namespace {

constexpr int kFormat = 1;

std::string read_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path.string() + ": cannot open (missing?)");
  std::ostringstream s;
  s << in.rdbuf();
  if (!in.good() && !in.eof()) throw std::runtime_error(path.string() + ": read error");
  return s.str();
}

nlohmann::json read_json(const fs::path& path) {
  try {
    return nlohmann::json::parse(read_file(path));
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(path.string() + ": " + e.what());
  }
}

template <class T>
T field(const nlohmann::json& j, const char* name, const fs::path& path) {
  if (!j.is_object() || !j.contains(name)) {
    throw std::runtime_error(path.string() + ": field '" + name + "' missing");
  }
  try {
    return j.at(name).get<T>();
  } catch (const nlohmann::json::exception&) {
    throw std::runtime_error(path.string() + ": field '" + name + "' has the wrong type");
  }
}

}  // namespace

Checkpointer::Checkpointer(std::string dir, std::uint64_t first_generation)
    : dir_(std::move(dir)), generation_(first_generation) {
  fs::create_directories(dir_);
}

void Checkpointer::reserve(const GridMap& map) {
  if (journal_.reserve(map)) write_journal();
}

void Checkpointer::write_journal() {
  nlohmann::json tiles = nlohmann::json::array();
  for (const TileKey k : journal_.keys) tiles.push_back({k.tx, k.ty});
  const nlohmann::json j = {
      {"format", kFormat}, {"version_ceiling", journal_.version_ceiling}, {"tiles", tiles}};
  write_file_atomically(dir_ + "/journal.json", j.dump() + "\n");
}

CounterCopy::CounterCopy(std::span<const std::uint32_t> hit, std::span<const std::uint32_t> err)
    : n_(hit.size()) {
  if (err.size() != hit.size()) {
    throw std::invalid_argument("CounterCopy: hit and err sizes differ");
  }
  const auto fits = [](std::span<const std::uint32_t> c) {
    return std::all_of(c.begin(), c.end(), [](std::uint32_t x) { return x <= 0xffffu; });
  };
  auto fill = [&](auto& both) {
    both.reserve(2 * n_);
    both.insert(both.end(), hit.begin(), hit.end());
    both.insert(both.end(), err.begin(), err.end());
  };
  if (fits(hit) && fits(err)) {
    fill(narrow_);
  } else {
    fill(wide_);
  }
}

void CounterCopy::take(std::vector<std::uint32_t>& hit, std::vector<std::uint32_t>& err) {
  hit.resize(n_);
  err.resize(n_);
  auto split = [&](const auto& both) {
    std::copy_n(both.begin(), n_, hit.begin());
    std::copy_n(both.begin() + static_cast<std::ptrdiff_t>(n_), n_, err.begin());
  };
  if (narrow()) {
    split(narrow_);
  } else {
    split(wide_);
  }
  narrow_ = {};
  wide_ = {};
  n_ = 0;
}

struct Checkpointer::Job {
  std::uint64_t generation = 0;
  CheckpointInfo info;
  SlamState state;
  double cell_size = 0.0;
  int tile_edge = 0;
  /// Every tile's key and version, sorted by key.
  std::vector<std::pair<TileKey, std::uint64_t>> tiles;
  /// Counters of the tiles whose version changed since the previous job.
  struct Changed {
    TileKey key;
    std::uint64_t version = 0;
    CounterCopy counters;
  };
  std::vector<Changed> changed;
  std::string why;  ///< for the log line; empty = periodic
};

std::unique_ptr<Checkpointer::Job> Checkpointer::prepare(Slam& slam, const CheckpointInfo& info) {
  slam.settle();  // a speculative loop-closure search is applied first (state() needs it)
  auto job = std::make_unique<Job>();
  job->generation = generation_++;
  job->info = info;
  job->state = slam.state();
  const GridMap& map = slam.map();
  job->cell_size = map.cell_size();
  job->tile_edge = map.tile_edge();
  for (const TileKey k : map.tile_keys()) {
    const Tile& t = *map.find_tile(k);
    job->tiles.emplace_back(k, t.version);
    const auto it = handed_.find(k);
    if (it != handed_.end() && it->second == t.version) continue;
    job->changed.push_back({k, t.version, CounterCopy(t.hit, t.err)});
    handed_[k] = t.version;
  }
  reserve(map);  // the journal covers every version in the snapshot
  return job;
}

std::uint64_t Checkpointer::write(Job& job) {
  std::vector<std::uint32_t> hit, err;
  for (Job::Changed& c : job.changed) {
    c.counters.take(hit, err);
    encoded_[c.key] = {c.version, encode_tile(hit, err, TileEncoding::kMedZlib)};
  }
  std::vector<SnapshotTile> tiles;
  tiles.reserve(job.tiles.size());
  for (const auto& [k, version] : job.tiles) {
    const auto& [encoded_version, encoded] = encoded_.at(k);
    if (encoded_version != version) {
      throw std::logic_error("checkpoint: tile version " + std::to_string(version) +
                             " was never handed over");
    }
    tiles.push_back({k, version, &encoded});
  }
  const std::uint64_t g = job.generation;
  const std::string map_name = "map." + std::to_string(g) + ".bin";
  const std::string slam_name = "slam." + std::to_string(g) + ".bin";
  const std::string map_bytes = encode_map_snapshot(job.cell_size, job.tile_edge, tiles);
  write_file_atomically(dir_ + "/" + map_name, map_bytes);
  // Streamed into the file: the key scans make the blob 8 MB on CSAIL, which the leader would
  // otherwise hold besides the state at every checkpoint.
  AtomicFile slam_file(dir_ + "/" + slam_name);
  write_slam_state(job.state, [&](std::string_view piece) { slam_file.write(piece); });
  slam_file.commit();
  const std::uint64_t slam_bytes = slam_file.bytes_written();
  job.state = {};
  const CheckpointInfo& info = job.info;
  const nlohmann::json manifest = {
      {"format", kFormat},
      {"generation", g},
      {"map_id", info.map_id},
      {"epoch", info.epoch},
      {"scans", info.scans},
      {"input", info.input},
      {"parameters", nlohmann::json::parse(info.params_json.empty() ? "{}" : info.params_json)},
      {"map_file", map_name},
      {"map_bytes", map_bytes.size()},
      {"slam_file", slam_name},
      {"slam_bytes", slam_bytes},
      {"tiles", job.tiles.size()},
      {"written_unix_s",
       std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count()},
  };
  write_file_atomically(dir_ + "/manifest.json", manifest.dump(2) + "\n");
  // Older generations are unreachable now: remove them (best effort).
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir_, ec)) {
    const std::string name = e.path().filename().string();
    if ((name.starts_with("map.") || name.starts_with("slam.")) && name.ends_with(".bin") &&
        name != map_name && name != slam_name) {
      fs::remove(e.path(), ec);
    }
  }
  return map_bytes.size() + slam_bytes;
}

std::uint64_t Checkpointer::save(Slam& slam, const CheckpointInfo& info) {
  const std::unique_ptr<Job> job = prepare(slam, info);
  return write(*job);
}

Resumed read_checkpoint(const std::string& checkpoint_dir, Slam& slam) {
  const fs::path base = fs::path(checkpoint_dir);
  const fs::path manifest_path = base / "manifest.json";
  if (!fs::exists(manifest_path)) {
    throw std::runtime_error(manifest_path.string() + ": missing (no checkpoint in " +
                             checkpoint_dir + ")");
  }
  const nlohmann::json m = read_json(manifest_path);
  if (field<int>(m, "format", manifest_path) != kFormat) {
    throw std::runtime_error(manifest_path.string() + ": field 'format' is not " +
                             std::to_string(kFormat));
  }
  Resumed r;
  r.generation = field<std::uint64_t>(m, "generation", manifest_path);
  r.info.map_id = field<std::string>(m, "map_id", manifest_path);
  r.info.epoch = field<std::uint32_t>(m, "epoch", manifest_path);
  r.info.scans = field<std::uint64_t>(m, "scans", manifest_path);
  r.info.input = field<std::string>(m, "input", manifest_path);
  r.info.params_json = field<nlohmann::json>(m, "parameters", manifest_path).dump();

  auto blob = [&](const char* name_field, const char* size_field) {
    const fs::path p = base / field<std::string>(m, name_field, manifest_path);
    const std::string bytes = read_file(p);
    const auto expected = field<std::uint64_t>(m, size_field, manifest_path);
    if (bytes.size() != expected) {
      throw std::runtime_error(p.string() + ": " + std::to_string(bytes.size()) +
                               " bytes, the manifest says " + std::to_string(expected));
    }
    return std::pair{p, bytes};
  };
  const auto [map_path, map_bytes] = blob("map_file", "map_bytes");
  const auto [slam_path, slam_bytes] = blob("slam_file", "slam_bytes");
  if (slam.map().tile_count() != 0 || slam.scans_processed() != 0) {
    throw std::logic_error("load_checkpoint needs a fresh Slam");
  }
  try {
    decode_map_snapshot(map_bytes, slam.map());
  } catch (const std::exception& e) {
    throw std::runtime_error(map_path.string() + ": " + e.what());
  }
  try {
    slam.restore(decode_slam_state(slam_bytes));
  } catch (const std::exception& e) {
    throw std::runtime_error(slam_path.string() + ": " + e.what());
  }
  if (slam.scans_processed() != r.info.scans) {
    throw std::runtime_error(manifest_path.string() + ": field 'scans' is " +
                             std::to_string(r.info.scans) + " but " + slam_path.string() +
                             " holds " + std::to_string(slam.scans_processed()) + " poses");
  }

  const fs::path journal_path = base / "journal.json";
  const nlohmann::json j = read_json(journal_path);
  r.journal.version_ceiling = field<std::uint64_t>(j, "version_ceiling", journal_path);
  for (const auto& t : field<nlohmann::json>(j, "tiles", journal_path)) {
    if (!t.is_array() || t.size() != 2 || !t[0].is_number_integer() || !t[1].is_number_integer()) {
      throw std::runtime_error(journal_path.string() + ": field 'tiles' has a bad entry " +
                               t.dump());
    }
    r.journal.keys.insert(TileKey{t[0].get<std::int32_t>(), t[1].get<std::int32_t>()});
  }
  return r;
}

namespace {
/// DIR/checkpoint/manifest.json; throws std::runtime_error when there is none.
fs::path existing_manifest(const std::string& dir) {
  const fs::path manifest_path = fs::path(dir) / "checkpoint" / "manifest.json";
  if (!fs::exists(manifest_path)) {
    throw std::runtime_error(manifest_path.string() + ": missing (no checkpoint in " + dir + ")");
  }
  return manifest_path;
}
}  // namespace

CheckpointSettings checkpoint_settings(const std::string& dir) {
  const fs::path manifest_path = existing_manifest(dir);
  const nlohmann::json m = read_json(manifest_path);
  CheckpointSettings out;
  out.input = field<std::string>(m, "input", manifest_path);
  const auto params = field<nlohmann::json>(m, "parameters", manifest_path);
  if (!params.is_object()) {
    throw std::runtime_error(manifest_path.string() + ": field 'parameters' is not an object");
  }
  for (const auto& [name, value] : params.items()) {
    if (!value.is_string()) {
      throw std::runtime_error(manifest_path.string() + ": field 'parameters': '" + name +
                               "' is not a string");
    }
    out.parameters.emplace(name, value.get<std::string>());
  }
  return out;
}

Resumed load_checkpoint(const std::string& dir, Slam& slam) {
  existing_manifest(dir);
  const fs::path base = fs::path(dir) / "checkpoint";
  Resumed r = read_checkpoint(base.string(), slam);
  const fs::path journal_path = base / "journal.json";
  // Supersede everything published before: every tile (and every tile followers may hold that
  // the checkpoint lacks, empty) at a version above anything the dead leader could have sent.
  try {
    const mapshare::Superseded s = mapshare::supersede(slam.map(), r.journal);
    r.new_version = s.new_version;
    r.tiles_added_empty = s.tiles_added_empty;
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(journal_path.string() + ": " + e.what());
  }
  return r;
}

namespace {
/// The generation the checkpoint directory `dir` starts at: the resumed checkpoint's next one
/// when it is that directory; otherwise 1, after moving an old checkpoint there aside.
std::uint64_t first_generation(const std::string& dir, const std::string& out_dir,
                               const std::string& resume_dir, const Resumed* resumed) {
  std::error_code ec;
  if (resumed != nullptr && fs::equivalent(fs::path(resume_dir) / "checkpoint", dir, ec)) {
    return resumed->generation + 1;
  }
  if (fs::exists(dir + "/manifest.json")) {
    fs::remove_all(dir + ".old", ec);
    fs::rename(dir, dir + ".old", ec);
    spdlog::warn("moved the old checkpoint {} to {}.old (start with --resume {} to continue it)",
                 dir, dir, out_dir);
  }
  return 1;
}
}  // namespace

CheckpointSchedule::CheckpointSchedule(const std::string& out_dir, std::size_t every,
                                       CheckpointInfo info, const std::string& resume_dir,
                                       const Resumed* resumed)
    : every_(every),
      info_(std::move(info)),
      checkpointer_(out_dir + "/checkpoint",
                    first_generation(out_dir + "/checkpoint", out_dir, resume_dir, resumed)) {
  if (resumed != nullptr) checkpointer_.adopt_journal(resumed->journal);
}

CheckpointSchedule::~CheckpointSchedule() {
  {
    const std::lock_guard lock(mutex_);
    quit_ = true;
  }
  cv_.notify_all();
  if (writer_.joinable()) writer_.join();
}

void CheckpointSchedule::after_scan(Slam& slam) {
  if (every_ > 0 && slam.scans_processed() % every_ == 0) start(slam, nullptr);
}

void CheckpointSchedule::save(Slam& slam, const char* why) {
  start(slam, why);
  wait_idle();
}

void CheckpointSchedule::start(Slam& slam, const char* why) {
  const auto t0 = std::chrono::steady_clock::now();
  wait_idle();
  info_.scans = slam.scans_processed();
  std::unique_ptr<Checkpointer::Job> job;
  try {
    job = checkpointer_.prepare(slam, info_);
  } catch (const std::exception& e) {
    spdlog::error("checkpoint at scan {} failed: {}", slam.scans_processed(), e.what());
    return;
  }
  if (why != nullptr) job->why = why;
  if (!writer_.joinable()) writer_ = std::thread([this] { writer_loop(); });
  {
    const std::lock_guard lock(mutex_);
    job_ = std::move(job);
  }
  cv_.notify_all();
  handoff_ms_.push_back(
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
}

void CheckpointSchedule::wait_idle() {
  std::unique_lock lock(mutex_);
  cv_.wait(lock, [this] { return job_ == nullptr && !busy_; });
}

void CheckpointSchedule::writer_loop() {
  std::unique_lock lock(mutex_);
  while (true) {
    cv_.wait(lock, [this] { return job_ != nullptr || quit_; });
    if (job_ == nullptr) return;  // quit, nothing left to write
    const std::unique_ptr<Checkpointer::Job> job = std::move(job_);
    busy_ = true;
    lock.unlock();
    const auto t0 = std::chrono::steady_clock::now();
    const std::uint64_t scans = job->info.scans;
    std::optional<std::uint64_t> bytes;
    try {
      bytes = checkpointer_.write(*job);
    } catch (const std::exception& e) {
      spdlog::error("checkpoint at scan {} failed: {}", scans, e.what());
    }
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    lock.lock();
    if (bytes) {
      bytes_last_ = *bytes;
      ms_.push_back(ms);
      if (ms_.size() == 1 || ms_.size() % 20 == 0 || !job->why.empty()) {
        spdlog::info("checkpoint {} at scan {}{}: {:.0f} kB in {:.1f} ms (writer thread)",
                     ms_.size(), scans, job->why.empty() ? "" : fmt::format(" ({})", job->why),
                     static_cast<double>(*bytes) / 1e3, ms);
      }
    }
    busy_ = false;
    cv_.notify_all();
  }
}

void CheckpointSchedule::reserve(const GridMap& map) {
  try {
    checkpointer_.reserve(map);
  } catch (const std::exception& e) {
    if (!reserve_failed_logged_) spdlog::error("publish journal: {}", e.what());
    reserve_failed_logged_ = true;
  }
}

nlohmann::json CheckpointSchedule::stats() const {
  std::vector<double> ms;
  std::uint64_t bytes_last = 0;
  {
    const std::lock_guard lock(mutex_);
    ms = ms_;
    bytes_last = bytes_last_;
  }
  const app::Summary c = app::summarize(ms);
  const app::Summary h = app::summarize(handoff_ms_);
  return {{"dir", checkpointer_.dir()},
          {"every", every_},
          {"written", ms.size()},
          {"ms_median", c.median},
          {"ms_max", c.max},
          {"mapping_thread_ms_median", h.median},
          {"mapping_thread_ms_max", h.max},
          {"bytes_last", bytes_last},
          {"version_ceiling", checkpointer_.journal().version_ceiling}};
}

}  // namespace esfleet::leader
