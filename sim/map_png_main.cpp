// esfleet-map-png: converts a map image (e.g. the leader's map.pgm) to a lossless 8-bit grey
// PNG, pixel for pixel, and checks that the PNG reads back identical. Used to make the worlds
// in data/worlds/ (data/worlds/README.md); the YAML is copied with its `image:` line changed.
//
// usage: esfleet-map-png IN.pgm OUT.png    exit 0 ok, 2 error (message names the file)

#include <cstdio>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "app/program.hpp"

namespace {

using esfleet::app::UsageError;

constexpr const char* kDescription =
    "esfleet-map-png: converts a map image (e.g. the leader's map.pgm) to a lossless 8-bit grey "
    "PNG, pixel for pixel, and checks that the PNG reads back identical (data/worlds/README.md).";

/// Writes `in` as the PNG `out` and reads it back. Every failure, the output's included, is a
/// UsageError naming the file (exit 2, as this program has always done).
void convert(const std::string& in, const std::string& out) {
  const cv::Mat image = cv::imread(in, cv::IMREAD_UNCHANGED);
  if (image.empty()) throw UsageError(in + ": cannot read the image");
  if (image.type() != CV_8UC1) throw UsageError(in + ": not an 8-bit grey image");
  const std::vector<int> params = {cv::IMWRITE_PNG_COMPRESSION, 9};
  if (!cv::imwrite(out, image, params)) throw UsageError(out + ": cannot write");
  const cv::Mat back = cv::imread(out, cv::IMREAD_UNCHANGED);
  if (back.empty() || back.type() != CV_8UC1 || back.size() != image.size() ||
      cv::countNonZero(back != image) != 0) {
    throw UsageError(out + ": does not read back identical to " + in);
  }
  std::printf("%s: %dx%d pixels, identical to %s\n", out.c_str(), image.cols, image.rows,
              in.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  esfleet::app::Program program("esfleet-map-png", "map-png", kDescription);
  std::string in, out;
  program.cli().add_option("IN", in, "map image to convert (e.g. map.pgm)")->required();
  program.cli().add_option("OUT", out, "8-bit grey PNG to write")->required();
  if (auto code = program.parse(argc, argv)) return *code;
  return program.run([&] {
    convert(in, out);
    return esfleet::app::kExitOk;
  });
}
