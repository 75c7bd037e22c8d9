#pragma once
// Private to core: what the text line readers (carmen_reader.cpp, relations.cpp,
// trajectory_io.cpp) share: splitting a line into whitespace-separated fields, reading a field
// as a number, and messages that name the file, the line and the field.

#include <array>
#include <cerrno>
#include <charconv>
#include <cstddef>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

namespace esfleet::detail {

/// Characters that separate fields: blanks, not the newline that ends a line.
constexpr bool is_field_space(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

/// Splits `line` at runs of field spaces into `fields` (cleared first; views into `line`).
void split_fields(std::string_view line, std::vector<std::string_view>& fields);

/// "<file>:<line>: <what>", or "<file>: <what>" when `line` is 0 (the file as a whole).
std::string line_message(const std::string& file, std::size_t line, const std::string& what);

/// How std::from_chars read a field as a number.
struct NumberParse {
  std::errc ec = std::errc();  ///< from_chars' verdict (result_out_of_range: too large/small)
  bool whole = false;          ///< the number it read ends where the field ends
  bool ok() const { return ec == std::errc() && whole; }
};

/// Reads `field` as a number of type T (std::from_chars: no leading '+' or spaces).
template <typename T>
NumberParse parse_number(std::string_view field, T& value) {
  const char* end = field.data() + field.size();
  const auto [ptr, ec] = std::from_chars(field.data(), end, value);
  return {ec, ptr == end};
}

/// Field `index` (0-based) of `fields` as a finite double. Throws std::runtime_error
/// "<file>:<line>: field <index + 1>: '<field>' is not a number" (also for characters after
/// the number), "... is out of range" or "... is not finite".
double finite_field(const std::vector<std::string_view>& fields, std::size_t index,
                    const std::string& file, std::size_t line);

/// Reads the text file `path` whose lines are rows of exactly N finite numbers ('#' comment
/// lines and blank lines are skipped) and calls `row(values)` for each. `kind` names the file in
/// messages ("relations", "trajectory") and `columns` lists the fields ("t x y theta"). Throws
/// std::runtime_error: "cannot open <kind> '<path>': <reason>", "<path>:<line>: expected N
/// fields (<columns>), got M", finite_field's messages, "cannot read <kind> '<path>': read
/// error".
template <std::size_t N, typename Row>
void read_number_rows(const std::string& path, const char* kind, const char* columns, Row&& row) {
  errno = 0;
  std::ifstream in(path);
  if (!in) {
    throw std::runtime_error(std::string("cannot open ") + kind + " '" + path +
                             "': " + (errno != 0 ? std::strerror(errno) : "unknown error"));
  }
  std::string line;
  std::size_t line_no = 0;
  std::vector<std::string_view> fields;
  while (std::getline(in, line)) {
    ++line_no;
    split_fields(line, fields);
    if (fields.empty() || fields[0].front() == '#') continue;
    if (fields.size() != N) {
      throw std::runtime_error(line_message(path, line_no,
                                            "expected " + std::to_string(N) + " fields (" +
                                                columns + "), got " +
                                                std::to_string(fields.size())));
    }
    std::array<double, N> v{};
    for (std::size_t i = 0; i < N; ++i) v[i] = finite_field(fields, i, path, line_no);
    row(v);
  }
  if (in.bad()) {
    throw std::runtime_error(std::string("cannot read ") + kind + " '" + path + "': read error");
  }
}

}  // namespace esfleet::detail
