#pragma once
// The view's HTTP and WebSocket server (Boost.Beast over Boost.Asio, one I/O thread of its own).
// It serves the embedded page (web_assets.hpp) and nothing else from this host: no file system
// access at all, so a path cannot traverse anywhere; GET only, on a fixed set of paths. A
// WebSocket on /ws gets the current map (every tile the server holds, newest version) and the
// fleet's state on connect, then what changes (docs/view.md, "Protocol").
//
// Limits (ServerLimits): request header size, request body, WebSocket message size from the
// browser, concurrent connections (beyond them a new connection is closed at once), the time a
// request may take to arrive, and each browser's send queue in bytes (SendQueue: tiles and
// states coalesce, newest wins; a browser whose queue would still overflow is dropped). The
// application thread never waits for a browser: it posts to the I/O thread and returns.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace esfleet::view {

struct ServerLimits {
  std::size_t max_connections = 256;  ///< HTTP and WebSocket together; more are closed at once
  std::uint32_t header_limit = 8192;  ///< bytes of a request's start line and headers
  std::uint64_t body_limit = 0;       ///< bytes of a request body (GET only: none)
  std::size_t ws_message_max = 4096;  ///< bytes of one WebSocket message from a browser
  std::size_t client_queue_bytes = 64u << 20;  ///< bytes waiting per browser (>= one whole map)
  std::chrono::seconds request_timeout{10};    ///< a request must arrive (whole) within this
  /// Throws std::invalid_argument naming the field when a value is 0.
  void validate() const;
};

/// A response the application makes (the downloads).
struct HttpResponse {
  int status = 200;
  std::string content_type = "application/octet-stream";
  std::string body;
  std::string filename;  ///< non-empty: Content-Disposition attachment with this name
};

/// Called on the I/O thread for GET /download/<name>; must call `done` exactly once, from any
/// thread (the server posts the response back to its own thread).
using DownloadHandler =
    std::function<void(const std::string& name, std::function<void(HttpResponse)> done)>;

/// Counters since start (read from any thread).
struct ServerStats {
  std::uint64_t connections = 0;   ///< open now (HTTP and WebSocket)
  std::uint64_t clients = 0;       ///< WebSocket clients now
  std::uint64_t accepted = 0;      ///< connections accepted in all
  std::uint64_t refused = 0;       ///< closed at once: max_connections reached
  std::uint64_t requests = 0;      ///< HTTP requests answered
  std::uint64_t bad_requests = 0;  ///< answered 4xx (or closed: malformed, too large, too slow)
  std::uint64_t dropped = 0;       ///< WebSocket clients dropped: send queue overflow
  std::uint64_t ws_errors = 0;     ///< WebSocket sessions ended by a protocol error or a limit
  std::uint64_t coalesced = 0;     ///< queued messages replaced by a newer one of the same key
  std::uint64_t bytes_sent = 0;    ///< WebSocket payload bytes sent
  std::uint64_t frames_sent = 0;   ///< WebSocket messages sent
  std::uint64_t foxglove = 0;      ///< Foxglove clients now (foxglove.websocket.v1)
};

class WebServer {
 public:
  /// Binds `bind`:`port` (port 0: any free one, see port()) and starts the I/O thread. Throws
  /// std::runtime_error naming the address when it cannot listen, std::invalid_argument for a
  /// bad address or limits.
  WebServer(const std::string& bind, std::uint16_t port, ServerLimits limits,
            DownloadHandler downloads);
  /// Stops the I/O thread and closes every connection.
  ~WebServer();
  WebServer(const WebServer&) = delete;
  WebServer& operator=(const WebServer&) = delete;

  std::uint16_t port() const { return port_; }

  // --- from the application thread (posted to the I/O thread; never blocks on a browser) ---
  /// A new map (epoch): drops the held tiles and every browser's waiting ones, then sends
  /// `map_json` (kept for newcomers under key "map").
  void reset_map(std::string map_json);
  /// Tiles that changed: (tile key, encoded frame) each; held as the newest copy of the tile
  /// and queued to every browser (replacing a waiting older copy).
  void send_tiles(std::vector<std::pair<std::string, std::shared_ptr<const std::string>>> tiles);
  /// A JSON state under `key` ("robots", "status", ...): held for newcomers and, with
  /// `broadcast`, queued to every browser (replacing a waiting one of the same key).
  void send_state(const std::string& key, std::string json, bool broadcast);

  /// A message of Foxglove channel `channel` (foxglove.hpp: the map as an OccupancyGrid, the
  /// robots as a PoseArray, in CDR), held for clients that subscribe later and sent to those
  /// subscribed (replacing a waiting copy).
  void send_foxglove(std::uint32_t channel, std::string cdr, std::uint64_t stamp_ns);

  ServerStats stats() const;

  struct Shared;

 private:
  std::shared_ptr<Shared> shared_;
  std::uint16_t port_ = 0;
};

}  // namespace esfleet::view
