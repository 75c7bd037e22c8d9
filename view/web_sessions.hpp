#pragma once
// The web server's insides, shared by web_server.cpp (the server, its accept loop and what the
// application posts), ws_session.cpp (one browser's or Foxglove client's WebSocket) and
// http_session.cpp (one HTTP connection: the page, JSON, downloads, the upgrade to a
// WebSocket). Everything here runs on the server's one I/O thread, except the atomic counters.

#include <atomic>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "send_queue.hpp"
#include "web_server.hpp"

namespace esfleet::view {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;

class WsSession;

/// What the sessions and the server share; touched only on the I/O thread, except the atomic
/// counters.
struct WebServer::Shared {
  ServerLimits limits;
  DownloadHandler downloads;
  /// Held by pointer so that ~WebServer can destroy it (and the handlers it holds, which hold
  /// the sessions) while the rest of Shared is alive.
  std::unique_ptr<asio::io_context> ioc = std::make_unique<asio::io_context>(1);
  std::optional<tcp::acceptor> acceptor;
  std::thread thread;
  std::weak_ptr<Shared> self_ptr;
  /// Set (under post_mutex) when the server stops: a download finished later posts nothing.
  std::mutex post_mutex;
  bool stopped = false;

  // I/O thread only.
  std::size_t connections = 0;
  std::uint64_t next_id = 0;
  std::map<std::uint64_t, std::weak_ptr<WsSession>> sessions;
  std::map<std::string, std::shared_ptr<const std::string>> tiles;  ///< newest frame per tile
  /// States for newcomers, in the order they are sent ("map" first).
  std::map<std::string, std::shared_ptr<const std::string>> states;
  /// For Foxglove clients, per channel: the newest message (CDR) and its time.
  std::map<std::uint32_t, std::pair<std::shared_ptr<const std::string>, std::uint64_t>>
      foxglove_latest;

  struct Counters {
    std::atomic<std::uint64_t> connections{0}, clients{0}, accepted{0}, refused{0}, requests{0},
        bad_requests{0}, dropped{0}, ws_errors{0}, coalesced{0}, bytes_sent{0}, frames_sent{0},
        foxglove{0};
  } counters;

  void accept();
};

/// Counts one open connection for as long as it lives.
class ConnectionSlot {
 public:
  explicit ConnectionSlot(std::shared_ptr<WebServer::Shared> s) : s_(std::move(s)) {
    ++s_->connections;
    ++s_->counters.connections;
  }
  ~ConnectionSlot() {
    --s_->connections;
    --s_->counters.connections;
  }
  ConnectionSlot(const ConnectionSlot&) = delete;
  ConnectionSlot& operator=(const ConnectionSlot&) = delete;
  WebServer::Shared& shared() const { return *s_; }
  const std::shared_ptr<WebServer::Shared>& ptr() const { return s_; }

 private:
  std::shared_ptr<WebServer::Shared> s_;
};

/// One WebSocket: the page's protocol, or Foxglove's when the client asks for it (foxglove.hpp).
/// Its SendQueue holds what waits for the client; it is dropped when that would overflow.
class WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(tcp::socket socket, std::unique_ptr<ConnectionSlot> slot)
      : ws_(std::move(socket)),
        slot_(std::move(slot)),
        queue_(slot_->shared().limits.client_queue_bytes) {}
  ~WsSession();

  void accept(http::request<http::empty_body> req);

  /// Queues `m`; drops the browser when its queue overflows. Returns false once dropped.
  bool push(OutMessage m);
  void clear_queue() { queue_.clear(); }
  void flush() { do_write(); }
  bool foxglove() const { return foxglove_; }
  /// Queues the newest message of `channel` for a Foxglove client subscribed to it (replacing
  /// a waiting one of the channel).
  void push_foxglove(const WebServer::Shared& s, std::uint32_t channel);

 private:
  void on_accept(beast::error_code ec);

  void do_read();
  void on_read(beast::error_code ec, std::size_t);

  void do_write();
  void on_write(beast::error_code ec, std::size_t n);

  void close();

  websocket::stream<beast::tcp_stream> ws_;
  std::unique_ptr<ConnectionSlot> slot_;
  beast::flat_buffer in_;
  SendQueue queue_;
  OutMessage current_;
  bool writing_ = false;
  bool closed_ = false;
  bool registered_ = false;
  bool foxglove_ = false;  ///< a Foxglove client (subprotocol), not the page
  std::map<std::uint32_t, std::uint32_t> foxglove_subs_;  ///< channel -> subscription id
};

/// Serves HTTP on an accepted connection (http_session.cpp); upgrades to a WsSession on /ws.
void start_http_session(tcp::socket socket, std::unique_ptr<ConnectionSlot> slot);

}  // namespace esfleet::view
