#include "app/program.hpp"

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <csignal>

#include "app/version.hpp"

namespace esfleet::app {

namespace {
std::atomic<bool> g_stop{false};
extern "C" void on_stop_signal(int) { g_stop.store(true); }

std::string footer(const std::string& extra) {
  return "Exit codes: 0 done, 1 failure while running, 2 bad usage or bad input" +
         (extra.empty() ? std::string() : ", " + extra) + ".";
}
}  // namespace

const char* version() { return kVersion; }

void setup_step(const std::string& what, const std::function<void()>& body) {
  try {
    body();
  } catch (const std::exception& e) {
    throw UsageError(what.empty() ? e.what() : what + ": " + e.what());
  }
}

std::string name_flag(const std::string& flag, const std::string& value, const std::string& cause) {
  return flag + " " + (cause.rfind(value, 0) == 0 ? cause : value + ": " + cause);
}

Program::Program(std::string name, std::string logger, std::string description,
                 std::string exit_codes)
    : name_(std::move(name)), cli_(std::move(description), name_) {
  // Not registered by name: a second Program in one process (tests) replaces the first.
  spdlog::set_default_logger(std::make_shared<spdlog::logger>(
      std::move(logger), std::make_shared<spdlog::sinks::stderr_color_sink_st>()));
  spdlog::set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");
  cli_.set_version_flag("--version", name_ + " " + kVersion);
  cli_.add_option_function<std::string>(
          "--log-level",
          [](const std::string& level) { spdlog::set_level(spdlog::level::from_str(level)); },
          "log lines at this level and above go to stderr")
      ->check(CLI::IsMember({"debug", "info", "warn", "error"}).description(""))
      ->type_name("debug|info|warn|error")
      ->default_str("info");
  cli_.footer(footer(exit_codes));
}

std::optional<int> Program::parse(int argc, char** argv) {
  try {
    cli_.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return cli_.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return cli_.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return cli_.exit(e);
  } catch (const CLI::ParseError& e) {
    spdlog::error("{} (run {} --help for usage)", e.what(), name_);
    return kExitUsage;
  }
  return std::nullopt;
}

const std::atomic<bool>& Program::stop_flag() {
  static const bool installed = [] {
    std::signal(SIGINT, on_stop_signal);
    std::signal(SIGTERM, on_stop_signal);
    return true;
  }();
  (void)installed;
  return g_stop;
}

int Program::run(const std::function<int()>& body) const {
  try {
    return body();
  } catch (const UsageError& e) {
    spdlog::error("{}", e.what());
    return kExitUsage;
  } catch (const std::invalid_argument& e) {
    spdlog::error("{}", e.what());
    return kExitUsage;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return kExitFailure;
  }
}

}  // namespace esfleet::app
