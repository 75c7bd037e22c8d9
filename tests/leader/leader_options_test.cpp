// esfleet-leader's command line and its map server mode (--map): the flags --map excludes, the
// inputs it accepts (a checkpoint directory given either way, a ROS map YAML file) and the
// set-up errors that name the file, all before any DDS participant exists.

#include "leader_options.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "app/program.hpp"
#include "checkpoint.hpp"
#include "esfleet/core/ros_map_format.hpp"
#include "esfleet/core/ros_map_writer.hpp"
#include "esfleet/core/tile_codec.hpp"
#include "leader_app.hpp"
#include "options_test_harness.hpp"
#include "scratch_paths.hpp"
#include "served_map.hpp"
#include "synthetic_world.hpp"

namespace esfleet::leader {
namespace {

namespace fs = std::filesystem;

using esfleet::testing::contains;

/// Parses `args` like esfleet-leader's main() and finishes the options. Returns the
/// std::invalid_argument / UsageError message ("" when the options are valid); `parse_code` is
/// set when the command line itself was refused.
std::string options_error(std::vector<std::string> args, LeaderOptions* out = nullptr,
                          std::optional<int>* parse_code = nullptr) {
  return esfleet::testing::options_error("esfleet-leader", "leader", std::move(args),
                                         add_leader_flags, finish_leader_options, out, parse_code);
}

TEST(LeaderOptions, ExactlyOneInput) {
  EXPECT_TRUE(contains(options_error({}), "give exactly one of --log FILE"));
  EXPECT_TRUE(contains(options_error({}), "--map PATH"));
  EXPECT_EQ(options_error({"--log", "x.clf"}), "");
  EXPECT_EQ(options_error({"--scan-topic", "r1"}), "");
  EXPECT_TRUE(contains(options_error({"--log", "x.clf", "--scan-topic", "r1"}), "exactly one"));
  EXPECT_TRUE(contains(options_error({"--scan-topic", "r1", "--offline"}), "--offline maps"));
}

TEST(LeaderOptions, MapAloneIsValid) {
  LeaderOptions o;
  EXPECT_EQ(options_error({"--map", "out", "--ros", "--linger", "5"}, &o), "");
  EXPECT_TRUE(o.serving_map());
  EXPECT_EQ(o.map, "out");
  EXPECT_EQ(o.input_name(), "map out");
  EXPECT_EQ(o.linger, 5.0);
  EXPECT_TRUE(o.ros.outputs);
  EXPECT_EQ(options_error({"--map", "m.yaml", "--map-id", "b1", "--epoch", "9"}, &o), "");
  EXPECT_EQ(*o.map_id, "b1");
  EXPECT_EQ(*o.epoch, 9u);
}

TEST(LeaderOptions, MapExcludesTheMappingInputsNamingThoseGiven) {
  const std::string base =
      "--map serves a saved map without mapping: it excludes --log, --scan-topic, --ros-scan, "
      "--resume and --offline (given: ";
  EXPECT_EQ(options_error({"--map", "out", "--log", "x.clf"}), base + "--log)");
  EXPECT_EQ(options_error({"--map", "out", "--scan-topic", "r1"}), base + "--scan-topic)");
  EXPECT_EQ(options_error({"--map", "out", "--ros-scan", "/scan"}), base + "--ros-scan)");
  EXPECT_EQ(options_error({"--map", "out", "--resume", "old"}), base + "--resume)");
  EXPECT_EQ(options_error({"--map", "out", "--offline"}), base + "--offline)");
  EXPECT_EQ(options_error({"--map", "out", "--log", "x.clf", "--resume", "old", "--offline"}),
            base + "--log, --resume, --offline)");
}

TEST(LeaderOptions, MapRefusesFlagsForScans) {
  EXPECT_TRUE(contains(options_error({"--map", "out", "--rate", "1"}), "--rate paces a --log"));
  EXPECT_TRUE(contains(options_error({"--map", "out", "--idle-exit", "3"}), "--idle-exit needs"));
  EXPECT_TRUE(contains(options_error({"--map", "out", "--publish-period", "0"}),
                       "--publish-period must be > 0"));
}

TEST(LeaderOptions, AcceptContributionsNeedsAMappingLeaderOnDds) {
  LeaderOptions o;
  EXPECT_EQ(options_error({"--log", "x.clf"}, &o), "");
  EXPECT_FALSE(o.accept_contributions);
  EXPECT_EQ(options_error({"--log", "x.clf", "--accept-contributions", "--max-scans", "900"}, &o),
            "");
  EXPECT_TRUE(o.accept_contributions);
  EXPECT_EQ(options_error({"--scan-topic", "r1", "--accept-contributions"}), "");
  EXPECT_TRUE(contains(options_error({"--log", "x.clf", "--offline", "--accept-contributions"}),
                       "--accept-contributions needs a mapping leader on DDS"));
  EXPECT_TRUE(contains(options_error({"--map", "out", "--accept-contributions"}),
                       "--accept-contributions needs"));
}

TEST(LeaderOptions, MapNeedsAValue) {
  std::optional<int> code;
  EXPECT_EQ(options_error({"--map"}, nullptr, &code), "parse error");
  EXPECT_EQ(code, app::kExitUsage);
}

TEST(LeaderOptions, ResumeTakesTheCheckpointsParametersAndRefusesOthersGiven) {
  const fs::path out =
      fs::path(::testing::TempDir()) / ("esfleet-resume-params-" + std::to_string(::getpid()));
  fs::remove_all(out);
  test::scratch_paths().add(out);
  // The run that wrote the checkpoint: two parameters changed; written by an "older esfleet"
  // that lacked one parameter and had one this version does not know.
  LeaderOptions first;
  ASSERT_EQ(options_error({"--log", "x.clf", "--free-margin", "0.1", "--seed", "3"}, &first), "");
  nlohmann::json saved = nlohmann::json::object();
  for (const auto& [name, value] : first.parameters) saved[name] = value;
  saved.erase("loop_final_icp_min_normal_cos");
  saved["old_knob"] = "3";
  Slam slam(first.slam);
  CheckpointSchedule(out.string(), 0, {"map", 7, 0, "log x.clf", saved.dump()}).save(slam, "t");
  // A checkpoint whose input names none: resuming it needs one given.
  const fs::path odd = out / "odd";
  CheckpointSchedule(odd.string(), 0, {"map", 7, 0, "tape 3", saved.dump()}).save(slam, "t");
  EXPECT_TRUE(contains(options_error({"--resume", odd.string()}),
                       "the checkpoint's field 'input' is 'tape 3'; give --log, --scan-topic or "
                       "--ros-scan"));

  // No input given: the checkpoint's.
  LeaderOptions o;
  ASSERT_EQ(options_error({"--resume", out.string()}, &o), "");
  EXPECT_EQ(o.log, "x.clf");
  EXPECT_EQ(o.input_name(), "log x.clf");
  EXPECT_EQ(o.slam.update.free_margin, 0.1);
  EXPECT_EQ(o.slam.seed, 3u);
  EXPECT_TRUE(contains(o.parameter_changes, "free_margin = 0.1"));
  ASSERT_EQ(o.resume_notes.size(), 2u);
  EXPECT_TRUE(contains(o.resume_notes[0],
                       "loop_final_icp_min_normal_cos = 0.94: the checkpoint "
                       "does not have it"));
  EXPECT_TRUE(contains(o.resume_notes[1],
                       "old_knob = 3: the checkpoint has it but this esfleet "
                       "does not; ignored"));
  // Flags that agree with the checkpoint are fine; others are named.
  EXPECT_EQ(options_error({"--log", "x.clf", "--resume", out.string(), "--seed", "3"}), "");
  const std::string differ = options_error(
      {"--log", "x.clf", "--resume", out.string(), "--free-margin", "0.15", "--mu", "100"});
  EXPECT_TRUE(contains(differ,
                       "the SLAM parameters given differ from the checkpoint's: "
                       "free_margin (checkpoint 0.1, given 0.15) (leave them out"))
      << differ;
  EXPECT_TRUE(contains(options_error({"--log", "x.clf", "--resume", out.string(), "--paper"}),
                       "prediction (checkpoint constant-velocity, given previous)"));
  EXPECT_TRUE(contains(options_error({"--log", "x.clf", "--resume", (out / "none").string()}),
                       "manifest.json: missing"));
  // A value the parameter's parser takes but the SLAM refuses (a hand-edited manifest) is named
  // as the checkpoint's.
  nlohmann::json edited = saved;
  edited["prior_sigma_xy"] = "-1";
  edited["mu"] = "50";  // also taken from the checkpoint, and "mu" is in "must": not blamed
  const fs::path bad = out / "edited";
  CheckpointSchedule(bad.string(), 0, {"map", 7, 0, "log x.clf", edited.dump()}).save(slam, "t");
  const std::string refused = options_error({"--resume", bad.string()});
  EXPECT_TRUE(contains(refused, "--resume " + bad.string() +
                                    ": checkpoint parameter 'prior_sigma_xy' = -1: "
                                    "slam.prior_sigma_xy"))
      << refused;
  // An input given with it wins (the leader warns when it is not the checkpoint's).
  LeaderOptions topic;
  ASSERT_EQ(options_error({"--scan-topic", "r7", "--resume", out.string()}, &topic), "");
  EXPECT_EQ(topic.input_name(), "scan-topic r7");
}

// --- the maps --map serves -----------------------------------------------------------------

/// A fresh directory under the test temp dir.
fs::path fresh_dir(const std::string& name) {
  const fs::path d = fs::path(::testing::TempDir()) /
                     ("esfleet-map-server-" + name + "-" + std::to_string(::getpid()));
  fs::remove_all(d);
  test::scratch_paths().add(d);
  fs::create_directories(d);
  return d;
}

/// A small map made by the SLAM and checkpointed into OUT/checkpoint (as the leader does).
std::unique_ptr<Slam> mapped_and_checkpointed(const fs::path& out, const SlamConfig& config = {}) {
  auto owned = std::make_unique<Slam>(config);
  Slam& slam = *owned;
  for (int i = 0; i < 12; ++i) {
    const double th = 0.3 + i * std::numbers::pi / 180.0;
    const Pose2 p{2.0 + 0.1 * i * std::cos(0.3), 1.5 + 0.1 * i * std::sin(0.3), th};
    slam.process(esfleet::testing::make_scan(esfleet::testing::asymmetric_room(), p, 0.2 * i));
  }
  CheckpointSchedule schedule(out.string(), 0, {"building-1", 42, 0, "log x.clf", "{}"});
  schedule.save(slam, "test");
  return owned;
}

TEST(ServedMap, ACheckpointGivenAsOutOrAsOutCheckpointComesBackExactly) {
  const fs::path out = fresh_dir("checkpoint");
  SlamConfig config;
  config.map.cell_size = 0.1;  // not the default: the server takes the checkpoint's layout
  config.map.tile_edge = 32;
  const auto made = mapped_and_checkpointed(out, config);
  const Slam& slam = *made;
  // The checkpoint records the parameters as the leader does (name -> text).
  {
    std::ifstream in(out / "checkpoint" / "manifest.json");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto at = text.find("\"parameters\": {}");
    ASSERT_NE(at, std::string::npos);
    text.replace(at, 16, R"("parameters": {"cell_size": "0.1", "tile_edge": "32"})");
    std::ofstream(out / "checkpoint" / "manifest.json") << text;
  }
  for (const fs::path& given : {out, out / "checkpoint", fs::path(out.string() + "/")}) {
    const ServedMap m = load_served_map(given.string(), SlamConfig{});
    EXPECT_EQ(m.kind, ServedMapKind::kCheckpoint) << given;
    EXPECT_EQ(m.file, (out / "checkpoint" / "manifest.json").string());
    ASSERT_TRUE(m.checkpoint);
    EXPECT_EQ(m.checkpoint->map_id, "building-1");
    EXPECT_EQ(m.checkpoint->epoch, 42u);
    EXPECT_EQ(m.checkpoint->scans, 12u);
    EXPECT_EQ(m.map.cell_size(), 0.1);
    EXPECT_EQ(m.map.tile_edge(), 32);
    EXPECT_EQ(map_digest(m.map), map_digest(slam.map()));  // the exact counters
    for (const TileKey k : slam.map().tile_keys()) {       // and versions, as saved
      EXPECT_EQ(m.map.find_tile(k)->version, slam.map().find_tile(k)->version);
    }
    EXPECT_EQ(m.dirs.size(), 2u);
  }
}

TEST(ServedMap, ARosYamlBecomesCountersOfItsResolution) {
  const fs::path dir = fresh_dir("yaml");
  GridMap map(GridMapConfig{.cell_size = 0.1, .tile_edge = 8});
  for (int i = 0; i < 3; ++i) map.add_hit({-5, -3});
  map.add_err({2, 4});
  map.commit_update();
  save_ros_map(map, dir.string(), "map");
  SlamConfig config;
  config.map.tile_edge = 16;  // the server's own tile edge
  const ServedMap m = load_served_map((dir / "map.yaml").string(), config);
  EXPECT_EQ(m.kind, ServedMapKind::kRosYaml);
  EXPECT_FALSE(m.checkpoint);
  ASSERT_TRUE(m.placement);
  EXPECT_TRUE(m.placement->aligned());
  EXPECT_EQ(m.map.cell_size(), 0.1);
  EXPECT_EQ(m.map.tile_edge(), 16);
  EXPECT_EQ(m.map.hit({-5, -3}), 5u);
  EXPECT_EQ(m.map.err({2, 4}), 5u);
  const CellClasses c = cell_classes(m.map);
  EXPECT_EQ(c.occupied, 1u);
  EXPECT_EQ(c.free, 1u);
  EXPECT_EQ(c.unknown, 8u * 8u - 2u);  // the 8 x 8 box of the known cells
  EXPECT_EQ(m.dirs, std::vector<std::string>{dir.string()});
}

std::string load_error(const std::string& path) {
  try {
    load_served_map(path, SlamConfig{});
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "no error";
}

TEST(ServedMap, BadPathsAreRefusedNamingTheFile) {
  const fs::path dir = fresh_dir("bad");
  EXPECT_EQ(load_error((dir / "nope").string()),
            (dir / "nope").string() + ": no such file or directory");
  // A directory without a checkpoint: a map.yaml there is suggested.
  std::ofstream(dir / "map.yaml") << "image: map.pgm\n";
  const std::string none = load_error(dir.string());
  EXPECT_TRUE(contains(none, "no checkpoint in this directory")) << none;
  EXPECT_TRUE(contains(none, "give " + (dir / "map.yaml").string())) << none;
  // A YAML file with a bad field: the reader's message, naming file and field.
  std::ofstream(dir / "bad.yaml") << "image: map.pgm\nresolution: -1\norigin: [0, 0, 0]\n"
                                     "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.2\n";
  const std::string bad = load_error((dir / "bad.yaml").string());
  EXPECT_TRUE(contains(bad, "bad.yaml")) << bad;
  EXPECT_TRUE(contains(bad, "resolution")) << bad;
  // A damaged checkpoint: names the checkpoint file.
  const fs::path out = dir / "out";
  mapped_and_checkpointed(out);
  std::ofstream(out / "checkpoint" / "journal.json") << "{";
  const std::string damaged = load_error(out.string());
  EXPECT_TRUE(contains(damaged, "journal.json")) << damaged;
}

TEST(LeaderApp, MapSetUpErrorsAreUsageErrorsBeforeDds) {
  const fs::path dir = fresh_dir("app");
  const std::atomic<bool> stop{false};
  LeaderOptions o;
  o.map = (dir / "missing.yaml").string();
  o.out_dir = (dir / "served").string();
  try {
    LeaderApp app(o, stop);
    ADD_FAILURE() << "no error";
  } catch (const app::UsageError& e) {
    EXPECT_EQ(std::string(e.what()), "--map " + o.map + ": no such file or directory");
  }
  // --out must not be where the served map lives (it would overwrite the leader's outputs).
  mapped_and_checkpointed(dir / "live");
  for (const fs::path& out : {dir / "live", dir / "live" / "checkpoint"}) {
    o.map = (dir / "live").string();
    o.out_dir = out.string();
    try {
      LeaderApp app(o, stop);
      ADD_FAILURE() << "no error";
    } catch (const app::UsageError& e) {
      EXPECT_TRUE(contains(e.what(), ": the map served (--map ")) << e.what();
    }
  }
}

}  // namespace
}  // namespace esfleet::leader
