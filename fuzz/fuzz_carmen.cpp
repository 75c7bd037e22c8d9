// libFuzzer target: the CARMEN log reader over arbitrary text (CarmenReader::from_text, the same
// parser as for files). Every input must end in scans that the rest of the system can use or in
// a LogError naming a line; anything else (a crash, a sanitizer report, another exception, a
// scan breaking the reader's documented contract or one the scan message refuses) is a finding.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "esfleet/core/carmen_reader.hpp"
#include "esfleet/dds/from_msg.hpp"
#include "esfleet/dds/to_msg.hpp"
#include "fuzz_check.hpp"

using esfleet::fuzz::check;

namespace {

void check_scan(const esfleet::LaserScan& s) {
  check(!s.ranges.empty() && s.ranges.size() <= 10000, "beam count in [1, 10000]");
  for (const float r : s.ranges) check(std::isfinite(r) && r >= 0.0f, "ranges finite and >= 0");
  check(std::isfinite(s.stamp), "stamp finite");
  check(std::isfinite(s.angle_min) && std::isfinite(s.angle_increment), "angles finite");
  check(std::isfinite(s.max_range) && s.max_range > 0.0f, "max_range finite and > 0");
  check(s.angle_increment != 0.0f, "angle_increment non-zero");
  // Every scan of a log can be replayed over DDS (esfleet-replay): the leader's side accepts it.
  try {
    esfleet::dds::scan_from_msg(esfleet::dds::scan_to_msg("fuzz", 0, s));
  } catch (const std::invalid_argument&) {
    check(false, "scan_from_msg accepts every scan the reader returns");
  }
  check(s.odometry.has_value(), "odometry present");
  check(std::isfinite(s.odometry->x) && std::isfinite(s.odometry->y) &&
            std::isfinite(s.odometry->theta),
        "odometry finite");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::string text(reinterpret_cast<const char*>(data), size);
  // The low bit of the size picks the even-beam convention, so both code paths are fuzzed.
  esfleet::CarmenReaderOptions options;
  if (size % 2 == 1) options.even_beams = esfleet::EvenBeamConvention::kCentered;
  auto reader = esfleet::CarmenReader::from_text(std::move(text), "fuzz.log", options);
  try {
    while (const auto scan = reader.next_scan()) check_scan(*scan);
  } catch (const esfleet::LogError& e) {
    check(e.file() == "fuzz.log", "LogError names the input");
    check(e.line() >= 1 && e.line() <= reader.line_number() + 1, "LogError names a line read");
  }
  return 0;
}
