#pragma once
// One table of named parameters shared by the command line and YAML config files, so every
// parameter has exactly one name, one help text and one parser. Precedence: defaults (the
// config structs' in-class values), then the YAML file (--config), then flags given on the
// command line. Unknown YAML keys and unparsable values are errors naming the file, line and key.

#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

namespace esfleet::app {

class ParamTable {
 public:
  void add_double(const std::string& name, double* field, const std::string& help);
  void add_float(const std::string& name, float* field, const std::string& help);
  void add_int(const std::string& name, int* field, const std::string& help);
  void add_u64(const std::string& name, std::uint64_t* field, const std::string& help);
  /// on|off (also true|false, yes|no, 1|0).
  void add_switch(const std::string& name, bool* field, const std::string& help);
  /// One of `choices` (the setter receives a validated choice; the getter shows the current one).
  void add_choice(const std::string& name, std::vector<std::string> choices,
                  std::function<void(const std::string&)> set, std::function<std::string()> get,
                  const std::string& help);
  /// One of the names in `names`, stored in `*field` as the value paired with it (one table
  /// for both directions; every value `*field` can hold must be listed).
  template <typename E>
  void add_enum(const std::string& name, E* field, std::vector<std::pair<std::string, E>> names,
                const std::string& help) {
    std::vector<std::string> choices;
    for (const auto& n : names) choices.push_back(n.first);
    add_choice(
        name, std::move(choices),
        [field, names](const std::string& v) {
          for (const auto& [text, value] : names) {
            if (text == v) *field = value;
          }
        },
        [field, names] {
          for (const auto& [text, value] : names) {
            if (value == *field) return text;
          }
          return std::string("?");
        },
        help);
  }

  /// Parameters this program takes but does not use (a config file shared with another
  /// program may hold them): hidden from --help; a flag for one is a UsageError saying `why`;
  /// in the --config file they are accepted. Call before bind().
  void not_used(const std::function<bool(const std::string&)>& which, const std::string& why);
  /// Registers `--name-with-dashes` for every parameter (in option group `group`) and
  /// `--config FILE`.
  void bind(CLI::App& app, const std::string& group = "Parameters");
  /// After CLI parsing: loads --config (if given) then applies the flags given on the command
  /// line. Throws UsageError (app/program.hpp) with a precise message.
  void apply();
  /// Loads a YAML file whose top level is a map of parameter names (snake_case) to values.
  void load_yaml(const std::string& path);
  /// name -> current value as text, for logs and stats.json.
  std::vector<std::pair<std::string, std::string>> values() const;
  /// The parameters whose value differs from the one they had at bind() (the in-class
  /// defaults), name -> current value.
  std::vector<std::pair<std::string, std::string>> changed() const;
  /// One log line's worth: "all defaults", or "N changed: a = 1, b = on"; parameters set
  /// (by a --config file) that this program does not use (not_used()) follow as
  /// "; ignored (not used by this program): c = off".
  std::string describe_changes() const;
  /// After apply(): whether `name` was set by a flag on the command line or by the --config file.
  bool given(const std::string& name) const;
  /// Sets parameter `name` from text as a flag would. Throws std::invalid_argument for an
  /// unknown name or a value its parser refuses.
  void set(const std::string& name, const std::string& value);

 private:
  struct Param {
    std::string name;
    std::string type;
    std::string help;
    std::function<void(const std::string&)> set;  // throws std::invalid_argument
    std::function<std::string()> get;
    std::string cli_value;
    std::string at_bind;  ///< the value at bind()
    bool given = false;   ///< set by --config or a flag
    std::string unused;   ///< not_used(): why a flag for it is refused ("" = used)
    CLI::Option* option = nullptr;
  };
  /// `type` is what --help shows for the value (FLOAT, INT, on|off, ...).
  void add(std::string name, std::string type, std::string help,
           std::function<void(const std::string&)> set, std::function<std::string()> get);
  Param* find(const std::string& name);
  const Param* find(const std::string& name) const;

  std::vector<Param> params_;
  std::string config_path_;
};

}  // namespace esfleet::app
