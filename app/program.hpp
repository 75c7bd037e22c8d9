#pragma once
// What every esfleet program does before and around its work, written once: the stderr logger,
// the command line with --help and --version, one set of exit codes (listed in every --help),
// the stop flag that SIGINT and SIGTERM set, and the mapping of errors to exit codes.
//
// A main() reads:
//   app::Program program("esfleet-leader", "leader", "what it does ...");
//   LeaderOptions o;  add_leader_flags(program.cli(), o);
//   if (auto code = program.parse(argc, argv)) return *code;
//   return program.run([&] { LeaderApp app(o, program.stop_flag()); return app.run(); });

#include <atomic>
#include <functional>
#include <optional>
#include <stdexcept>
#include <string>

#include <CLI/CLI.hpp>

namespace esfleet::app {

/// Exit codes of every program.
enum ExitCode : int {
  kExitOk = 0,             ///< done
  kExitFailure = 1,        ///< a failure while running (e.g. the results could not be written)
  kExitUsage = 2,          ///< bad usage or bad input: a flag, a file, a DDS profile
  kExitTimeout = 3,        ///< --timeout reached before the work was done (where offered)
  kExitInterrupted = 130,  ///< stopped by SIGINT or SIGTERM (outputs saved)
};

/// Bad usage or bad input found while starting (a flag, an input file, the DDS set-up): the
/// program exits with kExitUsage. The message names the flag, file, line or field.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Runs one set-up step of a program (reading an input, creating the DDS participant, ...); an
/// exception escaping `body` becomes a UsageError "<what>: <cause>" (the cause alone when
/// `what` is empty), so the program exits 2 naming the step.
void setup_step(const std::string& what, const std::function<void()>& body);

/// "<flag> <value>: <cause>", or "<flag> <cause>" when the cause already starts with the value
/// (a message that names the file itself): an error naming the flag and the input once.
std::string name_flag(const std::string& flag, const std::string& value, const std::string& cause);

/// The esfleet version ("0.1.0").
const char* version();

class Program {
 public:
  /// `name` is the executable ("esfleet-leader"), `logger` the short name in log lines,
  /// `description` the first paragraph of --help. `exit_codes` lists the codes this program
  /// uses beyond 0, 1 and 2 (e.g. "130 stopped by SIGINT/SIGTERM"), for --help.
  Program(std::string name, std::string logger, std::string description,
          std::string exit_codes = "");

  CLI::App& cli() { return cli_; }
  /// Parses the command line. Returns the code to exit with now: 0 after --help or --version,
  /// kExitUsage after a parse error (printed to stderr with a pointer to --help); std::nullopt
  /// when the program should go on.
  std::optional<int> parse(int argc, char** argv);
  /// Installs the SIGINT/SIGTERM handlers (the first call) and returns the flag they set.
  static const std::atomic<bool>& stop_flag();
  /// Runs `body` and returns its exit code; an exception escaping it is logged and becomes
  /// kExitUsage (UsageError, std::invalid_argument) or kExitFailure (anything else).
  int run(const std::function<int()>& body) const;

 private:
  std::string name_;
  CLI::App cli_;
};

}  // namespace esfleet::app
