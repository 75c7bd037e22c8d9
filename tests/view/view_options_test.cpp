// esfleet-view's options (view/view_options.hpp): the flags parse into ViewOptions and a bad
// value is refused naming its flag.

#include "view_options.hpp"

#include <gtest/gtest.h>

namespace esfleet::view {
namespace {

ViewOptions parse(std::vector<std::string> args) {
  CLI::App cli;
  ViewOptions o;
  add_view_flags(cli, o);
  std::reverse(args.begin(), args.end());
  cli.parse(args);
  return o;
}

void refused(std::vector<std::string> args, const std::string& flag) {
  const ViewOptions o = parse(std::move(args));
  try {
    o.validate();
    FAIL() << "accepted; expected an error naming " << flag;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(flag), std::string::npos) << e.what();
  }
}

TEST(ViewOptions, Defaults) {
  const ViewOptions o = parse({});
  EXPECT_EQ(o.port, 8080);
  EXPECT_EQ(o.bind, "0.0.0.0");
  EXPECT_EQ(o.limits.max_connections, 256u);
  EXPECT_NO_THROW(o.validate());
}

TEST(ViewOptions, FlagsSetTheFields) {
  const ViewOptions o =
      parse({"--port", "9000", "--bind", "127.0.0.1", "--domain", "7", "--max-connections", "20",
             "--max-header-bytes", "1000", "--client-queue-bytes", "5000", "--timeout", "3"});
  EXPECT_EQ(o.port, 9000);
  EXPECT_EQ(o.bind, "127.0.0.1");
  EXPECT_EQ(o.domain, 7);
  EXPECT_EQ(o.limits.max_connections, 20u);
  EXPECT_EQ(o.limits.header_limit, 1000u);
  EXPECT_EQ(o.limits.client_queue_bytes, 5000u);
  EXPECT_EQ(o.timeout, 3.0);
  EXPECT_NO_THROW(o.validate());
}

TEST(ViewOptions, BadValuesNameTheirFlag) {
  refused({"--port", "70000"}, "--port");
  refused({"--port", "-1"}, "--port");
  refused({"--bind", ""}, "--bind");
  refused({"--robots-period", "0"}, "--robots-period");
  refused({"--max-connections", "0"}, "--max-connections");
  refused({"--client-queue-bytes", "0"}, "--client-queue-bytes");
  refused({"--timeout", "-2"}, "--timeout");
}

}  // namespace
}  // namespace esfleet::view
