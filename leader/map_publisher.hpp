#pragma once
// The leader's map-sharing transport. The mapping thread only hands over what changed: publish()
// copies the counters of the tiles changed since the last call into a queue that coalesces
// (mapshare::TileQueue: one entry per tile, the newest) and replaces the waiting summary and pose
// with the newest. A publisher thread of its own takes everything waiting in rounds: it writes the
// summary and the pose first, then encodes the tiles (mapshare::TileSender: whole or as deltas
// against what it sent last, so coalesced versions make one exact delta) and writes the whole tiles
// before the deltas; a round that takes long (the writes wait for a slow link) is interleaved with
// the newest pose and summary every kPoseEvery. After a round it waits until the matched readers
// acknowledged it (at most kAckTimeout) before it takes the next: on a slow link the rounds get
// longer and fewer, the queue coalesces, and the mapping thread never waits for the network
// (docs/faults.md, "Publishing never blocks mapping"). It keeps the byte counts that show what
// tiles save over republishing the whole map (the ROS `map` topic habit).

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "esfleet/core/geometry.hpp"
#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/tile_codec.hpp"
#include "esfleet/dds/writer.hpp"
#include "esfleet/mapshare/tile_queue.hpp"
#include "esfleet/mapshare/tile_sender.hpp"

namespace esfleet::leader {

struct PublishStats {
  std::uint64_t publishes = 0;       ///< calls to publish() / publish_map() (hand-overs)
  std::uint64_t rounds = 0;          ///< rounds the publisher thread wrote
  std::uint64_t tiles = 0;           ///< tiles written (every part of each)
  std::uint64_t tile_bytes = 0;      ///< CDR bytes of their parts
  std::uint64_t deltas = 0;          ///< tile deltas written (every part of each)
  std::uint64_t delta_bytes = 0;     ///< their CDR bytes
  std::uint64_t meta_bytes = 0;      ///< summary CDR bytes
  std::uint64_t pose_bytes = 0;      ///< pose CDR bytes
  std::uint64_t write_failures = 0;  ///< samples DDS refused
  /// Rounds that brought every whole tile up to date because a tile reader had joined.
  std::uint64_t joiner_refreshes = 0;
  /// What a nav_msgs/OccupancyGrid of the known bounds at every publish would have cost:
  /// one byte per cell plus about 100 bytes of header and metadata.
  std::uint64_t full_map_bytes = 0;
  // The hand-over and the publisher thread.
  std::uint64_t tiles_handed_over = 0;  ///< tile copies the mapping thread queued
  std::uint64_t coalesced = 0;          ///< of those, replaced by a newer copy before being sent
  std::uint64_t queue_high_water = 0;   ///< most tiles waiting at once
  double handover_s = 0.0;         ///< mapping thread: time in publish() (copies, summary, pose)
  double encode_s = 0.0;           ///< publisher thread: encoding tiles and deltas
  double write_s = 0.0;            ///< publisher thread: DDS writes
  double ack_wait_s = 0.0;         ///< publisher thread: waiting for acknowledgments after rounds
  std::uint64_t ack_timeouts = 0;  ///< rounds not acknowledged within kAckTimeout
  double max_wait_s = 0.0;  ///< longest a hand-over waited before the publisher thread took it
  /// Newer poses and summaries written between the tiles of a long round (every kPoseEvery).
  std::uint64_t mid_round_updates = 0;
};

class MapPublisher {
 public:
  /// After a round, the publisher thread waits at most this long for acknowledgments (a
  /// follower that died stays matched until its lease ends).
  static constexpr std::chrono::milliseconds kAckTimeout{2000};
  /// During a round that takes longer, the newest pose and summary handed over are written
  /// between its tiles this often.
  static constexpr std::chrono::milliseconds kPoseEvery{500};

  /// Creates the tile, delta, summary and pose writers on `node` (which must outlive this
  /// object); the pose writer in the robot's partition (docs/security.md); then starts the
  /// publisher thread. Throws std::runtime_error naming the topic if DDS refuses.
  MapPublisher(dds::Node& node, mapshare::MapIdentity id, std::string robot_id,
               TileEncoding encoding = TileEncoding::kMedZlib, mapshare::DeltaPolicy policy = {});
  /// Stops the publisher thread (what is still queued is dropped: flush() first).
  ~MapPublisher();
  MapPublisher(const MapPublisher&) = delete;
  MapPublisher& operator=(const MapPublisher&) = delete;

  /// Hands over every tile changed since the last call (copies), the summary and the pose; the
  /// publisher thread sends them. `pose.stamp` is the scan time for the delta policy's
  /// full_period. Never waits for the network.
  void publish(GridMap& map, const TimedPose& pose, float fitness, bool complete,
               std::uint32_t scans, const std::string& params_json);
  /// The same without a pose (a map server has no robot). `stamp` takes the place of the scan
  /// time. Returns the number of tiles handed over.
  std::size_t publish_map(GridMap& map, double stamp, bool complete, std::uint32_t scans,
                          const std::string& params_json);
  /// The next round sends every tile whole (a resumed leader superseding what the dead one
  /// sent, a map server's first publish): marks every tile of `map` dirty and has the publisher
  /// thread forget what it sent.
  void republish_all(GridMap& map);

  PublishStats stats() const;
  /// Waits (bounded) until the publisher thread has written everything handed over; true if so.
  bool drain(std::chrono::milliseconds timeout);
  /// drain(), then waits (within the same bound) until every matched reader acknowledged
  /// everything written.
  bool flush(std::chrono::milliseconds timeout);

 private:
  /// What the publisher thread takes in one round.
  struct Round {
    std::vector<mapshare::TileCopy> tiles;
    std::optional<msg::MapMeta> meta;
    std::optional<msg::RobotPose> pose;
    mapshare::TileLayout layout;
    double stamp = 0.0;
    bool complete = false;
    bool forget_sent = false;
  };

  std::size_t hand_over(GridMap& map, double stamp, bool complete, std::uint32_t scans,
                        const std::string& params_json, std::optional<msg::RobotPose> pose);
  bool has_work() const;  ///< caller holds mutex_
  void run();
  /// Summary and pose, then the tiles whole, then the deltas.
  void write_round(Round& round);
  /// The round's messages (TileSender), whole tiles first; `joined`: a tile reader joined.
  std::vector<mapshare::TileMessage> encode(const Round& round, bool joined);
  /// Writes them in parts, with the newest pose and summary every kPoseEvery.
  void write_tiles(std::vector<mapshare::TileMessage>& out);
  /// Takes the pose and summary waiting in next_, if any, and writes them.
  void write_newest_pose_and_meta();
  /// After a round: until the readers acknowledged it, kAckTimeout passed or stop.
  void wait_acknowledged();
  /// Copies the writers' byte and failure counts into stats_ (caller holds mutex_).
  void count_bytes();

  std::string robot_id_;
  dds::TileWriter tiles_;
  dds::TileDeltaWriter deltas_;
  dds::MetaWriter meta_;
  dds::PoseWriter pose_;

  // Publisher thread only.
  mapshare::TileSender sender_;
  int tile_readers_ = 0;  ///< tile readers matched at the last round

  mutable std::mutex mutex_;
  std::condition_variable work_;     ///< something handed over, or stop
  std::condition_variable written_;  ///< a round was written
  // Guarded by mutex_: the hand-over.
  mapshare::TileQueue queue_;
  Round next_;            ///< all but its tiles (in queue_)
  bool waiting_ = false;  ///< next_ holds a hand-over not taken yet
  std::chrono::steady_clock::time_point waiting_since_;
  bool writing_ = false;  ///< the publisher thread is writing a round it took
  bool stop_ = false;
  PublishStats stats_;

  std::thread thread_;  ///< last: started once everything above exists
};

}  // namespace esfleet::leader
