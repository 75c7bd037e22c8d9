#pragma once
// Whether the leader is there, as a follower sees it. Present from its first map summary; gone
// when DDS reports its tile writer unmatched (its participant's lease expired or it left) or,
// while it maps, when no summary came for `leader_timeout` seconds; back at the next summary.
// A lost leader changes nothing else in the follower: the map stays, tracking goes on, a resumed
// or new leader's tiles are applied as they come. Pure: the caller passes the time and what DDS
// reports, so tests drive it directly.

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

namespace esfleet::follower {

class LeaderWatch {
 public:
  /// `leader_timeout_s` 0 = only DDS's report counts.
  explicit LeaderWatch(double leader_timeout_s) : timeout_s_(leader_timeout_s) {}

  enum class Event { kNone, kBack, kGone };
  /// Called often with the time (s since start), the summaries received so far, the leader
  /// map writers matched now, and whether the leader's last summary says it is mapping (not
  /// complete). Returns kBack when the leader returned after being reported gone, kGone when
  /// it is reported gone now (reason() says why). Matches are checked at most every 0.1 s.
  Event update(double now_s, std::uint64_t meta_received, int matched_writers, bool mapping);

  bool present() const { return present_; }
  std::uint64_t lost() const { return lost_; }
  std::uint64_t returned() const { return returned_; }
  const std::string& reason() const { return reason_; }
  double lost_at_s() const { return lost_at_s_; }
  /// At the last loss: seconds since the last summary.
  double silence_at_loss_s() const { return silence_at_loss_; }
  double returned_at_s() const { return returned_at_s_; }
  /// stats.json "leader".
  nlohmann::json json() const;

 private:
  double timeout_s_;
  bool present_ = false;
  bool matched_seen_ = false;  ///< its tile writer was matched during this presence
  std::uint64_t meta_seen_ = 0;
  double last_meta_s_ = 0.0;
  double last_check_s_ = -1e300;
  std::uint64_t lost_ = 0, returned_ = 0;
  double lost_at_s_ = -1.0;
  double silence_at_loss_ = -1.0;
  double returned_at_s_ = -1.0;
  std::string reason_;
};

}  // namespace esfleet::follower
