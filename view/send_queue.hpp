#pragma once
// One browser's queue of WebSocket messages waiting to be sent, bounded in bytes. A message
// with a key (a tile "t:tx,ty", the robots, the status) replaces the waiting message with the
// same key in its place: a slow client gets the newest version of each tile and of each status
// once, never a backlog of old ones, so its queue holds at most one copy of the map plus a few
// messages. Messages without a key (a map reset) are never replaced. When the bytes waiting
// would exceed the bound even so, push() says so and the server drops the client.
//
// Payloads are shared (std::shared_ptr): one encoded tile is queued for every client without a
// copy. Not thread-safe: the server's I/O thread owns every queue.

#include <cstddef>
#include <cstdint>
#include <list>
#include <memory>
#include <string>
#include <unordered_map>

namespace esfleet::view {

struct OutMessage {
  std::string key;  ///< "" = never coalesced
  std::shared_ptr<const std::string> data;
  bool binary = false;  ///< binary frame (a tile) or text (JSON)
};

class SendQueue {
 public:
  /// `max_bytes`: the most payload bytes that may wait, >= 1.
  explicit SendQueue(std::size_t max_bytes) : max_bytes_(max_bytes) {}

  /// Queues `m`, replacing a waiting message with the same non-empty key. Returns false when
  /// the queue would then hold more than max_bytes (it is left as it was before the call: the
  /// caller drops the client).
  bool push(OutMessage m);
  /// Drops everything waiting (a new map epoch makes the queued tiles worthless).
  void clear();
  bool empty() const { return order_.empty(); }
  std::size_t size() const { return order_.size(); }
  std::size_t bytes() const { return bytes_; }
  /// Takes the oldest message (its position is that of the first push of its key).
  /// Requires !empty().
  OutMessage pop();
  /// Messages replaced by a newer one of the same key since construction.
  std::uint64_t coalesced() const { return coalesced_; }

 private:
  std::size_t max_bytes_;
  std::size_t bytes_ = 0;
  std::uint64_t coalesced_ = 0;
  std::list<OutMessage> order_;
  std::unordered_map<std::string, std::list<OutMessage>::iterator> by_key_;
};

/// The key of tile (tx, ty): "t:tx,ty".
std::string tile_key(std::int32_t tx, std::int32_t ty);

}  // namespace esfleet::view
