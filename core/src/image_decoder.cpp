#include "image_decoder.hpp"

#include <zlib.h>

#include <algorithm>
#include <stdexcept>
#include <string_view>

#include "esfleet/core/ros_map_format.hpp"
#include "png_io.hpp"

namespace esfleet::detail {
namespace {

void check_dimensions(const std::string& path, std::uint64_t w, std::uint64_t h) {
  if (w == 0 || h == 0) {
    throw std::runtime_error(path + ": image has zero width or height (" + std::to_string(w) + "x" +
                             std::to_string(h) + ")");
  }
  // w, h < 2^32 here, so the product cannot overflow.
  if (w > kMaxMapImagePixels || h > kMaxMapImagePixels || w * h > kMaxMapImagePixels) {
    throw std::runtime_error(path + ": image is " + std::to_string(w) + "x" + std::to_string(h) +
                             " pixels, more than the " + std::to_string(kMaxMapImagePixels) +
                             " allowed");
  }
}

bool is_pnm_space(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
}

/// Netpbm grey map, P5 (binary) or P2 (ascii).
class PgmParser {
 public:
  PgmParser(const std::string& path, std::string_view data) : path_(path), d_(data) {}

  Pixels parse() {
    const bool binary = d_[1] == '5';
    pos_ = 2;
    const std::uint64_t w = header_number("width");
    const std::uint64_t h = header_number("height");
    const std::uint64_t maxval = header_number("maxval");
    if (maxval == 0 || maxval > 65535) {
      fail("maxval must be in 1..65535, got " + std::to_string(maxval));
    }
    check_dimensions(path_, w, h);
    if (pos_ >= d_.size() || !is_pnm_space(d_[pos_])) fail("truncated header");
    ++pos_;  // the single whitespace character before the raster
    const std::size_t n = static_cast<std::size_t>(w * h);
    const std::size_t bytes_per_sample = maxval > 255 ? 2 : 1;
    // Check the data can hold the raster before allocating it: binary samples take 1 or 2
    // bytes, ascii ones at least a digit and a separator.
    const std::size_t left = d_.size() - pos_;
    const std::size_t need = binary ? n * bytes_per_sample : 2 * n - 1;
    if (left < need) {
      fail("truncated: " + std::to_string(left) + " bytes of pixel data, " + std::to_string(w) +
           "x" + std::to_string(h) + " needs " + (binary ? "" : "at least ") +
           std::to_string(need));
    }
    Pixels px;
    px.width = static_cast<int>(w);
    px.height = static_cast<int>(h);
    px.data.resize(n);
    if (binary) {
      for (std::size_t i = 0; i < n; ++i) {
        std::uint64_t v = static_cast<unsigned char>(d_[pos_ + i * bytes_per_sample]);
        if (bytes_per_sample == 2) {
          v = (v << 8) | static_cast<unsigned char>(d_[pos_ + i * 2 + 1]);
        }
        px.data[i] = scale(v, maxval, i);
      }
    } else {
      for (std::size_t i = 0; i < n; ++i) {
        while (pos_ < d_.size() && is_pnm_space(d_[pos_])) ++pos_;
        if (pos_ >= d_.size()) {
          fail("truncated: " + std::to_string(i) + " samples, " + std::to_string(w) + "x" +
               std::to_string(h) + " needs " + std::to_string(n));
        }
        px.data[i] = scale(number("sample " + std::to_string(i)), maxval, i);
      }
    }
    return px;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error(path_ + ": bad PGM image: " + what);
  }

  std::uint8_t scale(std::uint64_t v, std::uint64_t maxval, std::size_t i) const {
    if (v > maxval) {
      fail("sample " + std::to_string(i) + " is " + std::to_string(v) + ", above maxval " +
           std::to_string(maxval));
    }
    if (maxval == 255) return static_cast<std::uint8_t>(v);
    return static_cast<std::uint8_t>((v * 255 + maxval / 2) / maxval);
  }

  /// A decimal number at pos_ (no sign), at most 10 digits.
  std::uint64_t number(const std::string& what) {
    std::uint64_t v = 0;
    std::size_t digits = 0;
    while (pos_ < d_.size() && d_[pos_] >= '0' && d_[pos_] <= '9') {
      if (++digits > 10) fail(what + " has too many digits");
      v = v * 10 + static_cast<std::uint64_t>(d_[pos_] - '0');
      ++pos_;
    }
    if (digits == 0) fail(what + " is not a number");
    return v;
  }

  /// Skips whitespace and '#' comments, then reads a number.
  std::uint64_t header_number(const std::string& what) {
    for (;;) {
      while (pos_ < d_.size() && is_pnm_space(d_[pos_])) ++pos_;
      if (pos_ < d_.size() && d_[pos_] == '#') {
        while (pos_ < d_.size() && d_[pos_] != '\n' && d_[pos_] != '\r') ++pos_;
        continue;
      }
      break;
    }
    if (pos_ >= d_.size()) fail("truncated header (no " + what + ")");
    return number(what);
  }

  const std::string& path_;
  std::string_view d_;
  std::size_t pos_ = 0;
};

constexpr unsigned char kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

std::uint64_t be32(std::string_view d, std::size_t at) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < 4; ++i) v = (v << 8) | static_cast<unsigned char>(d[at + i]);
  return v;
}

/// Checks a PNG's chunk structure (lengths, CRCs, IHDR fields, IDAT and IEND present) and
/// that the file could hold its raster, so that libpng only ever sees well-formed files and
/// nothing allocates for a lying header.
void check_png(const std::string& path, std::string_view data) {
  const auto bad = [&](const std::string& what) {
    return std::runtime_error(path + ": bad PNG image: " + what);
  };
  if (data.size() < 33 || data.compare(12, 4, "IHDR") != 0 || be32(data, 8) != 13) {
    throw bad("no IHDR header");
  }
  const std::uint64_t w = be32(data, 16), h = be32(data, 20);
  check_dimensions(path, w, h);
  const auto depth = static_cast<unsigned char>(data[24]);
  const auto colour = static_cast<unsigned char>(data[25]);
  std::uint64_t samples = 0;
  bool depth_ok = false;
  switch (colour) {
    case 0:  // grey
      samples = 1;
      depth_ok = depth == 1 || depth == 2 || depth == 4 || depth == 8 || depth == 16;
      break;
    case 3:  // palette
      samples = 1;
      depth_ok = depth == 1 || depth == 2 || depth == 4 || depth == 8;
      break;
    case 2:  // RGB
    case 4:  // grey + alpha
    case 6:  // RGBA
      samples = colour == 2 ? 3 : colour == 4 ? 2 : 4;
      depth_ok = depth == 8 || depth == 16;
      break;
    default:
      break;
  }
  if (!depth_ok || data[26] != 0 || data[27] != 0 || (data[28] != 0 && data[28] != 1)) {
    throw bad("invalid IHDR (bit depth " + std::to_string(depth) + ", colour type " +
              std::to_string(colour) + ")");
  }
  std::size_t pos = 8;
  std::uint64_t idat_bytes = 0;
  bool have_palette = false, have_end = false;
  while (!have_end) {
    if (data.size() - pos < 12) throw bad("truncated (no IEND chunk)");
    const std::uint64_t len = be32(data, pos);
    if (len > data.size() - pos - 12) throw bad("truncated chunk at byte " + std::to_string(pos));
    const std::string_view type = data.substr(pos + 4, 4);
    uLong crc = crc32(0L, Z_NULL, 0);
    crc = crc32(crc, reinterpret_cast<const Bytef*>(data.data() + pos + 4),
                static_cast<uInt>(len + 4));
    if (crc != be32(data, pos + 8 + len)) {
      throw bad("CRC error in chunk '" + std::string(type) + "' at byte " + std::to_string(pos));
    }
    if (type == "IDAT") idat_bytes += len;
    if (type == "PLTE") have_palette = true;
    if (type == "IEND") have_end = true;
    pos += 12 + len;
  }
  if (idat_bytes == 0) throw bad("no image data");
  if (colour == 3 && !have_palette) throw bad("palette image without a palette");
  // Deflate expands at most ~1032:1: compressed data much smaller than the raster (one filter
  // byte per row plus the packed samples) cannot hold it.
  const std::uint64_t raster = h * (1 + (w * samples * depth + 7) / 8);
  if (idat_bytes * 1100 < raster) {
    throw bad(std::to_string(idat_bytes) + " bytes of image data cannot hold " + std::to_string(w) +
              "x" + std::to_string(h) + " pixels");
  }
}

Pixels decode_png(const std::string& path, const std::string& data) {
  check_png(path, data);
  Pixels px = read_png(path, data);
  if (static_cast<std::uint64_t>(px.width) != be32(data, 16) ||
      static_cast<std::uint64_t>(px.height) != be32(data, 20)) {
    throw std::runtime_error(path + ": PNG decoded to a size other than its header's");
  }
  return px;
}

}  // namespace

/// The image file contents `data` (PGM or PNG, told apart by their magic bytes); `path` names
/// it in errors.
Pixels decode_image(const std::string& path, const std::string& data) {
  if (data.size() >= 2 && data[0] == 'P' && (data[1] == '5' || data[1] == '2')) {
    return PgmParser(path, data).parse();
  }
  if (data.size() >= 8 &&
      std::equal(kPngSignature, kPngSignature + 8, data.begin(),
                 [](unsigned char a, char b) { return a == static_cast<unsigned char>(b); })) {
    return decode_png(path, data);
  }
  throw std::runtime_error(path + ": cannot read image: not a PGM (P5/P2) or PNG file");
}

}  // namespace esfleet::detail
