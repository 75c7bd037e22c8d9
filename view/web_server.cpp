#include "web_server.hpp"

#include <algorithm>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <map>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <thread>
#include <unordered_map>

#include "foxglove.hpp"
#include "send_queue.hpp"
#include "web_assets.hpp"

namespace esfleet::view {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;

void ServerLimits::validate() const {
  const auto need = [](bool ok, const char* field) {
    if (!ok) throw std::invalid_argument(std::string(field) + " must be > 0");
  };
  need(max_connections > 0, "max_connections");
  need(header_limit > 0, "header_limit");
  need(ws_message_max > 0, "ws_message_max");
  need(client_queue_bytes > 0, "client_queue_bytes");
  need(request_timeout.count() > 0, "request_timeout");
}

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
  /// The newest whole map for Foxglove clients (OccupancyGrid CDR) and its time.
  std::shared_ptr<const std::string> foxglove_map;
  std::uint64_t foxglove_map_stamp_ns = 0;

  struct Counters {
    std::atomic<std::uint64_t> connections{0}, clients{0}, accepted{0}, refused{0}, requests{0},
        bad_requests{0}, dropped{0}, ws_errors{0}, coalesced{0}, bytes_sent{0}, frames_sent{0},
        foxglove{0};
  } counters;

  void accept();
};

namespace {

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

/// The order newcomers get the states in: the map's layout first, the tiles after the trails.
const char* const kStateOrder[] = {"map", "status", "trails"};

}  // namespace

class WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(tcp::socket socket, std::unique_ptr<ConnectionSlot> slot)
      : ws_(std::move(socket)),
        slot_(std::move(slot)),
        queue_(slot_->shared().limits.client_queue_bytes) {}
  ~WsSession() {
    if (registered_) --slot_->shared().counters.clients;
    if (registered_ && foxglove_) --slot_->shared().counters.foxglove;
  }

  void accept(http::request<http::empty_body> req) {
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    // A Foxglove client asks for its subprotocol; the page asks for none.
    const auto offered = req[http::field::sec_websocket_protocol];
    const std::optional<std::string> protocol =
        foxglove_subprotocol(std::string_view(offered.data(), offered.size()));
    foxglove_ = protocol.has_value();
    ws_.set_option(websocket::stream_base::decorator([protocol](websocket::response_type& res) {
      res.set(http::field::server, "esfleet-view");
      if (protocol) res.set(http::field::sec_websocket_protocol, *protocol);
    }));
    ws_.read_message_max(slot_->shared().limits.ws_message_max);
    ws_.async_accept(req, beast::bind_front_handler(&WsSession::on_accept, shared_from_this()));
  }

  /// Queues `m`; drops the browser when its queue overflows. Returns false once dropped.
  bool push(OutMessage m) {
    if (closed_) return false;
    const std::uint64_t before = queue_.coalesced();
    if (!queue_.push(std::move(m))) {
      ++slot_->shared().counters.dropped;
      close();
      return false;
    }
    slot_->shared().counters.coalesced += queue_.coalesced() - before;
    return true;
  }
  void clear_queue() { queue_.clear(); }
  void flush() { do_write(); }
  bool foxglove() const { return foxglove_; }
  /// Queues the whole map for a Foxglove client subscribed to it (replacing a waiting one).
  void push_foxglove_map(const WebServer::Shared& s) {
    if (!foxglove_sub_ || !s.foxglove_map) return;
    push({"fg:map",
          std::make_shared<const std::string>(
              foxglove_message_data(*foxglove_sub_, s.foxglove_map_stamp_ns, *s.foxglove_map)),
          true});
  }

 private:
  void on_accept(beast::error_code ec) {
    if (ec) {
      ++slot_->shared().counters.ws_errors;
      return;
    }
    WebServer::Shared& s = slot_->shared();
    s.sessions[s.next_id++] = weak_from_this();
    registered_ = true;
    ++s.counters.clients;
    if (foxglove_) {
      // Foxglove: who we are and the /map channel; the map once the client subscribes.
      ++s.counters.foxglove;
      push({"", std::make_shared<const std::string>(foxglove_server_info()), false});
      push({"", std::make_shared<const std::string>(foxglove_advertise()), false});
      do_read();
      do_write();
      return;
    }
    // Newcomers: the map's layout and the fleet's state, every tile held, then the robots.
    for (const char* key : kStateOrder) {
      if (auto it = s.states.find(key); it != s.states.end()) push({key, it->second, false});
    }
    for (const auto& [key, frame] : s.tiles) {
      if (!push({key, frame, true})) return;
    }
    for (const auto& [key, json] : s.states) {
      if (std::find(std::begin(kStateOrder), std::end(kStateOrder), key) == std::end(kStateOrder)) {
        push({key, json, false});
      }
    }
    do_read();
    do_write();
  }

  void do_read() {
    ws_.async_read(in_, beast::bind_front_handler(&WsSession::on_read, shared_from_this()));
  }
  void on_read(beast::error_code ec, std::size_t) {
    if (ec) {
      // A closed tab is normal; anything else (too large, malformed, timed out) is counted.
      if (ec != websocket::error::closed && ec != asio::error::operation_aborted &&
          ec != asio::error::eof && ec != asio::error::connection_reset) {
        ++slot_->shared().counters.ws_errors;
      }
      closed_ = true;
      return;
    }
    if (foxglove_ && ws_.got_text()) {
      const std::string text = beast::buffers_to_string(in_.data());
      const FoxgloveRequest r = parse_foxglove_request(text, foxglove_sub_.value_or(~0u));
      if (r.subscribe_map) {
        foxglove_sub_ = r.subscribe_map;
        push_foxglove_map(slot_->shared());
        do_write();
      } else if (r.unsubscribe) {
        foxglove_sub_.reset();
      }
    }
    in_.consume(in_.size());  // the page sends nothing the server needs; read only to answer pings
    do_read();
  }

  void do_write() {
    if (writing_ || closed_ || queue_.empty()) return;
    writing_ = true;
    current_ = queue_.pop();
    ws_.binary(current_.binary);
    ws_.async_write(asio::buffer(*current_.data),
                    beast::bind_front_handler(&WsSession::on_write, shared_from_this()));
  }
  void on_write(beast::error_code ec, std::size_t n) {
    writing_ = false;
    current_ = {};
    if (ec) {
      closed_ = true;
      return;
    }
    slot_->shared().counters.bytes_sent += n;
    ++slot_->shared().counters.frames_sent;
    do_write();
  }

  void close() {
    closed_ = true;
    queue_.clear();
    beast::error_code ignored;
    beast::get_lowest_layer(ws_).socket().shutdown(tcp::socket::shutdown_both, ignored);
    beast::get_lowest_layer(ws_).socket().close(ignored);
  }

  websocket::stream<beast::tcp_stream> ws_;
  std::unique_ptr<ConnectionSlot> slot_;
  beast::flat_buffer in_;
  SendQueue queue_;
  OutMessage current_;
  bool writing_ = false;
  bool closed_ = false;
  bool registered_ = false;
  bool foxglove_ = false;                      ///< a Foxglove client (subprotocol), not the page
  std::optional<std::uint32_t> foxglove_sub_;  ///< its subscription id of the map channel
};

namespace {

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket socket, std::unique_ptr<ConnectionSlot> slot)
      : stream_(std::move(socket)), slot_(std::move(slot)) {}

  void start() { do_read(); }

 private:
  WebServer::Shared& shared() { return slot_->shared(); }

  void do_read() {
    parser_.emplace();
    parser_->header_limit(shared().limits.header_limit);
    parser_->body_limit(shared().limits.body_limit);
    stream_.expires_after(shared().limits.request_timeout);
    http::async_read(stream_, buffer_, *parser_,
                     beast::bind_front_handler(&HttpSession::on_read, shared_from_this()));
  }

  void on_read(beast::error_code ec, std::size_t) {
    if (ec == http::error::end_of_stream || ec == asio::error::eof) return close();
    if (ec == http::error::header_limit || ec == http::error::buffer_overflow) {
      return refuse(http::status::request_header_fields_too_large, "request header too large");
    }
    if (ec == http::error::body_limit) {
      return refuse(http::status::payload_too_large, "request body not accepted");
    }
    if (ec == beast::error::timeout || ec == asio::error::operation_aborted ||
        ec == asio::error::connection_reset) {
      if (ec == beast::error::timeout) ++shared().counters.bad_requests;
      return close();
    }
    if (ec) return refuse(http::status::bad_request, "malformed request");
    http::request<http::empty_body>& req = parser_->get();
    if (websocket::is_upgrade(req)) {
      if (path_of(req.target()) != "/ws") return refuse(http::status::not_found, "no such socket");
      stream_.expires_never();
      std::make_shared<WsSession>(stream_.release_socket(), std::move(slot_))
          ->accept(parser_->release());
      return;
    }
    handle(req);
  }

  static std::string_view path_of(beast::string_view target) {
    std::string_view t(target.data(), target.size());
    return t.substr(0, t.find('?'));
  }

  void handle(const http::request<http::empty_body>& req) {
    ++shared().counters.requests;
    keep_alive_ = req.keep_alive();
    if (req.method() != http::verb::get) {
      return refuse(http::status::method_not_allowed, "only GET");
    }
    const std::string_view path = path_of(req.target());
    if (const WebAsset* a = find_web_asset(path)) {
      HttpResponse r;
      r.content_type = std::string(a->content_type);
      r.body = std::string(a->body);
      return send(std::move(r));
    }
    // The states as JSON for scripts: the server's and map's figures, the map's status, the
    // robots (what the page gets over the WebSocket).
    if (path == "/stats.json" || path == "/status.json" || path == "/robots.json") {
      const auto it = shared().states.find(std::string(path.substr(1, path.size() - 6)));
      HttpResponse r;
      r.content_type = "application/json";
      r.body = it != shared().states.end() ? *it->second : "{}";
      return send(std::move(r));
    }
    constexpr std::string_view kDownload = "/download/";
    if (path.starts_with(kDownload) && shared().downloads) {
      const std::string name(path.substr(kDownload.size()));
      if (name == "map.yaml" || name == "map.pgm" || name == "map.png") {
        auto self = shared_from_this();
        auto executor = stream_.get_executor();
        std::weak_ptr<WebServer::Shared> server = slot_->ptr();
        shared().downloads(name, [self, executor, server](HttpResponse r) {
          const auto s = server.lock();
          if (!s) return;
          std::lock_guard lock(s->post_mutex);
          if (s->stopped) return;
          asio::post(executor, [self, r = std::move(r)]() mutable { self->send(std::move(r)); });
        });
        return;
      }
    }
    refuse(http::status::not_found, "not found");
  }

  void refuse(http::status status, const char* why) {
    ++shared().counters.bad_requests;
    keep_alive_ = false;
    HttpResponse r;
    r.status = static_cast<int>(status);
    r.content_type = "text/plain; charset=utf-8";
    r.body = std::string(why) + "\n";
    send(std::move(r));
  }

  void send(HttpResponse r) {
    auto res = std::make_shared<http::response<http::string_body>>(
        static_cast<http::status>(r.status), 11);
    res->set(http::field::server, "esfleet-view");
    res->set(http::field::content_type, r.content_type);
    res->set(http::field::cache_control, "no-store");
    res->set("X-Content-Type-Options", "nosniff");
    res->set("Content-Security-Policy",
             "default-src 'self'; connect-src 'self' ws: wss:; img-src 'self' data: blob:");
    if (!r.filename.empty()) {
      res->set(http::field::content_disposition, "attachment; filename=\"" + r.filename + "\"");
    }
    res->body() = std::move(r.body);
    res->keep_alive(keep_alive_);
    res->prepare_payload();
    stream_.expires_after(std::chrono::seconds(30));
    http::async_write(stream_, *res,
                      [self = shared_from_this(), res](beast::error_code ec, std::size_t) {
                        if (ec || !res->keep_alive()) return self->close();
                        self->do_read();
                      });
  }

  void close() {
    beast::error_code ignored;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ignored);
    stream_.socket().close(ignored);
  }

  beast::tcp_stream stream_;
  std::unique_ptr<ConnectionSlot> slot_;
  beast::flat_buffer buffer_{65536};
  std::optional<http::request_parser<http::empty_body>> parser_;
  bool keep_alive_ = false;
};

}  // namespace

void WebServer::Shared::accept() {
  acceptor->async_accept([this](beast::error_code ec, tcp::socket socket) {
    if (ec == asio::error::operation_aborted) return;
    if (ec) {
      // Out of file descriptors or similar: try again shortly rather than spin.
      auto timer = std::make_shared<asio::steady_timer>(*ioc, std::chrono::milliseconds(50));
      timer->async_wait([this, timer](beast::error_code) { accept(); });
      return;
    }
    ++counters.accepted;
    if (connections >= limits.max_connections) {
      ++counters.refused;
      beast::error_code ignored;
      socket.close(ignored);
    } else {
      // The slot needs the shared_ptr of this Shared: the sessions keep it alive.
      std::shared_ptr<Shared> self = self_ptr.lock();
      if (self) {
        std::make_shared<HttpSession>(std::move(socket), std::make_unique<ConnectionSlot>(self))
            ->start();
      }
    }
    accept();
  });
}

WebServer::WebServer(const std::string& bind, std::uint16_t port, ServerLimits limits,
                     DownloadHandler downloads)
    : shared_(std::make_shared<Shared>()) {
  limits.validate();
  shared_->limits = limits;
  shared_->downloads = std::move(downloads);
  shared_->self_ptr = shared_;
  beast::error_code ec;
  const asio::ip::address address = asio::ip::make_address(bind, ec);
  if (ec) throw std::invalid_argument("address '" + bind + "': " + ec.message());
  const tcp::endpoint endpoint(address, port);
  const auto where = [&] { return bind + ":" + std::to_string(port); };
  tcp::acceptor& acceptor = shared_->acceptor.emplace(*shared_->ioc);
  acceptor.open(endpoint.protocol(), ec);
  if (!ec) acceptor.set_option(asio::socket_base::reuse_address(true), ec);
  if (!ec) acceptor.bind(endpoint, ec);
  if (!ec) acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) throw std::runtime_error("cannot listen on " + where() + ": " + ec.message());
  port_ = acceptor.local_endpoint().port();
  shared_->accept();
  shared_->thread = std::thread([s = shared_.get()] { s->ioc->run(); });
}

WebServer::~WebServer() {
  {
    std::lock_guard lock(shared_->post_mutex);
    shared_->stopped = true;
  }
  shared_->ioc->stop();
  if (shared_->thread.joinable()) shared_->thread.join();
  beast::error_code ignored;
  shared_->acceptor->close(ignored);
  shared_->acceptor.reset();
  shared_->sessions.clear();
  shared_->ioc.reset();  // destroys the pending handlers and with them the sessions
}

namespace {
/// Runs `f` on the I/O thread with the live sessions; prunes the dead ones.
template <class F>
void for_each_session(WebServer::Shared& s, F&& f) {
  for (auto it = s.sessions.begin(); it != s.sessions.end();) {
    if (auto session = it->second.lock()) {
      f(*session);
      ++it;
    } else {
      it = s.sessions.erase(it);
    }
  }
}
}  // namespace

void WebServer::reset_map(std::string map_json) {
  auto json = std::make_shared<const std::string>(std::move(map_json));
  asio::post(*shared_->ioc, [s = shared_, json] {
    s->tiles.clear();
    s->states["map"] = json;
    for_each_session(*s, [&](WsSession& w) {
      if (w.foxglove()) return;
      w.clear_queue();
      if (w.push({"map", json, false})) w.flush();
    });
  });
}

void WebServer::send_tiles(
    std::vector<std::pair<std::string, std::shared_ptr<const std::string>>> tiles) {
  if (tiles.empty()) return;
  asio::post(*shared_->ioc, [s = shared_, tiles = std::move(tiles)] {
    for (const auto& [key, frame] : tiles) s->tiles[key] = frame;
    for_each_session(*s, [&](WsSession& w) {
      if (w.foxglove()) return;
      for (const auto& [key, frame] : tiles) {
        if (!w.push({key, frame, true})) return;
      }
      w.flush();
    });
  });
}

void WebServer::send_state(const std::string& key, std::string json, bool broadcast) {
  auto data = std::make_shared<const std::string>(std::move(json));
  asio::post(*shared_->ioc, [s = shared_, key, data, broadcast] {
    s->states[key] = data;
    if (!broadcast) return;
    for_each_session(*s, [&](WsSession& w) {
      if (!w.foxglove() && w.push({key, data, false})) w.flush();
    });
  });
}

void WebServer::send_foxglove_map(std::string cdr, std::uint64_t stamp_ns) {
  auto data = std::make_shared<const std::string>(std::move(cdr));
  asio::post(*shared_->ioc, [s = shared_, data, stamp_ns] {
    s->foxglove_map = data;
    s->foxglove_map_stamp_ns = stamp_ns;
    for_each_session(*s, [&](WsSession& w) {
      if (!w.foxglove()) return;
      w.push_foxglove_map(*s);
      w.flush();
    });
  });
}

ServerStats WebServer::stats() const {
  const Shared::Counters& c = shared_->counters;
  return {c.connections.load(), c.clients.load(),      c.accepted.load(),    c.refused.load(),
          c.requests.load(),    c.bad_requests.load(), c.dropped.load(),     c.ws_errors.load(),
          c.coalesced.load(),   c.bytes_sent.load(),   c.frames_sent.load(), c.foxglove.load()};
}

}  // namespace esfleet::view
