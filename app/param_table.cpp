#include "app/param_table.hpp"

#include "app/program.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace esfleet::app {

namespace {

std::string dashed(std::string s) {
  std::replace(s.begin(), s.end(), '_', '-');
  return s;
}

std::string trimmed(const std::string& s) {
  const auto b = s.find_first_not_of(" \t");
  const auto e = s.find_last_not_of(" \t");
  return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
}

double parse_double(const std::string& text) {
  const std::string t = trimmed(text);
  double v = 0.0;
  const auto [ptr, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
  if (ec != std::errc() || ptr != t.data() + t.size() || t.empty() || !std::isfinite(v)) {
    throw std::invalid_argument("expected a finite number, got '" + text + "'");
  }
  return v;
}

template <typename Int>
Int parse_int(const std::string& text) {
  const std::string t = trimmed(text);
  Int v = 0;
  const auto [ptr, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
  if (ec != std::errc() || ptr != t.data() + t.size() || t.empty()) {
    throw std::invalid_argument("expected an integer, got '" + text + "'");
  }
  return v;
}

std::string show_double(double v) {
  std::ostringstream os;
  os.precision(10);
  os << v;
  return os.str();
}

/// The shortest text that reads back as the float `v` ("81.9", not "81.90000153").
std::string show_float(float v) {
  char buf[32];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);
  return ec == std::errc() ? std::string(buf, end) : show_double(v);
}

}  // namespace

void ParamTable::add(std::string name, std::string type, std::string help,
                     std::function<void(const std::string&)> set,
                     std::function<std::string()> get) {
  Param p;
  p.name = std::move(name);
  p.type = std::move(type);
  p.help = std::move(help);
  p.set = std::move(set);
  p.get = std::move(get);
  params_.push_back(std::move(p));
}

ParamTable::Param* ParamTable::find(const std::string& name) {
  return const_cast<Param*>(std::as_const(*this).find(name));
}

const ParamTable::Param* ParamTable::find(const std::string& name) const {
  for (const Param& p : params_)
    if (p.name == name) return &p;
  return nullptr;
}

void ParamTable::add_double(const std::string& name, double* field, const std::string& help) {
  add(
      name, "FLOAT", help, [field](const std::string& s) { *field = parse_double(s); },
      [field] { return show_double(*field); });
}

void ParamTable::add_float(const std::string& name, float* field, const std::string& help) {
  add(
      name, "FLOAT", help,
      [field](const std::string& s) { *field = static_cast<float>(parse_double(s)); },
      [field] { return show_float(*field); });
}

void ParamTable::add_int(const std::string& name, int* field, const std::string& help) {
  add(
      name, "INT", help, [field](const std::string& s) { *field = parse_int<int>(s); },
      [field] { return std::to_string(*field); });
}

void ParamTable::add_u64(const std::string& name, std::uint64_t* field, const std::string& help) {
  add(
      name, "UINT", help, [field](const std::string& s) { *field = parse_int<std::uint64_t>(s); },
      [field] { return std::to_string(*field); });
}

void ParamTable::add_switch(const std::string& name, bool* field, const std::string& help) {
  add(
      name, "on|off", help,
      [field](const std::string& s) {
        const std::string t = trimmed(s);
        if (t == "on" || t == "true" || t == "yes" || t == "1") {
          *field = true;
        } else if (t == "off" || t == "false" || t == "no" || t == "0") {
          *field = false;
        } else {
          throw std::invalid_argument("expected on or off, got '" + s + "'");
        }
      },
      [field] { return std::string(*field ? "on" : "off"); });
}

void ParamTable::add_choice(const std::string& name, std::vector<std::string> choices,
                            std::function<void(const std::string&)> set,
                            std::function<std::string()> get, const std::string& help) {
  std::string list;
  for (const auto& c : choices) list += (list.empty() ? "" : "|") + c;
  add(
      name, list, help,
      [choices, set, list](const std::string& s) {
        const std::string t = trimmed(s);
        if (std::find(choices.begin(), choices.end(), t) == choices.end()) {
          throw std::invalid_argument("expected one of " + list + ", got '" + s + "'");
        }
        set(t);
      },
      std::move(get));
}

void ParamTable::bind(CLI::App& app, const std::string& group) {
  app.add_option("--config", config_path_,
                 "YAML file of parameters (keys as the flags below, with '_' for '-'); flags on "
                 "the command line override it")
      ->check(CLI::ExistingFile)
      ->group(group);
  for (Param& p : params_) {
    p.at_bind = p.get();
    p.option = app.add_option("--" + dashed(p.name), p.cli_value, p.help)
                   ->type_name(p.type)
                   ->default_str(p.get())
                   ->group(p.unused.empty() ? group : std::string());  // "": hidden
  }
}

void ParamTable::apply() {
  if (!config_path_.empty()) load_yaml(config_path_);
  for (Param& p : params_) {
    if (p.option == nullptr || p.option->count() == 0) continue;
    if (!p.unused.empty()) throw UsageError("--" + dashed(p.name) + ": " + p.unused);
    try {
      p.set(p.cli_value);
    } catch (const std::invalid_argument& e) {
      throw UsageError("--" + dashed(p.name) + ": " + e.what());
    }
    p.given = true;
  }
}

void ParamTable::load_yaml(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw UsageError(path + ": cannot open");
  } catch (const YAML::Exception& e) {
    throw UsageError(path + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  if (root.IsNull()) return;  // an empty file sets nothing
  if (!root.IsMap()) throw UsageError(path + ": top level must be a map of parameters");
  for (const auto& kv : root) {
    const auto line = std::to_string(kv.first.Mark().line + 1);
    const std::string key = kv.first.as<std::string>();
    Param* p = find(key);
    if (p == nullptr) {
      throw UsageError(path + ":" + line + ": unknown parameter '" + key + "'");
    }
    if (!kv.second.IsScalar()) {
      throw UsageError(path + ":" + line + ": '" + key + "' must be a single value");
    }
    try {
      p->set(kv.second.Scalar());
    } catch (const std::invalid_argument& e) {
      throw UsageError(path + ":" + line + ": '" + key + "': " + e.what());
    }
    p->given = true;
  }
}

std::vector<std::pair<std::string, std::string>> ParamTable::values() const {
  std::vector<std::pair<std::string, std::string>> out;
  for (const Param& p : params_) out.emplace_back(p.name, p.get());
  return out;
}

std::vector<std::pair<std::string, std::string>> ParamTable::changed() const {
  std::vector<std::pair<std::string, std::string>> out;
  for (const Param& p : params_) {
    if (std::string now = p.get(); now != p.at_bind) out.emplace_back(p.name, std::move(now));
  }
  return out;
}

std::string ParamTable::describe_changes() const {
  // Parameters this program does not use (not_used()) but a shared --config file set are listed
  // apart: they changed nothing here.
  std::string used, unused;
  std::size_t n_used = 0;
  for (const auto& [name, now] : changed()) {
    const bool is_used = find(name)->unused.empty();
    std::string& into = is_used ? used : unused;
    into += (into.empty() ? " " : ", ") + name + " = " + now;
    n_used += is_used ? 1 : 0;
  }
  std::string out = n_used == 0 ? "all defaults" : std::to_string(n_used) + " changed:" + used;
  if (!unused.empty()) out += "; ignored (not used by this program):" + unused;
  return out;
}

void ParamTable::not_used(const std::function<bool(const std::string&)>& which,
                          const std::string& why) {
  for (Param& p : params_) {
    if (which(p.name)) p.unused = why;
  }
}

bool ParamTable::given(const std::string& name) const {
  const Param* p = find(name);
  return p != nullptr && p->given;
}

void ParamTable::set(const std::string& name, const std::string& value) {
  Param* p = find(name);
  if (p == nullptr) throw std::invalid_argument("unknown parameter '" + name + "'");
  p->set(value);
}

}  // namespace esfleet::app
