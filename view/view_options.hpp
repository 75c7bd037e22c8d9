#pragma once
// esfleet-view's command line: where it listens, which DDS domain it reads, and the server's
// limits (ViewOptions), its checks (validate) and the flags that set it (add_view_flags), apart
// from main() so that a test can parse an argv into it.

#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>

#include "web_server.hpp"

namespace esfleet::view {

struct ViewOptions {
  // --- the web side ---
  std::string bind = "0.0.0.0";  ///< address to listen on (0.0.0.0: every interface)
  int port = 8080;               ///< TCP port, [0, 65535]; 0 = any free one (logged)
  ServerLimits limits;           ///< connections, header, message and queue sizes
  double robots_period = 0.2;    ///< seconds between robot updates to the browsers, > 0

  // --- the DDS side (read only) ---
  int domain = 0;
  std::string profile;          ///< Fast DDS XML profile; empty = Fast DDS defaults
  std::string secure;           ///< DDS Security directory of the view's identity; empty = off
  std::string map_id;           ///< map to show; empty = the first one seen
  double leader_timeout = 5.0;  ///< leader gone after this long without a summary while mapping
  double timeout = 0.0;         ///< stop after this many seconds; 0 = no limit

  /// Throws std::invalid_argument naming the flag.
  void validate() const;
};

/// Registers esfleet-view's flags on `cli`, bound to `o` (its values are the defaults shown).
void add_view_flags(CLI::App& cli, ViewOptions& o);

}  // namespace esfleet::view
