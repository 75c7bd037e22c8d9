#include "view_options.hpp"

#include <stdexcept>

#include "app/dds_flags.hpp"

namespace esfleet::view {

void ViewOptions::validate() const {
  if (port < 0 || port > 65535) {
    throw std::invalid_argument("--port " + std::to_string(port) + ": not in [0, 65535]");
  }
  if (bind.empty()) throw std::invalid_argument("--bind: empty address");
  if (!(robots_period > 0.0 && robots_period <= 60.0)) {
    throw std::invalid_argument("--robots-period " + std::to_string(robots_period) +
                                ": not in (0, 60] s");
  }
  if (!(leader_timeout >= 0.0)) {
    throw std::invalid_argument("--leader-timeout " + std::to_string(leader_timeout) +
                                ": must be >= 0");
  }
  if (!(timeout >= 0.0)) {
    throw std::invalid_argument("--timeout " + std::to_string(timeout) + ": must be >= 0");
  }
  const auto positive = [](std::uint64_t v, const char* flag) {
    if (v == 0) throw std::invalid_argument(std::string(flag) + " must be > 0");
  };
  positive(limits.max_connections, "--max-connections");
  positive(limits.header_limit, "--max-header-bytes");
  positive(limits.ws_message_max, "--max-message-bytes");
  positive(limits.client_queue_bytes, "--client-queue-bytes");
}

void add_view_flags(CLI::App& cli, ViewOptions& o) {
  app::add_dds_flags(cli, o.domain, o.profile, o.secure);
  cli.add_option("--port", o.port, "TCP port of the page (0 = any free one, logged)")
      ->capture_default_str();
  cli.add_option("--bind", o.bind, "address to listen on (0.0.0.0 = every interface)")
      ->capture_default_str();
  cli.add_option("--map-id", o.map_id, "map to show (default: the first one seen)");
  cli.add_option("--leader-timeout", o.leader_timeout,
                 "show the leader gone when no map summary came for S seconds while it was "
                 "mapping (0 = only when DDS reports its writers gone)")
      ->capture_default_str();
  cli.add_option("--timeout", o.timeout, "stop after this many seconds (0 = no limit)")
      ->capture_default_str();
  cli.add_option("--robots-period", o.robots_period,
                 "seconds between robot updates sent to the browsers")
      ->capture_default_str();
  cli.add_option("--max-connections", o.limits.max_connections,
                 "concurrent HTTP and WebSocket connections; more are closed at once")
      ->capture_default_str();
  cli.add_option("--max-header-bytes", o.limits.header_limit,
                 "largest request line and headers; larger requests get 431")
      ->capture_default_str();
  cli.add_option("--max-message-bytes", o.limits.ws_message_max,
                 "largest WebSocket message a browser may send; larger ones close it (1009)")
      ->capture_default_str();
  cli.add_option("--client-queue-bytes", o.limits.client_queue_bytes,
                 "bytes that may wait for one browser (tiles coalesce, newest wins); a browser "
                 "that would need more is dropped")
      ->capture_default_str();
}

}  // namespace esfleet::view
