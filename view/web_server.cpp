#include "web_server.hpp"

#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <stdexcept>

#include "web_sessions.hpp"

namespace esfleet::view {

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
        start_http_session(std::move(socket), std::make_unique<ConnectionSlot>(self));
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

void WebServer::send_foxglove(std::uint32_t channel, std::string cdr, std::uint64_t stamp_ns) {
  auto data = std::make_shared<const std::string>(std::move(cdr));
  asio::post(*shared_->ioc, [s = shared_, channel, data, stamp_ns] {
    s->foxglove_latest[channel] = {data, stamp_ns};
    for_each_session(*s, [&](WsSession& w) {
      if (!w.foxglove()) return;
      w.push_foxglove(*s, channel);
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
