// The view's server (view/web_server.hpp) against real sockets on loopback: the fixed set of
// GET paths and nothing from the file system, the limits (header, connections, WebSocket
// message size), the whole map for a newcomer, coalescing for a slow browser and dropping one
// that still cannot keep up.

#include "web_server.hpp"

#include <gtest/gtest.h>

#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <thread>

#include "web_assets.hpp"

namespace esfleet::view {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;

/// Everything the server sends back to `request` until it closes the connection (every request
/// here ends with the connection closed: "Connection: close" or a refusal).
std::string raw_exchange(std::uint16_t port, const std::string& request) {
  asio::io_context ioc;
  tcp::socket s(ioc);
  s.connect({asio::ip::make_address("127.0.0.1"), port});
  beast::error_code ec;
  asio::write(s, asio::buffer(request), ec);
  std::string out;
  char buf[4096];
  for (;;) {
    const std::size_t n = s.read_some(asio::buffer(buf), ec);
    if (ec) break;
    out.append(buf, n);
  }
  return out;
}

int status_of(const std::string& response) {
  if (response.size() < 12 || response.rfind("HTTP/1.1 ", 0) != 0) return 0;
  return std::stoi(response.substr(9, 3));
}

template <class Pred>
bool eventually(Pred p, double seconds = 5.0) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < end) {
    if (p()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return p();
}

std::shared_ptr<const std::string> bytes(std::size_t n, char c) {
  return std::make_shared<const std::string>(n, c);
}

struct WsClient {
  asio::io_context ioc;
  websocket::stream<tcp::socket> ws{ioc};
  explicit WsClient(std::uint16_t port, std::size_t receive_buffer = 0) {
    if (receive_buffer > 0) {
      ws.next_layer().open(tcp::v4());
      ws.next_layer().set_option(
          asio::socket_base::receive_buffer_size(static_cast<int>(receive_buffer)));
    }
    ws.next_layer().connect({asio::ip::make_address("127.0.0.1"), port});
    ws.handshake("127.0.0.1", "/ws");
  }
  std::string read() {
    beast::flat_buffer b;
    ws.read(b);
    return beast::buffers_to_string(b.data());
  }
};

TEST(WebServer, ServesTheEmbeddedPageAndOnlyIt) {
  WebServer server("127.0.0.1", 0, {}, nullptr);
  const auto get = [&](const std::string& target) {
    return raw_exchange(server.port(),
                        "GET " + target + " HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  };
  const std::string page = get("/");
  EXPECT_EQ(status_of(page), 200);
  EXPECT_NE(page.find("<canvas id=\"view\">"), std::string::npos);
  EXPECT_NE(page.find("Content-Type: text/html"), std::string::npos);
  EXPECT_EQ(status_of(get("/view.js")), 200);
  EXPECT_EQ(status_of(get("/view.css")), 200);
  EXPECT_EQ(status_of(get("/view.js?x=1")), 200);
  for (const char* bad :
       {"/../../etc/passwd", "/..%2f..%2fetc/passwd", "/etc/passwd", "//etc/passwd", "/web/view.js",
        "/CMakeLists.txt", "*", "http://evil/../../etc/passwd", "/download/../../etc/passwd",
        "/download/map.png"}) {
    const std::string r = get(bad);
    EXPECT_EQ(status_of(r), 404) << bad << "\n" << r;
    EXPECT_EQ(r.find("root:"), std::string::npos) << bad;
  }
  EXPECT_EQ(status_of(raw_exchange(server.port(),
                                   "POST / HTTP/1.1\r\nHost: x\r\nContent-Length: 0\r\n\r\n")),
            405);
  EXPECT_EQ(status_of(raw_exchange(server.port(), "BREW / HTCPCP/1.0\r\n\r\n")), 400);
  EXPECT_EQ(status_of(raw_exchange(server.port(), "\x16\x03\x01\x02\x00\x01\x00\r\n\r\n")), 400);
  // A body where none is accepted.
  EXPECT_EQ(status_of(raw_exchange(server.port(),
                                   "GET / HTTP/1.1\r\nHost: x\r\nContent-Length: 100000\r\n\r\n")),
            413);
  // Keep-alive: two requests on one connection.
  const std::string two = raw_exchange(
      server.port(),
      "GET /view.css HTTP/1.1\r\nHost: x\r\n\r\nGET /view.css HTTP/1.1\r\nHost: x\r\nConnection: "
      "close\r\n\r\n");
  EXPECT_EQ(status_of(two), 200);
  EXPECT_NE(two.find("HTTP/1.1 200", 10), std::string::npos);
}

TEST(WebServer, RefusesOversizedHeaders) {
  ServerLimits limits;
  limits.header_limit = 4096;
  WebServer server("127.0.0.1", 0, limits, nullptr);
  const std::string big =
      "GET / HTTP/1.1\r\nHost: x\r\nX-Big: " + std::string(100000, 'a') + "\r\n\r\n";
  const int status = status_of(raw_exchange(server.port(), big));
  EXPECT_TRUE(status == 431 || status == 0) << status;  // 431, or closed while still sending
  EXPECT_GE(server.stats().bad_requests, 1u);
  EXPECT_EQ(status_of(raw_exchange(server.port(),
                                   "GET / HTTP/1.1\r\nHost: x\r\nConnection: "
                                   "close\r\n\r\n")),
            200);
}

TEST(WebServer, ClosesConnectionsBeyondTheLimit) {
  ServerLimits limits;
  limits.max_connections = 3;
  WebServer server("127.0.0.1", 0, limits, nullptr);
  asio::io_context ioc;
  std::vector<tcp::socket> held;
  for (int i = 0; i < 3; ++i) {
    held.emplace_back(ioc);
    held.back().connect({asio::ip::make_address("127.0.0.1"), server.port()});
  }
  ASSERT_TRUE(eventually([&] { return server.stats().connections == 3; }));
  tcp::socket extra(ioc);
  extra.connect({asio::ip::make_address("127.0.0.1"), server.port()});
  char c;
  beast::error_code ec;
  extra.read_some(asio::buffer(&c, 1), ec);  // closed at once: eof (or reset)
  EXPECT_TRUE(ec == asio::error::eof || ec == asio::error::connection_reset) << ec.message();
  EXPECT_EQ(server.stats().refused, 1u);
  held.clear();
  ASSERT_TRUE(eventually([&] { return server.stats().connections == 0; }));
  EXPECT_EQ(status_of(raw_exchange(server.port(),
                                   "GET / HTTP/1.1\r\nHost: x\r\nConnection: "
                                   "close\r\n\r\n")),
            200);
}

TEST(WebServer, NewcomerGetsLayoutStatesAndEveryTileThenChanges) {
  WebServer server("127.0.0.1", 0, {}, nullptr);
  server.reset_map(R"({"type":"map","epoch":5})");
  server.send_state("status", R"({"type":"status"})", true);
  server.send_tiles({{"t:0,0", bytes(100, 'a')}, {"t:1,0", bytes(100, 'b')}});
  server.send_tiles({{"t:0,0", bytes(100, 'c')}});  // newer copy of (0, 0)
  server.send_state("robots", R"({"type":"robots"})", true);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  WsClient c(server.port());
  EXPECT_EQ(c.read(), R"({"type":"map","epoch":5})");
  EXPECT_EQ(c.read(), R"({"type":"status"})");
  EXPECT_EQ(c.read(), std::string(100, 'c'));
  EXPECT_EQ(c.read(), std::string(100, 'b'));
  EXPECT_EQ(c.read(), R"({"type":"robots"})");
  server.send_tiles({{"t:1,0", bytes(10, 'd')}});
  EXPECT_EQ(c.read(), std::string(10, 'd'));
  // A new epoch: the layout again, and no tile of the old map for the next newcomer.
  server.reset_map(R"({"type":"map","epoch":6})");
  EXPECT_EQ(c.read(), R"({"type":"map","epoch":6})");
  WsClient late(server.port());
  EXPECT_EQ(late.read(), R"({"type":"map","epoch":6})");
  EXPECT_EQ(late.read(), R"({"type":"status"})");
  EXPECT_EQ(late.read(), R"({"type":"robots"})");
  EXPECT_EQ(server.stats().clients, 2u);
}

TEST(WebServer, ClosesAWebSocketThatSendsTooMuch) {
  ServerLimits limits;
  limits.ws_message_max = 1024;
  WebServer server("127.0.0.1", 0, limits, nullptr);
  WsClient c(server.port());
  c.ws.write(asio::buffer(std::string(100, 'x')));  // small: read and ignored
  beast::error_code ec;
  c.ws.write(asio::buffer(std::string(1 << 20, 'x')), ec);
  beast::flat_buffer b;
  c.ws.read(b, ec);
  EXPECT_TRUE(ec) << "the server should have closed the socket";
  if (ec == websocket::error::closed) {
    EXPECT_EQ(c.ws.reason().code, websocket::close_code::too_big);
  }
  ASSERT_TRUE(eventually([&] { return server.stats().clients == 0; }));
  EXPECT_GE(server.stats().ws_errors, 1u);
}

TEST(WebServer, ASlowBrowserGetsCoalescedTiles) {
  ServerLimits limits;
  limits.client_queue_bytes = 200'000;
  WebServer server("127.0.0.1", 0, limits, nullptr);
  WsClient c(server.port(), 4096);  // reads nothing for now
  ASSERT_TRUE(eventually([&] { return server.stats().clients == 1; }));
  // 500 publishes of the same 10 tiles, 10 kB each: 50 MB offered, never more than 10 tiles
  // waiting.
  for (int round = 0; round < 500; ++round) {
    std::vector<std::pair<std::string, std::shared_ptr<const std::string>>> tiles;
    for (int t = 0; t < 10; ++t) {
      tiles.emplace_back("t:" + std::to_string(t) + ",0",
                         bytes(10'000, static_cast<char>('a' + round % 26)));
    }
    server.send_tiles(std::move(tiles));
  }
  ASSERT_TRUE(eventually([&] { return server.stats().coalesced > 1000; }));
  EXPECT_EQ(server.stats().dropped, 0u);
  EXPECT_EQ(server.stats().clients, 1u);
  // It reads at last: the last version of each tile arrives (maybe after some older ones).
  std::size_t last_versions = 0;
  const char last = static_cast<char>('a' + 499 % 26);
  for (int i = 0; i < 5000 && last_versions < 10; ++i) {
    const std::string m = c.read();
    if (m.size() == 10'000 && m[0] == last) ++last_versions;
  }
  EXPECT_EQ(last_versions, 10u);
}

TEST(WebServer, DropsABrowserThatCannotKeepUp) {
  ServerLimits limits;
  limits.client_queue_bytes = 200'000;
  WebServer server("127.0.0.1", 0, limits, nullptr);
  WsClient slow(server.port(), 4096);
  ASSERT_TRUE(eventually([&] { return server.stats().clients == 1; }));
  // 3000 different tiles of 10 kB: nothing to coalesce, 30 MB.
  for (int t = 0; t < 3000; ++t) {
    server.send_tiles({{"t:" + std::to_string(t) + ",1", bytes(10'000, 'x')}});
  }
  ASSERT_TRUE(eventually([&] { return server.stats().dropped == 1; }));
  ASSERT_TRUE(eventually([&] { return server.stats().clients == 0; }));
}

TEST(WebServer, DownloadsComeFromTheHandler) {
  std::thread worker;
  WebServer server("127.0.0.1", 0, {},
                   [&](const std::string& name, std::function<void(HttpResponse)> done) {
                     // Answered later from another thread, as the application does.
                     worker = std::thread([name, done = std::move(done)] {
                       std::this_thread::sleep_for(std::chrono::milliseconds(20));
                       done({200, "text/plain", "file " + name, name});
                     });
                   });
  const std::string r = raw_exchange(
      server.port(), "GET /download/map.yaml HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  worker.join();
  EXPECT_EQ(status_of(r), 200);
  EXPECT_NE(r.find("file map.yaml"), std::string::npos);
  EXPECT_NE(r.find("attachment; filename=\"map.yaml\""), std::string::npos);
}

TEST(WebServer, RefusesABadAddressOrAPortInUse) {
  EXPECT_THROW(WebServer("not-an-address", 0, {}, nullptr), std::invalid_argument);
  WebServer a("127.0.0.1", 0, {}, nullptr);
  try {
    WebServer b("127.0.0.1", a.port(), {}, nullptr);
    FAIL() << "second server on the same port";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot listen on 127.0.0.1:"), std::string::npos);
  }
}

TEST(WebAssets, EveryAssetIsServedAtItsPath) {
  ASSERT_EQ(web_assets().size(), 3u);
  for (const WebAsset& a : web_assets()) {
    EXPECT_EQ(find_web_asset(a.path), &a);
    EXPECT_FALSE(a.body.empty()) << a.path;
  }
  EXPECT_EQ(find_web_asset("/index.html"), nullptr);
}

}  // namespace
}  // namespace esfleet::view
