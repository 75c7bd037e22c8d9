#include "line_fields.hpp"

#include <cmath>
#include <stdexcept>

namespace esfleet::detail {
namespace {

/// "'<field>' <what>". Built by appending: `"'" + std::string(...)` trips GCC 12's
/// -Wrestrict false positive (GCC bug 105329).
std::string describe(std::string_view field, std::string_view what) {
  std::string s;
  s.reserve(field.size() + what.size() + 3);
  s.append("'").append(field).append("' ").append(what);
  return s;
}

}  // namespace

void split_fields(std::string_view line, std::vector<std::string_view>& fields) {
  fields.clear();
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_field_space(line[i])) ++i;
    const std::size_t start = i;
    while (i < line.size() && !is_field_space(line[i])) ++i;
    if (i > start) fields.push_back(line.substr(start, i - start));
  }
}

std::string line_message(const std::string& file, std::size_t line, const std::string& what) {
  return line == 0 ? file + ": " + what : file + ":" + std::to_string(line) + ": " + what;
}

double finite_field(const std::vector<std::string_view>& fields, std::size_t index,
                    const std::string& file, std::size_t line) {
  const std::string_view field = fields[index];
  double value = 0.0;
  const NumberParse p = parse_number(field, value);
  std::string problem;
  if (p.ec == std::errc::result_out_of_range) {
    problem = describe(field, "is out of range");
  } else if (!p.ok()) {
    problem = describe(field, "is not a number");
  } else if (!std::isfinite(value)) {
    problem = describe(field, "is not finite");
  } else {
    return value;
  }
  throw std::runtime_error(
      line_message(file, line, "field " + std::to_string(index + 1) + ": " + problem));
}

}  // namespace esfleet::detail
