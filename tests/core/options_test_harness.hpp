#pragma once
// The options tests' harness (leader, follower): a command line parsed as the program's main()
// parses it, then the options finished and checked, all before any DDS participant exists.

#include <exception>
#include <optional>
#include <string>
#include <vector>

#include "app/param_table.hpp"
#include "app/program.hpp"

namespace esfleet::testing {

/// Parses `args` (without the program name) for program `name` (its logger `logger`):
/// `add(cli, options, params)` registers the flags, `finish(options, params)` finishes them.
/// Returns the error message ("" when the options are valid, "parse error" when the command
/// line itself was refused, with its exit code in `*parse_code`); `*out` gets the options.
template <typename Options, typename Add, typename Finish>
std::string options_error(const std::string& name, const std::string& logger,
                          std::vector<std::string> args, Add add, Finish finish,
                          Options* out = nullptr, std::optional<int>* parse_code = nullptr) {
  app::Program program(name, logger, "test");
  Options o;
  app::ParamTable params;
  add(program.cli(), o, params);
  args.insert(args.begin(), name);
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  const std::optional<int> code = program.parse(static_cast<int>(argv.size()), argv.data());
  if (parse_code != nullptr) *parse_code = code;
  if (code) return "parse error";
  try {
    finish(o, params);
  } catch (const std::exception& e) {
    return e.what();
  }
  if (out != nullptr) *out = o;
  return "";
}

inline bool contains(const std::string& s, const std::string& part) {
  return s.find(part) != std::string::npos;
}

}  // namespace esfleet::testing
