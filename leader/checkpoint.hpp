#pragma once
// The leader's checkpoints: what a leader killed at any moment needs to continue the same map
// (`esfleet-leader --resume DIR`), and the publish journal that lets the resumed leader's tiles
// supersede whatever the dead one published after its last checkpoint (docs/faults.md).
//
// DIR/checkpoint/ holds
//   map.<g>.bin, slam.<g>.bin  generation g of the snapshot
//                              (core/include/esfleet/core/slam_snapshot.hpp): every
//                              tile's counters and version; pose history, motion state, key
//                              scans, pose graph, random generator
//   manifest.json              written last (atomically): names generation g and its files with
//                              sizes, map id, epoch, scans processed, the input, the parameters.
//                              A checkpoint exists once its manifest does; older generations
//                              are deleted after the manifest is replaced.
//   journal.json               the publish journal: a version ceiling no published tile version
//                              exceeds and every tile key ever published. Rewritten (atomically)
//                              BEFORE a publish that would break it, so it always covers what
//                              followers may hold, however old the last checkpoint is.
// On resume every tile takes version ceiling + 1 and tiles the journal names but the checkpoint
// lacks are created empty, so every tile the followers hold is replaced by a newer version.

#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <thread>
#include <unordered_map>
#include <vector>

#include <nlohmann/json.hpp>
#include <span>
#include <string>

#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/slam.hpp"
#include "esfleet/core/tile_codec.hpp"
#include "esfleet/mapshare/publish_journal.hpp"

namespace esfleet::leader {

/// What a checkpoint records besides the snapshot.
struct CheckpointInfo {
  std::string map_id;
  std::uint32_t epoch = 0;
  std::uint64_t scans = 0;  ///< scans processed: with --log, the index of the next scan
  std::string input;        ///< "log PATH" or "scan-topic ROBOT_ID"
  std::string params_json;  ///< the SLAM parameters (a resumed leader must use the same)
};

class Checkpointer {
 public:
  /// Checkpoints go to `dir` (DIR/checkpoint, created). `first_generation` continues the
  /// numbering of a resumed checkpoint in the same directory.
  explicit Checkpointer(std::string dir, std::uint64_t first_generation = 1);

  /// Before publishing `map`: when the journal does not cover it (mapshare::PublishJournal::
  /// reserve), rewrites journal.json. Throws std::runtime_error naming the file on I/O failure.
  void reserve(const GridMap& map);
  /// Writes generation g+1 of the checkpoint (snapshot files, journal, manifest last) and
  /// deletes older generations; returns the bytes written. Throws std::runtime_error.
  /// The same as write(prepare(slam, info)).
  std::uint64_t save(Slam& slam, const CheckpointInfo& info);

  /// What one checkpoint needs, copied from the SLAM (the counters of the tiles changed since
  /// the previous prepare only), so that write() can run on another thread.
  struct Job;
  /// On the thread that owns `slam`: copies the state and the changed tiles and brings the
  /// journal up to the snapshot (journal.json is written before the manifest that needs it).
  std::unique_ptr<Job> prepare(Slam& slam, const CheckpointInfo& info);
  /// Encodes the changed tiles (the others come from earlier writes), writes the snapshot
  /// files and the manifest (each atomically, the manifest last) and deletes older
  /// generations; returns the bytes written. One call at a time, jobs in prepare() order.
  std::uint64_t write(Job& job);

  /// Takes over a resumed leader's journal and writes it at once (before anything is published).
  void adopt_journal(mapshare::PublishJournal journal) {
    journal_ = std::move(journal);
    write_journal();
  }
  const mapshare::PublishJournal& journal() const { return journal_; }
  const std::string& dir() const { return dir_; }

 private:
  void write_journal();

  std::string dir_;
  std::uint64_t generation_;  ///< of the next prepare()
  mapshare::PublishJournal journal_;
  /// prepare(): the tile versions handed to write() so far.
  std::unordered_map<TileKey, std::uint64_t, TileKeyHash> handed_;
  /// write(): each tile's counters encoded at the version last handed over.
  std::map<TileKey, std::pair<std::uint64_t, EncodedTile>> encoded_;
};

/// A loaded checkpoint.
struct Resumed {
  CheckpointInfo info;
  mapshare::PublishJournal journal;
  std::uint64_t generation = 0;
  std::uint64_t tiles_added_empty = 0;  ///< journal tiles the checkpoint did not have
  std::uint64_t new_version = 0;        ///< every tile's version after resume
};

/// Loads the checkpoint in `checkpoint_dir` (the directory holding manifest.json, e.g.
/// OUT/checkpoint) into `slam` (fresh, built with the same map layout: its map must be empty)
/// exactly as saved: every tile's counters and version, the SLAM state, and the publish journal,
/// without superseding anything (esfleet-leader --map serves the map as saved):
/// `tiles_added_empty` and `new_version` stay 0.
/// Throws std::runtime_error naming the file and field on a missing or corrupt checkpoint.
Resumed read_checkpoint(const std::string& checkpoint_dir, Slam& slam);

/// Loads DIR/checkpoint into `slam` (fresh, built with the same config: its map must be empty),
/// then supersedes what was published (mapshare::supersede): every tile gets version journal
/// ceiling + 1, journal tiles the snapshot lacks are created empty, the ceiling is raised past
/// the new versions.
/// Throws std::runtime_error naming the file and field on a missing or corrupt checkpoint.
Resumed load_checkpoint(const std::string& dir, Slam& slam);

/// What --resume starts from, as recorded in DIR/checkpoint/manifest.json.
struct CheckpointSettings {
  std::map<std::string, std::string> parameters;  ///< SLAM parameter -> value text
  std::string input;  ///< CheckpointInfo::input: "log PATH", "scan-topic ID" or "ros-scan TOPIC"
};
/// Throws std::runtime_error naming the file and field.
CheckpointSettings checkpoint_settings(const std::string& dir);

/// A tile's counters copied for the checkpoint writer thread: 16 bits each when every counter
/// of the tile fits (nearly always), else 32. After a loop closure re-writes many key scans
/// these copies were the largest allocation at the leader's peak (docs/benchmarks.md).
class CounterCopy {
 public:
  /// Throws std::invalid_argument if the sizes differ.
  CounterCopy(std::span<const std::uint32_t> hit, std::span<const std::uint32_t> err);
  bool narrow() const { return !narrow_.empty() || wide_.empty(); }
  /// Bytes the copy holds.
  std::size_t bytes() const { return 2 * narrow_.size() + 4 * wide_.size(); }
  /// The counters again, exactly, into `hit` and `err` (resized); frees the copy.
  void take(std::vector<std::uint32_t>& hit, std::vector<std::uint32_t>& err);

 private:
  std::size_t n_ = 0;
  std::vector<std::uint16_t> narrow_;  ///< hit then err
  std::vector<std::uint32_t> wide_;    ///< hit then err, when a counter is above 65535
};

/// The checkpoints of one leader run (`--checkpoint-every N`): OUT/checkpoint written every N
/// scans and at the end, and the publish journal kept ahead of every publish. A failure to
/// write is logged, never fatal: mapping and sharing go on (only a resumed leader could then
/// fail to supersede tiles).
class CheckpointSchedule {
 public:
  /// Opens `out_dir`/checkpoint for map `info` (its scans field is filled in at each save).
  /// When `resumed` was loaded from that same directory its generations continue, and its
  /// journal is adopted; an unrelated old checkpoint there is moved aside to checkpoint.old (a
  /// fresh start must not overwrite the map an operator may still want to resume). Throws
  /// std::runtime_error naming the directory.
  CheckpointSchedule(const std::string& out_dir, std::size_t every, CheckpointInfo info,
                     const std::string& resume_dir = {}, const Resumed* resumed = nullptr);

  /// Waits for the writer thread to finish the last checkpoint.
  ~CheckpointSchedule();
  CheckpointSchedule(const CheckpointSchedule&) = delete;
  CheckpointSchedule& operator=(const CheckpointSchedule&) = delete;

  /// After each scan: checkpoints when the scans processed are a multiple of `every`. The
  /// snapshot is copied here (the changed tiles, the SLAM state) and written by a writer thread
  /// while mapping goes on; a checkpoint still being written when the next one is due is
  /// waited for.
  void after_scan(Slam& slam);
  /// Checkpoints now and waits until it is written; `why` (e.g. "end of input") goes into the
  /// log line.
  void save(Slam& slam, const char* why);
  /// Before a publish of `map`: keeps the journal ahead of it.
  void reserve(const GridMap& map);

  /// Waits until the writer thread is idle: every checkpoint handed to it is written.
  void wait_idle();

  /// stats.json "checkpoint": directory, period, saves, median and max ms, last size, ceiling.
  /// Counts the checkpoints written so far; one the writer thread still holds is not counted.
  nlohmann::json stats() const;
  const Checkpointer& checkpointer() const { return checkpointer_; }

 private:
  /// Hands a checkpoint to the writer thread (after the previous one is written).
  void start(Slam& slam, const char* why);
  void writer_loop();

  std::size_t every_;
  CheckpointInfo info_;
  Checkpointer checkpointer_;
  std::vector<double> handoff_ms_;  ///< mapping-thread time of each checkpoint (copy, hand-off)
  bool reserve_failed_logged_ = false;

  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::unique_ptr<Checkpointer::Job> job_;  ///< waiting for the writer
  bool busy_ = false;                       ///< the writer holds a job
  bool quit_ = false;
  std::vector<double> ms_;  ///< writer time of each checkpoint (guarded by mutex_)
  std::uint64_t bytes_last_ = 0;
  std::thread writer_;  ///< last: started after everything it uses
};

}  // namespace esfleet::leader
