// One HTTP connection of the view's server (web_sessions.hpp): a fixed set of GET paths, the
// limits, the upgrade to a WebSocket on /ws.

#include "web_assets.hpp"
#include "web_sessions.hpp"

namespace esfleet::view {

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

void start_http_session(tcp::socket socket, std::unique_ptr<ConnectionSlot> slot) {
  std::make_shared<HttpSession>(std::move(socket), std::move(slot))->start();
}

}  // namespace esfleet::view
