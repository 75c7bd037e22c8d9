#include "contribution_intake.hpp"

#include <spdlog/spdlog.h>

#include <exception>
#include <utility>

#include "app/summary.hpp"
#include "esfleet/core/clock.hpp"
#include "esfleet/dds/from_msg.hpp"
#include "esfleet/dds/topics.hpp"

namespace esfleet::leader {

namespace {

/// "120 accepted, 3 rejected (2 refine_moved, 1 disagrees)".
std::string counts_text(const dds::ContributionTally& t,
                        const std::map<std::string, std::uint64_t>& rejected_by) {
  std::string s = fmt::format("{} accepted, {} rejected", t.accepted, t.rejected);
  std::string why;
  for (const auto& [verdict, n] : rejected_by) {
    why += fmt::format("{}{} {}", why.empty() ? "" : ", ", n, verdict);
  }
  return why.empty() ? s : s + " (" + why + ")";
}

}  // namespace

ContributionIntake::ContributionIntake(dds::Node& node, mapshare::MapIdentity map)
    : node_(node), map_(std::move(map)) {
  reader_ = std::make_unique<dds::ContributionReader>(
      node_, [this](const msg::ContributedScan& m, const dds::SampleMeta&) { on_sample(m); },
      dds::kAllPartitions);
}

// The reader first: no callback may run while the rest goes.
ContributionIntake::~ContributionIntake() {
  reader_.reset();
  robots_.clear();
}

void ContributionIntake::on_sample(const msg::ContributedScan& m) {
  std::lock_guard lock(mutex_);
  if (queue_.size() >= kMaxQueue) {
    const std::string id = queue_.front().robot_id().to_string();
    if (dropped_.size() < static_cast<std::size_t>(dds::kMaxRobots) || dropped_.count(id) > 0) {
      ++dropped_[id];
    }
    queue_.pop_front();
  }
  queue_.push_back(m);
}

ContributionIntake::Robot* ContributionIntake::robot(const std::string& id) {
  if (auto it = robots_.find(id); it != robots_.end()) return &it->second;
  if (robots_.size() >= static_cast<std::size_t>(dds::kMaxRobots)) return nullptr;
  Robot r;
  try {
    // In the robot's own partition: under DDS Security each robot may read its own status only.
    r.status = std::make_unique<dds::ContributionStatusWriter>(node_, id);
    spdlog::info("contributions from {}: the first one arrived", id);
  } catch (const std::exception& e) {
    // Checked all the same; only the answers are missing (once per robot in the log).
    spdlog::warn("contributions from {}: checked, but the robot cannot be answered: {}", id,
                 e.what());
  }
  r.last_log = std::chrono::steady_clock::now();
  return &robots_.emplace(id, std::move(r)).first->second;
}

std::size_t ContributionIntake::process(Slam& slam) {
  std::deque<msg::ContributedScan> batch;
  {
    std::lock_guard lock(mutex_);
    batch.swap(queue_);
  }
  const std::uint64_t before = accepted_;
  for (const msg::ContributedScan& m : batch) handle(slam, m);
  const auto now = std::chrono::steady_clock::now();
  for (auto& [id, r] : robots_) {
    if (now - r.last_log >= std::chrono::duration<double>(kLogPeriodS)) log_robot(id, r);
  }
  return static_cast<std::size_t>(accepted_ - before);
}

void ContributionIntake::handle(Slam& slam, const msg::ContributedScan& m) {
  Robot* r = robot(m.robot_id().to_string());
  if (r == nullptr) {
    ++ignored_robots_;
    return;
  }
  dds::ReceivedContribution c;
  try {
    c = dds::contribution_from_msg(m);
  } catch (const std::exception& e) {
    if (r->malformed++ == 0) {
      spdlog::warn("{}: a malformed contribution from {} dropped (further ones counted): {}",
                   dds::kContributionTopic, m.robot_id().to_string(), e.what());
    }
    return;
  }
  if (c.claim.map_id != map_.map_id || c.claim.epoch != map_.epoch) {
    ++r->stale;
    return;
  }
  const double cpu0 = thread_cpu_seconds();
  const ContributionResult result = slam.contribute(c.contribution);
  r->cpu_ms.push_back((thread_cpu_seconds() - cpu0) * 1e3);
  dds::ContributionTally& t = r->tally;
  t.last_seq = c.contribution.seq;
  t.last_verdict = result.verdict;
  if (result.accepted()) {
    ++t.accepted;
    ++accepted_;
    t.rejected_in_row = 0;
  } else if (!result.rejected()) {
    ++r->redundant;  // another robot mapped this place already: neither accepted nor refused
  } else {
    ++t.rejected;
    // Only refusals that doubt the pose count towards the follower's relocalisation.
    if (result.pose_doubtful()) ++t.rejected_in_row;
    ++r->rejected_by[to_string(result.verdict)];
  }
  t.stamp_ns = static_cast<std::uint64_t>(realtime_ns());
  if (r->status) r->status->write(dds::contribution_status_to_msg(c.contribution.robot, t));
}

void ContributionIntake::log_robot(const std::string& id, Robot& r) {
  r.last_log = std::chrono::steady_clock::now();
  const std::uint64_t checked = r.tally.accepted + r.tally.rejected + r.redundant;
  if (checked == r.logged) return;
  r.logged = checked;
  spdlog::info("contributions from {}: {}", id, counts_text(r.tally, r.rejected_by));
}

void ContributionIntake::log_summary() const {
  std::map<std::string, std::uint64_t> dropped;
  {
    std::lock_guard lock(mutex_);
    dropped = dropped_;
  }
  for (const auto& [id, r] : robots_) {
    const app::Summary cpu = app::summarize(r.cpu_ms);
    const auto d = dropped.find(id);
    spdlog::info(
        "contributions from {}: {}, {} redundant; {} stale (another map), {} dropped (queue full), "
        "{} "
        "malformed; {:.2f} ms CPU per check (median), {:.2f} p95",
        id, counts_text(r.tally, r.rejected_by), r.redundant, r.stale,
        d == dropped.end() ? 0 : d->second, r.malformed, cpu.median, cpu.p95);
  }
  if (ignored_robots_ > 0) {
    spdlog::warn("{} contributions ignored: more than {} robots contributed", ignored_robots_,
                 dds::kMaxRobots);
  }
}

nlohmann::json ContributionIntake::json() const {
  std::map<std::string, std::uint64_t> dropped;
  {
    std::lock_guard lock(mutex_);
    dropped = dropped_;
  }
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [id, r] : robots_) {
    const app::Summary cpu = app::summarize(r.cpu_ms);
    nlohmann::json rejected = nlohmann::json::object();
    for (const auto& [verdict, n] : r.rejected_by) rejected[verdict] = n;
    const auto d = dropped.find(id);
    j[id] = {{"accepted", r.tally.accepted},
             {"redundant", r.redundant},
             {"rejected", rejected},
             {"rejected_total", r.tally.rejected},
             {"stale", r.stale},
             {"dropped", d == dropped.end() ? 0 : d->second},
             {"malformed", r.malformed},
             {"cpu_ms_median", cpu.median},
             {"cpu_ms_p95", cpu.p95}};
  }
  // Dropped samples of robots whose contributions never reached the mapping thread.
  for (const auto& [id, n] : dropped) {
    if (robots_.count(id) == 0)
      j[id] = {{"accepted", 0}, {"rejected", nlohmann::json::object()}, {"dropped", n}};
  }
  return j;
}

}  // namespace esfleet::leader
