#include "leader_watch.hpp"

#include <spdlog/fmt/fmt.h>

namespace esfleet::follower {

LeaderWatch::Event LeaderWatch::update(double now_s, std::uint64_t meta_received,
                                       int matched_writers, bool mapping) {
  Event event = Event::kNone;
  if (meta_received != meta_seen_) {
    meta_seen_ = meta_received;
    last_meta_s_ = now_s;
    if (!present_) {
      present_ = true;
      matched_seen_ = false;
      if (lost_ > 0) {
        ++returned_;
        returned_at_s_ = now_s;
        event = Event::kBack;
      }
    }
  }
  if (!present_ || now_s - last_check_s_ < 0.1) return event;
  last_check_s_ = now_s;
  if (matched_writers > 0) matched_seen_ = true;
  const double silent = now_s - last_meta_s_;
  std::string why;
  if (matched_seen_ && matched_writers == 0) {
    why = "DDS reports its map writer gone";
  } else if (timeout_s_ > 0 && mapping && silent > timeout_s_) {
    why = fmt::format("no map summary for {:.1f} s while it was mapping", silent);
  }
  if (why.empty()) return event;
  present_ = false;
  ++lost_;
  lost_at_s_ = now_s;
  silence_at_loss_ = silent;
  reason_ = std::move(why);
  return Event::kGone;
}

nlohmann::json LeaderWatch::json() const {
  return {{"present", present_},
          {"lost_at_s", lost_at_s_},
          {"silence_at_loss_s", silence_at_loss_},
          {"returned_at_s", returned_at_s_},
          {"reason", reason_},
          {"leader_timeout_s", timeout_s_}};
}

}  // namespace esfleet::follower
