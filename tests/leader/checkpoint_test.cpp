// The leader's checkpoints: a leader resumed from its last checkpoint continues exactly where
// the saved one was (same trajectory and counters as an uninterrupted run), its tiles supersede
// whatever the dead leader published after it, and a missing or damaged checkpoint is refused
// naming the file.

#include "checkpoint.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>

#include <unistd.h>

#include "esfleet/core/tile_codec.hpp"
#include "scratch_paths.hpp"
#include "synthetic_world.hpp"

namespace esfleet::leader {
namespace {

namespace fs = std::filesystem;
using esfleet::testing::asymmetric_room;
using esfleet::testing::make_scan;

/// A fresh directory under the test temp dir, per process (two checkouts may test at once).
fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::path(::testing::TempDir()) /
                     ("esfleet-checkpoint-" + name + "-" + std::to_string(::getpid()));
  fs::remove_all(d);
  test::scratch_paths().add(d);
  fs::create_directories(d);
  return d;
}

/// Scan i of a drive through the room (0.1 m and 1 degree per scan).
LaserScan scan(int i) {
  const double th = 0.3 + i * std::numbers::pi / 180.0;
  const Pose2 p{2.0 + 0.1 * i * std::cos(0.3), 1.5 + 0.1 * i * std::sin(0.3), th};
  return make_scan(asymmetric_room(), p, 0.2 * i);
}

CheckpointInfo info() { return {"map", 7, 0, "log test", "{\"mu\":\"100\"}"}; }

TEST(CounterCopy, KeepsCountersExactlyInHalfTheBytesWhenTheyFitSixteenBits) {
  std::vector<std::uint32_t> hit(4096), err(4096);
  for (std::size_t i = 0; i < hit.size(); ++i) {
    hit[i] = static_cast<std::uint32_t>((i * 7919) % 65536);
    err[i] = static_cast<std::uint32_t>((i * 104729) % 3001);
  }
  CounterCopy narrow(hit, err);
  EXPECT_TRUE(narrow.narrow());
  EXPECT_EQ(narrow.bytes(), 2 * 4096 * sizeof(std::uint16_t));
  std::vector<std::uint32_t> h, e;
  narrow.take(h, e);
  EXPECT_EQ(h, hit);
  EXPECT_EQ(e, err);
  EXPECT_EQ(narrow.bytes(), 0u);  // freed

  // One counter above 65535 (a long run) keeps the whole tile in 32 bits, exactly.
  err[4095] = 65536;
  CounterCopy wide(hit, err);
  EXPECT_FALSE(wide.narrow());
  EXPECT_EQ(wide.bytes(), 2 * 4096 * sizeof(std::uint32_t));
  wide.take(h, e);
  EXPECT_EQ(h, hit);
  EXPECT_EQ(e, err);

  EXPECT_THROW(CounterCopy(hit, std::vector<std::uint32_t>(10)), std::invalid_argument);
}

TEST(CheckpointSchedule, AResumedLeaderContinuesExactlyAsAnUninterruptedOne) {
  const fs::path out = fresh_dir("resume");
  SlamConfig config;
  config.seed = 5;
  Slam uninterrupted(config);
  {
    CheckpointSchedule schedule(out.string(), 20, info());
    for (int i = 0; i < 30; ++i) {
      uninterrupted.process(scan(i));
      schedule.after_scan(uninterrupted);  // saves at scan 20 only
    }
    schedule.wait_idle();  // the writer thread may still hold it
    EXPECT_EQ(schedule.stats()["written"], 1);
  }
  for (int i = 30; i < 50; ++i) uninterrupted.process(scan(i));

  // The leader died at scan 30; the checkpoint holds scan 20.
  Slam resumed(config);
  const Resumed r = load_checkpoint(out.string(), resumed);
  EXPECT_EQ(r.info.scans, 20u);
  EXPECT_EQ(r.info.map_id, "map");
  EXPECT_EQ(r.info.epoch, 7u);
  EXPECT_EQ(r.info.input, "log test");
  EXPECT_EQ(r.generation, 1u);
  for (int i = 20; i < 50; ++i) resumed.process(scan(i));
  ASSERT_EQ(resumed.trajectory().size(), uninterrupted.trajectory().size());
  for (std::size_t i = 0; i < resumed.trajectory().size(); ++i) {
    EXPECT_EQ(resumed.trajectory()[i].pose, uninterrupted.trajectory()[i].pose) << "scan " << i;
  }
  EXPECT_EQ(map_digest(resumed.map()), map_digest(uninterrupted.map()));  // counters
}

TEST(CheckpointSchedule, TheJournalStaysAheadOfPublishesAndResumedTilesSupersedeThem) {
  const fs::path out = fresh_dir("journal");
  Slam slam;
  std::uint64_t published_max = 0;
  {
    CheckpointSchedule schedule(out.string(), 10, info());
    for (int i = 0; i < 25; ++i) {
      slam.process(scan(i));
      schedule.after_scan(slam);
      schedule.reserve(slam.map());  // before every publish
      for (const TileKey k : slam.map().tile_keys()) {
        published_max = std::max(published_max, slam.map().find_tile(k)->version);
      }
      // The journal on disk covers everything published so far.
      std::ifstream in(out / "checkpoint" / "journal.json");
      const nlohmann::json j = nlohmann::json::parse(in);
      EXPECT_GE(j["version_ceiling"].get<std::uint64_t>(), published_max) << "scan " << i;
      EXPECT_EQ(j["tiles"].size(), slam.map().tile_count()) << "scan " << i;
    }
  }  // the writer thread has written the checkpoint of scan 20 (it may still run before)
  // Resumed from scan 20: every tile above anything published, none missing.
  Slam resumed;
  const Resumed r = load_checkpoint(out.string(), resumed);
  EXPECT_EQ(r.info.scans, 20u);
  EXPECT_GT(r.new_version, published_max);
  for (const TileKey k : slam.map().tile_keys()) {
    const Tile* t = resumed.map().find_tile(k);
    ASSERT_NE(t, nullptr);
    EXPECT_EQ(t->version, r.new_version);
  }
  EXPECT_GT(r.journal.version_ceiling, r.new_version);
}

TEST(CheckpointSchedule, AFreshStartMovesAnOldCheckpointAsideAResumeContinuesItsNumbering) {
  const fs::path out = fresh_dir("aside");
  Slam slam;
  slam.process(scan(0));
  { CheckpointSchedule(out.string(), 10, info()).save(slam, "test"); }
  ASSERT_TRUE(fs::exists(out / "checkpoint" / "manifest.json"));
  { CheckpointSchedule(out.string(), 10, info()).save(slam, "test"); }
  EXPECT_TRUE(fs::exists(out / "checkpoint.old" / "manifest.json"));
  // Resuming from this directory continues the generations (2 follows 1).
  Slam resumed;
  const Resumed r = load_checkpoint(out.string(), resumed);
  CheckpointSchedule again(out.string(), 10, info(), out.string(), &r);
  again.save(resumed, "test");
  EXPECT_TRUE(fs::exists(out / "checkpoint" / "map.2.bin"));
  EXPECT_FALSE(fs::exists(out / "checkpoint" / "map.1.bin"));  // the older generation went
  EXPECT_FALSE(fs::exists(out / "checkpoint.old" / "checkpoint"));
}

TEST(LoadCheckpoint, AMissingOrDamagedCheckpointIsRefusedNamingTheFile) {
  const fs::path out = fresh_dir("damaged");
  Slam slam;
  try {
    load_checkpoint(out.string(), slam);
    FAIL() << "loaded a checkpoint that does not exist";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("manifest.json: missing"), std::string::npos) << e.what();
  }
  slam.process(scan(0));
  CheckpointSchedule(out.string(), 10, info()).save(slam, "test");
  // A truncated map snapshot: the manifest's size no longer matches.
  const fs::path map_file = out / "checkpoint" / "map.1.bin";
  fs::resize_file(map_file, fs::file_size(map_file) / 2);
  Slam fresh;
  try {
    load_checkpoint(out.string(), fresh);
    FAIL() << "loaded a truncated checkpoint";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("map.1.bin"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("the manifest says"), std::string::npos) << e.what();
  }
  // A manifest without a field.
  std::ofstream(out / "checkpoint" / "manifest.json") << "{\"format\": 1}";
  Slam other;
  try {
    load_checkpoint(out.string(), other);
    FAIL() << "loaded a manifest without fields";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("field 'generation' missing"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace esfleet::leader
