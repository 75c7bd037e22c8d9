// esfleet-map-png: converts a map image (e.g. the leader's map.pgm) to a lossless 8-bit grey
// PNG, pixel for pixel, and checks that the PNG reads back identical. Used to make the worlds
// in data/worlds/ (README there); the YAML is copied with its `image:` line changed.
//
// usage: esfleet-map-png IN.pgm OUT.png    exit 0 ok, 2 error (message names the file)

#include <cstdio>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: esfleet-map-png IN.pgm OUT.png\n");
    return 2;
  }
  const std::string in = argv[1], out = argv[2];
  const cv::Mat image = cv::imread(in, cv::IMREAD_UNCHANGED);
  if (image.empty()) {
    std::fprintf(stderr, "%s: cannot read the image\n", in.c_str());
    return 2;
  }
  if (image.type() != CV_8UC1) {
    std::fprintf(stderr, "%s: not an 8-bit grey image\n", in.c_str());
    return 2;
  }
  const std::vector<int> params = {cv::IMWRITE_PNG_COMPRESSION, 9};
  if (!cv::imwrite(out, image, params)) {
    std::fprintf(stderr, "%s: cannot write\n", out.c_str());
    return 2;
  }
  const cv::Mat back = cv::imread(out, cv::IMREAD_UNCHANGED);
  if (back.empty() || back.type() != CV_8UC1 || back.size() != image.size() ||
      cv::countNonZero(back != image) != 0) {
    std::fprintf(stderr, "%s: does not read back identical to %s\n", out.c_str(), in.c_str());
    return 2;
  }
  std::printf("%s: %dx%d pixels, identical to %s\n", out.c_str(), image.cols, image.rows,
              in.c_str());
  return 0;
}
