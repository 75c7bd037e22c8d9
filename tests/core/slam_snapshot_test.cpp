// Snapshots of a running SLAM (core/include/esfleet/core/slam_snapshot.hpp): a Slam restored
// from a snapshot taken mid-log continues exactly as the one that was never stopped, and damaged
// snapshots are refused with a message naming the field.
#include "esfleet/core/slam_snapshot.hpp"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "esfleet/core/carmen_reader.hpp"
#include "esfleet/core/tile_codec.hpp"

namespace esfleet {
namespace {

std::vector<LaserScan> csail_scans(std::size_t n) {
  std::vector<LaserScan> scans =
      read_carmen_log(std::string(ESFLEET_DATA_DIR) + "/mit-csail/mit-csail.clf.gz", {}, n);
  scans.resize(std::min(n, scans.size()));
  return scans;
}

SlamConfig test_config() {
  SlamConfig c;
  c.tracking.use_odometry = true;
  c.seed = 7;
  return c;
}

/// The resumed Slam's map, trajectory and loop closures equal the uninterrupted one's.
void expect_same_run(const Slam& resumed, const Slam& straight) {
  EXPECT_EQ(map_digest(resumed.map()), map_digest(straight.map()));
  ASSERT_EQ(resumed.trajectory().size(), straight.trajectory().size());
  for (std::size_t i = 0; i < straight.trajectory().size(); ++i) {
    EXPECT_EQ(resumed.trajectory()[i].pose.x, straight.trajectory()[i].pose.x) << i;
    EXPECT_EQ(resumed.trajectory()[i].pose.theta, straight.trajectory()[i].pose.theta) << i;
  }
  EXPECT_EQ(resumed.loop_closures(), straight.loop_closures());
}

/// A run of `config` over CSAIL's first 300 scans, snapshot after 170 and resumed, against the
/// same run never stopped.
void expect_resumes_identically(SlamConfig config) {
  const std::vector<LaserScan> scans = csail_scans(300);
  ASSERT_EQ(scans.size(), 300u);
  const std::size_t cut = 170;
  // Searches on the mapping thread: with speculative ones the tile versions (not the map)
  // depend on how many scans were undone and processed again.
  config.loop.speculate = false;
  Slam straight(config);
  std::string map_blob, slam_blob;
  float reach_at_cut = 0.0f;
  for (std::size_t i = 0; i < scans.size(); ++i) {
    if (i == cut) {
      map_blob = encode_map_snapshot(straight.map());
      slam_blob = encode_slam_state(straight.state());
      reach_at_cut = straight.laser_reach();
    }
    straight.process(scans[i]);
  }
  Slam resumed(config);
  decode_map_snapshot(map_blob, resumed.map());
  resumed.restore(decode_slam_state(slam_blob));
  EXPECT_EQ(resumed.scans_processed(), cut);
  EXPECT_GT(reach_at_cut, 13.0f);  // CSAIL's beams of 13 m or more come before the cut
  EXPECT_EQ(resumed.laser_reach(), reach_at_cut);
  EXPECT_GT(resumed.key_scans(), 10u);
  for (std::size_t i = cut; i < scans.size(); ++i) resumed.process(scans[i]);

  expect_same_run(resumed, straight);
  // Tile versions survive too.
  for (const TileKey k : straight.map().tile_keys()) {
    EXPECT_EQ(resumed.map().find_tile(k)->version, straight.map().find_tile(k)->version);
  }
}

TEST(SlamSnapshot, RestoredSlamContinuesBitIdentically) {
  expect_resumes_identically(test_config());
}

// The short laser's hold (SlamConfig::short_view_range) depends on the longest beam of the key
// scans so far (Slam::laser_reach, checked above). CSAIL's first beam of 13 m or more comes at
// raw scan 162: before the cut the hold is on, after it off.
TEST(SlamSnapshot, TheShortLasersHoldContinuesAsBeforeTheSnapshot) {
  SlamConfig config = test_config();
  config.short_view_range = 13.0;
  expect_resumes_identically(config);
}

TEST(SlamSnapshot, SpeculativeLoopSearchesGiveTheMappingThreadsResult) {
  // Searches on a worker thread while later scans are processed; an accepted closure undoes
  // and re-processes them. Same map, trajectory and closures as searching on the mapping
  // thread, whenever the worker finishes.
  const std::vector<LaserScan> scans = csail_scans(700);
  SlamConfig on = test_config(), off = test_config();
  on.loop.speculate = true;
  off.loop.speculate = false;
  Slam speculative(on), straight(off);
  bool checked_state = false;
  for (const LaserScan& scan : scans) {
    speculative.process(scan);
    straight.process(scan);
    if (!checked_state && speculative.speculating()) {
      // Until the next scan or settle() the search is pending: no state to save yet.
      EXPECT_THROW((void)speculative.state(), std::logic_error);
      checked_state = true;
    }
  }
  EXPECT_TRUE(checked_state);
  speculative.settle();
  EXPECT_FALSE(speculative.speculating());
  EXPECT_NO_THROW((void)speculative.state());
  EXPECT_GT(straight.loop_closures(), 0u);
  EXPECT_FALSE(straight.speculating());
  expect_same_run(speculative, straight);
}

TEST(SlamSnapshot, APendingDeferredLoopSearchIsSavedAndRestarted) {
  // Loop closure on a worker thread (defer_keys): a snapshot taken while a search is pending
  // holds its key scan; the restored Slam searches again and applies the result at the same
  // key scan as the one never stopped.
  SlamConfig config = test_config();
  config.loop.defer_keys = 5;
  const std::vector<LaserScan> scans = csail_scans(300);
  ASSERT_EQ(scans.size(), 300u);
  Slam straight(config);
  std::string map_blob, slam_blob;
  std::size_t cut = 0;
  for (std::size_t i = 0; i < scans.size(); ++i) {
    if (cut == 0 && i >= 150) {
      const SlamState state = straight.state();
      if (state.pending_loop_key) {
        cut = i;
        map_blob = encode_map_snapshot(straight.map());
        slam_blob = encode_slam_state(state);
      }
    }
    straight.process(scans[i]);
  }
  ASSERT_GT(cut, 0u) << "no pending search after scan 150";
  Slam resumed(config);
  decode_map_snapshot(map_blob, resumed.map());
  resumed.restore(decode_slam_state(slam_blob));
  ASSERT_TRUE(resumed.state().pending_loop_key.has_value());
  for (std::size_t i = cut; i < scans.size(); ++i) resumed.process(scans[i]);
  expect_same_run(resumed, straight);
}

TEST(SlamSnapshot, StreamedStateEqualsTheEncodedOne) {
  const std::vector<LaserScan> scans = csail_scans(60);
  Slam slam(test_config());
  for (const LaserScan& s : scans) slam.process(s);
  SlamState state = slam.state();
  // More key scans than 60 scans make, so that the blob takes several pieces (encoding does not
  // check that they fit the graph).
  const std::vector<KeyScan> keys = state.keys;
  for (int i = 0; i < 30; ++i) state.keys.insert(state.keys.end(), keys.begin(), keys.end());
  std::string streamed;
  std::size_t pieces = 0;
  const std::uint64_t n = write_slam_state(state, [&](std::string_view piece) {
    EXPECT_LE(piece.size(), std::size_t{1} << 17);
    streamed += piece;
    ++pieces;
  });
  const std::string encoded = encode_slam_state(state);
  EXPECT_EQ(streamed, encoded);
  EXPECT_EQ(n, encoded.size());
  EXPECT_GT(pieces, 1u) << encoded.size() << " bytes in one piece";
}

TEST(SlamSnapshot, TheTrailingSectionsRoundTripInAnyCombination) {
  const std::vector<LaserScan> scans = csail_scans(60);
  Slam slam(test_config());
  for (const LaserScan& s : scans) slam.process(s);
  const SlamState base = slam.state();
  ASSERT_GT(base.keys.size(), 2u);
  // Every combination of: a pending loop search, contributed key scans, a last recovery jump.
  for (int mask = 0; mask < 8; ++mask) {
    SlamState s = base;
    if (mask & 1) s.pending_loop_key = 1;
    if (mask & 2) {
      s.contributors = {"robot-1"};
      s.keys.back().contributor = 1;
    }
    s.last_jumped = (mask & 4) != 0;
    const SlamState back = decode_slam_state(encode_slam_state(s));
    EXPECT_EQ(back.pending_loop_key, s.pending_loop_key) << mask;
    EXPECT_EQ(back.contributors, s.contributors) << mask;
    EXPECT_EQ(back.keys.back().contributor, s.keys.back().contributor) << mask;
    EXPECT_EQ(back.last_jumped, s.last_jumped) << mask;
  }
}

TEST(SlamSnapshot, DamageIsReportedWithTheField) {
  const std::vector<LaserScan> scans = csail_scans(60);
  Slam slam(test_config());
  for (const LaserScan& s : scans) slam.process(s);
  const std::string map_blob = encode_map_snapshot(slam.map());
  const std::string slam_blob = encode_slam_state(slam.state());

  auto map_error = [](std::string blob) {
    GridMap map(test_config().map);
    try {
      decode_map_snapshot(blob, map);
    } catch (const SnapshotError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  auto slam_error = [](std::string blob) {
    try {
      decode_slam_state(blob);
    } catch (const SnapshotError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(map_error(map_blob), "no error");
  EXPECT_EQ(slam_error(slam_blob), "no error");
  EXPECT_NE(map_error(map_blob.substr(0, map_blob.size() / 2)).find("checksum"), std::string::npos);
  std::string flipped = slam_blob;
  flipped[flipped.size() / 2] ^= 0x40;
  EXPECT_NE(slam_error(flipped).find("slam snapshot: checksum"), std::string::npos);
  EXPECT_NE(slam_error("ESFMAP01xxxxxxxx").find("magic"), std::string::npos);
  EXPECT_NE(slam_error("short").find("shorter"), std::string::npos);

  // Another tile edge: the field is named.
  SlamConfig other = test_config();
  other.map.tile_edge = 32;
  GridMap map(other.map);
  try {
    decode_map_snapshot(map_blob, map);
    FAIL() << "accepted a snapshot of another tile edge";
  } catch (const SnapshotError& e) {
    EXPECT_NE(std::string(e.what()).find("tile_edge"), std::string::npos) << e.what();
  }
}

TEST(SlamSnapshot, RestoreRefusesInconsistentState) {
  Slam slam(test_config());
  SlamState s;
  s.graph_nodes.resize(2);  // no key scans
  EXPECT_THROW(slam.restore(s), std::invalid_argument);
}

}  // namespace
}  // namespace esfleet
