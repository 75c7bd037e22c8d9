#include "generalise_data.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <stdexcept>
#include <string_view>
#include <unordered_map>

namespace esfleet::bench {

const char* mode_name(GeneraliseMode mode) {
  return mode == GeneraliseMode::kLaserOnly ? "laser" : "odom";
}

namespace {

std::uint64_t parse_seed(std::string_view text, const std::string& whole) {
  std::uint64_t value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size()) {
    throw std::invalid_argument("seeds '" + whole + "': '" + std::string(text) +
                                "' is not a seed (a non-negative integer)");
  }
  return value;
}

/// The bytes of a scan's ranges: what "identical ranges" compares.
std::string_view range_bytes(const LaserScan& scan) {
  return {reinterpret_cast<const char*>(scan.ranges.data()), scan.ranges.size() * sizeof(float)};
}

}  // namespace

std::vector<std::uint64_t> parse_seed_list(const std::string& text) {
  std::vector<std::uint64_t> seeds;
  std::string_view rest = text;
  if (rest.empty()) throw std::invalid_argument("seeds: empty list");
  while (true) {
    const std::size_t comma = rest.find(',');
    const std::string_view part = rest.substr(0, comma);
    const std::size_t dash = part.find('-');
    std::uint64_t first = 0, last = 0;
    if (dash == std::string_view::npos) {
      first = last = parse_seed(part, text);
    } else {
      first = parse_seed(part.substr(0, dash), text);
      last = parse_seed(part.substr(dash + 1), text);
      if (last < first) {
        throw std::invalid_argument("seeds '" + text + "': range '" + std::string(part) +
                                    "' ends before it starts");
      }
      if (last - first > 100000) {
        throw std::invalid_argument("seeds '" + text + "': range '" + std::string(part) +
                                    "' is too long");
      }
    }
    for (std::uint64_t s = first;; ++s) {
      if (std::find(seeds.begin(), seeds.end(), s) == seeds.end()) seeds.push_back(s);
      if (s == last) break;
    }
    if (comma == std::string_view::npos) break;
    rest = rest.substr(comma + 1);
  }
  return seeds;
}

std::vector<std::size_t> subsample_indices(std::size_t n, std::size_t k, std::size_t max_count) {
  if (k == 0) throw std::invalid_argument("subsampling: k must be >= 1");
  std::vector<std::size_t> kept;
  for (std::size_t i = 0; i < n; i += k) {
    if (max_count > 0 && kept.size() == max_count) break;
    kept.push_back(i);
  }
  return kept;
}

std::vector<std::size_t> match_key_scans(const std::vector<LaserScan>& keys,
                                         const std::vector<LaserScan>& raw,
                                         const std::string& keys_name,
                                         const std::string& raw_name) {
  std::unordered_map<std::string_view, std::vector<std::size_t>> by_ranges;
  for (std::size_t i = 0; i < raw.size(); ++i) by_ranges[range_bytes(raw[i])].push_back(i);
  std::vector<std::size_t> match;
  match.reserve(keys.size());
  for (std::size_t k = 0; k < keys.size(); ++k) {
    const std::string where =
        keys_name + ": key scan " + std::to_string(k) + " (FLASER " + std::to_string(k + 1) + ")";
    const auto found = by_ranges.find(range_bytes(keys[k]));
    if (found == by_ranges.end()) {
      throw std::runtime_error(where + ": no scan of " + raw_name + " has the same ranges");
    }
    if (found->second.size() > 1) {
      throw std::runtime_error(where + ": " + std::to_string(found->second.size()) + " scans of " +
                               raw_name + " have the same ranges (scans " +
                               std::to_string(found->second[0]) + " and " +
                               std::to_string(found->second[1]) + "), the match is ambiguous");
    }
    const std::size_t r = found->second.front();
    if (!match.empty() && r <= match.back()) {
      throw std::runtime_error(where + ": matches scan " + std::to_string(r) + " of " + raw_name +
                               ", not after the previous key scan's " +
                               std::to_string(match.back()));
    }
    // The key log prints stamps with 6 significant digits: they must round to the raw stamp.
    const double difference = std::abs(keys[k].stamp - raw[r].stamp);
    if (!(difference <= 5e-6 * std::abs(raw[r].stamp))) {
      throw std::runtime_error(where + ": its stamp " + std::to_string(keys[k].stamp) +
                               " is not the stamp " + std::to_string(raw[r].stamp) + " of scan " +
                               std::to_string(r) + " of " + raw_name + " to 6 significant digits");
    }
    match.push_back(r);
  }
  return match;
}

namespace {

/// Checks that every scan has an odometry field (the source of noise or the reference).
void require_odometry(const std::vector<LaserScan>& scans, const std::string& name,
                      const char* what) {
  for (std::size_t i = 0; i < scans.size(); ++i) {
    if (!scans[i].odometry) {
      throw std::runtime_error(name + ": scan " + std::to_string(i) +
                               " has no pose fields, needed as " + what);
    }
  }
}

std::vector<double> stamps_of(const std::vector<LaserScan>& scans) {
  std::vector<double> stamps;
  stamps.reserve(scans.size());
  for (const LaserScan& s : scans) stamps.push_back(s.stamp);
  return stamps;
}

std::vector<std::size_t> identity(std::size_t n) {
  std::vector<std::size_t> index(n);
  for (std::size_t i = 0; i < n; ++i) index[i] = i;
  return index;
}

}  // namespace

GeneraliseLog make_key_scan_log(std::vector<LaserScan> keys, const std::vector<LaserScan>& raw,
                                std::vector<Relation> relations, const std::string& keys_name,
                                const std::string& raw_name) {
  require_odometry(keys, keys_name, "the reference pose");
  GeneraliseLog log;
  log.name = "csail-keys";
  log.path = keys_name;
  log.match_index = match_key_scans(keys, raw, keys_name, raw_name);
  for (std::size_t k = 0; k < keys.size(); ++k) {
    keys[k].stamp = raw[log.match_index[k]].stamp;  // the true stamp; the printed one is rounded
    log.reference.push_back(*keys[k].odometry);
  }
  log.scans = std::move(keys);
  log.relation_ends = match_relation_ends(stamps_of(raw), relations, log.relation_options);
  log.relations = std::move(relations);
  return log;
}

GeneraliseLog make_raw_log_with_keys(std::vector<LaserScan> raw,
                                     const std::vector<std::size_t>& key_raw_index,
                                     const std::vector<Pose2>& key_poses,
                                     std::vector<Relation> relations, const std::string& raw_name) {
  if (key_raw_index.size() != key_poses.size()) {
    throw std::invalid_argument("key scans: " + std::to_string(key_raw_index.size()) +
                                " raw indices but " + std::to_string(key_poses.size()) + " poses");
  }
  GeneraliseLog log;
  log.name = "csail";
  log.path = raw_name;
  log.reference.assign(raw.size(), std::nullopt);
  for (std::size_t k = 0; k < key_raw_index.size(); ++k) {
    if (key_raw_index[k] >= raw.size()) {
      throw std::invalid_argument("key scan " + std::to_string(k) + ": raw index " +
                                  std::to_string(key_raw_index[k]) + " is beyond " + raw_name);
    }
    log.reference[key_raw_index[k]] = key_poses[k];
  }
  log.match_index = identity(raw.size());
  log.relation_ends = match_relation_ends(stamps_of(raw), relations, log.relation_options);
  log.relations = std::move(relations);
  log.scans = std::move(raw);
  return log;
}

GeneraliseLog make_corrected_log(std::vector<LaserScan> scans, std::vector<Relation> relations,
                                 double time_offset, const std::string& name,
                                 const std::string& path) {
  require_odometry(scans, path, "the reference pose");
  GeneraliseLog log;
  log.name = name;
  log.path = path;
  log.relation_options.time_offset = time_offset;
  for (const LaserScan& s : scans) log.reference.push_back(*s.odometry);
  log.match_index = identity(scans.size());
  log.relation_ends = match_relation_ends(stamps_of(scans), relations, log.relation_options);
  log.relations = std::move(relations);
  log.scans = std::move(scans);
  return log;
}

std::vector<LaserScan> slam_input(const GeneraliseLog& log, const std::vector<std::size_t>& kept,
                                  GeneraliseMode mode, const OdometryNoise& noise,
                                  std::uint64_t seed) {
  std::vector<LaserScan> scans;
  scans.reserve(kept.size());
  for (std::size_t i : kept) scans.push_back(log.scans.at(i));
  if (mode == GeneraliseMode::kLaserOnly) {
    for (LaserScan& s : scans) s.odometry.reset();
    return scans;
  }
  std::vector<Pose2> source;
  source.reserve(scans.size());
  for (std::size_t j = 0; j < scans.size(); ++j) {
    if (!scans[j].odometry) {
      throw std::runtime_error(log.path + ": scan " + std::to_string(kept[j]) +
                               " has no pose fields for the noisy odometry");
    }
    source.push_back(*scans[j].odometry);
  }
  const std::vector<Pose2> noisy = noisy_odometry(source, noise, seed);
  for (std::size_t j = 0; j < scans.size(); ++j) scans[j].odometry = noisy[j];
  return scans;
}

LaserScan keep_every_beam(LaserScan scan, std::size_t step) {
  if (step <= 1) return scan;
  std::vector<float> kept;
  kept.reserve(scan.ranges.size() / step + 1);
  for (std::size_t i = 0; i < scan.ranges.size(); i += step) kept.push_back(scan.ranges[i]);
  scan.ranges = std::move(kept);
  scan.angle_increment *= static_cast<float>(step);
  return scan;
}

KeptRelations score_kept_relations(const GeneraliseLog& log, const std::vector<std::size_t>& kept,
                                   const std::vector<Pose2>& estimate) {
  if (kept.size() != estimate.size()) {
    throw std::invalid_argument("kept relations: " + std::to_string(kept.size()) +
                                " kept scans but " + std::to_string(estimate.size()) + " poses");
  }
  // Matched-log index -> position in the run.
  std::unordered_map<std::size_t, std::size_t> position;
  for (std::size_t j = 0; j < kept.size(); ++j) position[log.match_index.at(kept[j])] = j;
  // The kept relations, re-stamped with the positions as stamps, so evaluate_relations pairs
  // each end with exactly the scan it was matched to (no nearest-stamp search across gaps).
  std::vector<TimedPose> trajectory;
  for (std::size_t j = 0; j < estimate.size(); ++j) {
    trajectory.push_back({static_cast<double>(j), estimate[j]});
  }
  std::vector<Relation> used;
  for (std::size_t r = 0; r < log.relations.size(); ++r) {
    const auto& ends = log.relation_ends.at(r);
    if (!ends) continue;
    const auto a = position.find(ends->first);
    const auto b = position.find(ends->second);
    if (a == position.end() || b == position.end()) continue;
    used.push_back(
        {static_cast<double>(a->second), static_cast<double>(b->second), log.relations[r].rel});
  }
  KeptRelations out;
  out.used = used.size();
  out.total = log.relations.size();
  RelationsOptions exact = log.relation_options;
  exact.time_offset = 0.0;
  exact.tolerance = 0.0;
  out.result = evaluate_relations(trajectory, used, exact);
  return out;
}

KeptDerived score_kept_derived(const GeneraliseLog& log, const std::vector<std::size_t>& kept,
                               const std::vector<Pose2>& estimate,
                               const std::vector<std::size_t>& gaps) {
  if (kept.size() != estimate.size()) {
    throw std::invalid_argument("derived relations: " + std::to_string(kept.size()) +
                                " kept scans but " + std::to_string(estimate.size()) + " poses");
  }
  std::vector<Pose2> reference, est;
  for (std::size_t j = 0; j < kept.size(); ++j) {
    if (const auto& p = log.reference.at(kept[j])) {
      reference.push_back(*p);
      est.push_back(estimate[j]);
    }
  }
  KeptDerived out;
  out.reference_scans = reference.size();
  out.result = evaluate_derived_relations(reference, est, gaps);
  return out;
}

std::optional<KeptDerived> score_derived_floor(const GeneraliseLog& log,
                                               const std::vector<std::size_t>& kept,
                                               const std::vector<Pose2>& dense,
                                               const std::vector<std::size_t>& gaps) {
  std::vector<Pose2> at_kept;
  at_kept.reserve(kept.size());
  for (const std::size_t i : kept) {
    const std::size_t d = log.match_index.at(i);
    if (d >= dense.size()) return std::nullopt;
    at_kept.push_back(dense[d]);
  }
  return score_kept_derived(log, kept, at_kept, gaps);
}

}  // namespace esfleet::bench
