#include "send_queue.hpp"

namespace esfleet::view {

namespace {
std::size_t size_of(const OutMessage& m) { return m.data ? m.data->size() : 0; }
}  // namespace

bool SendQueue::push(OutMessage m) {
  const std::size_t add = size_of(m);
  if (!m.key.empty()) {
    if (const auto it = by_key_.find(m.key); it != by_key_.end()) {
      const std::size_t old = size_of(*it->second);
      if (bytes_ - old + add > max_bytes_) return false;
      bytes_ = bytes_ - old + add;
      it->second->data = std::move(m.data);
      it->second->binary = m.binary;
      ++coalesced_;
      return true;
    }
  }
  if (bytes_ + add > max_bytes_) return false;
  bytes_ += add;
  order_.push_back(std::move(m));
  if (!order_.back().key.empty()) by_key_[order_.back().key] = std::prev(order_.end());
  return true;
}

void SendQueue::clear() {
  order_.clear();
  by_key_.clear();
  bytes_ = 0;
}

OutMessage SendQueue::pop() {
  OutMessage m = std::move(order_.front());
  order_.pop_front();
  if (!m.key.empty()) by_key_.erase(m.key);
  bytes_ -= size_of(m);
  return m;
}

std::string tile_key(std::int32_t tx, std::int32_t ty) {
  return "t:" + std::to_string(tx) + "," + std::to_string(ty);
}

}  // namespace esfleet::view
