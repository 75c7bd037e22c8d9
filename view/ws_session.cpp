// One WebSocket session of the view's server (web_sessions.hpp).

#include <algorithm>

#include "foxglove.hpp"
#include "web_sessions.hpp"

namespace esfleet::view {

namespace {

/// The order newcomers get the states in: the map's layout first, the tiles after the trails.
const char* const kStateOrder[] = {"map", "status", "trails"};

}  // namespace

WsSession::~WsSession() {
  if (registered_) --slot_->shared().counters.clients;
  if (registered_ && foxglove_) --slot_->shared().counters.foxglove;
}

void WsSession::accept(http::request<http::empty_body> req) {
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

bool WsSession::push(OutMessage m) {
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

void WsSession::push_foxglove(const WebServer::Shared& s, std::uint32_t channel) {
  const auto sub = foxglove_subs_.find(channel);
  const auto latest = s.foxglove_latest.find(channel);
  if (sub == foxglove_subs_.end() || latest == s.foxglove_latest.end()) return;
  push({"fg:" + std::to_string(channel),
        std::make_shared<const std::string>(
            foxglove_message_data(sub->second, latest->second.second, *latest->second.first)),
        true});
}

void WsSession::on_accept(beast::error_code ec) {
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

void WsSession::do_read() {
  ws_.async_read(in_, beast::bind_front_handler(&WsSession::on_read, shared_from_this()));
}

void WsSession::on_read(beast::error_code ec, std::size_t) {
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
    const FoxgloveRequest r = parse_foxglove_request(text);
    for (const auto& [id, channel] : r.subscribe) {
      foxglove_subs_[channel] = id;
      push_foxglove(slot_->shared(), channel);
    }
    for (std::uint32_t id : r.unsubscribe) {
      std::erase_if(foxglove_subs_, [id](const auto& cs) { return cs.second == id; });
    }
    do_write();
  }
  in_.consume(in_.size());  // the page sends nothing the server needs; read only to answer pings
  do_read();
}

void WsSession::do_write() {
  if (writing_ || closed_ || queue_.empty()) return;
  writing_ = true;
  current_ = queue_.pop();
  ws_.binary(current_.binary);
  ws_.async_write(asio::buffer(*current_.data),
                  beast::bind_front_handler(&WsSession::on_write, shared_from_this()));
}

void WsSession::on_write(beast::error_code ec, std::size_t n) {
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

void WsSession::close() {
  closed_ = true;
  queue_.clear();
  beast::error_code ignored;
  beast::get_lowest_layer(ws_).socket().shutdown(tcp::socket::shutdown_both, ignored);
  beast::get_lowest_layer(ws_).socket().close(ignored);
}

}  // namespace esfleet::view
