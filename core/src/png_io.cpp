#include "png_io.hpp"

#include <png.h>
#include <zlib.h>

#include <algorithm>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <new>
#include <stdexcept>
#include <vector>

#include "esfleet/core/ros_map_format.hpp"

// libpng reports an error by calling our error function, which must not return: it longjmps to
// the setjmp of the function that called into libpng. A longjmp skips destructors, so every
// function holding a setjmp below (png_read_layout, png_read_pixels, png_encode) keeps only
// trivially destructible locals, and the callbacks hold no live C++ objects when they jump. The
// buffers libpng fills belong to the callers, whose frames the jump never crosses.

namespace esfleet::detail {
namespace {

/// libpng's error and I/O pointer: the bytes being read or the string being written, and the
/// message of the last error. Trivially destructible (see above).
struct PngIo {
  const unsigned char* data = nullptr;  ///< reading: the PNG bytes
  std::size_t size = 0;
  std::size_t pos = 0;
  std::string* out = nullptr;  ///< writing: the encoded bytes so far
  char message[200] = {};
};

void on_error(png_structp png, png_const_charp message) {
  auto* io = static_cast<PngIo*>(png_get_error_ptr(png));
  std::snprintf(io->message, sizeof io->message, "%s", message);
  png_longjmp(png, 1);
}

void on_warning(png_structp, png_const_charp) {}  // libpng would print them to stderr

void read_from_memory(png_structp png, png_bytep dest, png_size_t n) {
  auto* io = static_cast<PngIo*>(png_get_io_ptr(png));
  if (n > io->size - io->pos) png_error(png, "truncated image data");
  std::memcpy(dest, io->data + io->pos, n);
  io->pos += n;
}

void write_to_string(png_structp png, png_bytep data, png_size_t n) {
  auto* io = static_cast<PngIo*>(png_get_io_ptr(png));
  bool ok = true;
  try {
    io->out->append(reinterpret_cast<const char*>(data), n);
  } catch (const std::bad_alloc&) {
    ok = false;
  }
  if (!ok) png_error(png, "out of memory");  // outside the catch: nothing alive to skip
}

void flush_nothing(png_structp) {}

/// The rows libpng hands over after the transformations set by png_read_layout.
struct PngLayout {
  png_uint_32 width = 0;
  png_uint_32 height = 0;
  int channels = 0;
  int bit_depth = 0;
  std::size_t row_bytes = 0;
  int passes = 1;  ///< 7 for an interlaced image
};

/// Reads the header and sets up the transformations to 8-bit samples; false on a libpng error.
bool png_read_layout(png_structp png, png_infop info, PngLayout& layout) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_read_info(png, info);
  const int colour = png_get_color_type(png, info);
  if (colour == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if (colour == PNG_COLOR_TYPE_GRAY && png_get_bit_depth(png, info) < 8) {
    png_set_expand_gray_1_2_4_to_8(png);
  }
  // A tRNS chunk becomes an alpha channel for colour images only (grey ones ignore it).
  if ((colour & PNG_COLOR_MASK_COLOR) != 0 && png_get_valid(png, info, PNG_INFO_tRNS) != 0) {
    png_set_tRNS_to_alpha(png);
  }
  png_set_scale_16(png);  // round(v * 255 / 65535), as OpenCV's conversion did
  layout.passes = png_set_interlace_handling(png);
  png_read_update_info(png, info);
  layout.width = png_get_image_width(png, info);
  layout.height = png_get_image_height(png, info);
  layout.channels = png_get_channels(png, info);
  layout.bit_depth = png_get_bit_depth(png, info);
  layout.row_bytes = png_get_rowbytes(png, info);
  return true;
}

/// Reads every row (every pass of an interlaced image) into `out`, rows `row_bytes` apart, then
/// the chunks after the image; false on a libpng error.
bool png_read_pixels(png_structp png, const PngLayout& layout, unsigned char* out) {
  if (setjmp(png_jmpbuf(png))) return false;
  for (int pass = 0; pass < layout.passes; ++pass) {
    for (png_uint_32 r = 0; r < layout.height; ++r) {
      png_read_row(png, out + static_cast<std::size_t>(r) * layout.row_bytes, nullptr);
    }
  }
  png_read_end(png, nullptr);
  return true;
}

/// Owns libpng's read structures.
class PngReader {
 public:
  explicit PngReader(PngIo& io)
      : png_(png_create_read_struct(PNG_LIBPNG_VER_STRING, &io, on_error, on_warning)),
        info_(png_ ? png_create_info_struct(png_) : nullptr) {}
  ~PngReader() { png_destroy_read_struct(&png_, info_ ? &info_ : nullptr, nullptr); }
  PngReader(const PngReader&) = delete;
  PngReader& operator=(const PngReader&) = delete;
  png_structp png() const { return png_; }
  png_infop info() const { return info_; }

 private:
  png_structp png_;
  png_infop info_;
};

/// Owns libpng's write structures.
class PngWriter {
 public:
  explicit PngWriter(PngIo& io)
      : png_(png_create_write_struct(PNG_LIBPNG_VER_STRING, &io, on_error, on_warning)),
        info_(png_ ? png_create_info_struct(png_) : nullptr) {}
  ~PngWriter() { png_destroy_write_struct(&png_, info_ ? &info_ : nullptr); }
  PngWriter(const PngWriter&) = delete;
  PngWriter& operator=(const PngWriter&) = delete;
  png_structp png() const { return png_; }
  png_infop info() const { return info_; }

 private:
  png_structp png_;
  png_infop info_;
};

/// What png_encode writes: the size and where each row comes from (`row` is a buffer of
/// width * channels bytes owned by the caller).
struct PngRows {
  int width = 0;
  int height = 0;
  int channels = 0;
  const std::function<void(int, std::uint8_t*)>* fill_row = nullptr;
  std::uint8_t* row = nullptr;
};

/// Writes the rows as a PNG through `png`; false on a libpng error. An exception from fill_row
/// leaves through here (no libpng frame is on the stack while it runs).
bool png_encode(png_structp png, png_infop info, const PngRows& image) {
  if (setjmp(png_jmpbuf(png))) return false;
  static constexpr int kColourTypes[] = {PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA,
                                         PNG_COLOR_TYPE_RGB, PNG_COLOR_TYPE_RGB_ALPHA};
  png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);
  png_set_compression_level(png, Z_BEST_SPEED);
  png_set_compression_strategy(png, Z_RLE);
  png_set_IHDR(png, info, static_cast<png_uint_32>(image.width),
               static_cast<png_uint_32>(image.height), 8, kColourTypes[image.channels - 1],
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (int r = 0; r < image.height; ++r) {
    (*image.fill_row)(r, image.row);
    png_write_row(png, image.row);
  }
  png_write_end(png, nullptr);
  return true;
}

}  // namespace

Pixels read_png(const std::string& path, std::string_view data) {
  PngIo io;
  io.data = reinterpret_cast<const unsigned char*>(data.data());
  io.size = data.size();
  const auto fail = [&](const char* why) {
    return std::runtime_error(path + ": cannot decode PNG image: " + why);
  };
  PngReader reader(io);
  if (reader.info() == nullptr) throw fail("out of memory");
  png_set_read_fn(reader.png(), &io, read_from_memory);
  // check_png has limited the size already; this keeps libpng itself to the same limit.
  const auto max_edge =
      static_cast<png_uint_32>(std::min<std::uint64_t>(kMaxMapImagePixels, 0x7fffffff));
  png_set_user_limits(reader.png(), max_edge, max_edge);
  PngLayout layout;
  if (!png_read_layout(reader.png(), reader.info(), layout)) throw fail(io.message);
  if (layout.bit_depth != 8 || layout.channels < 1 || layout.channels > 4 ||
      layout.row_bytes != static_cast<std::size_t>(layout.width) * layout.channels) {
    throw std::runtime_error(path + ": unsupported PNG sample format");
  }
  Pixels px;
  px.width = static_cast<int>(layout.width);
  px.height = static_cast<int>(layout.height);
  px.channels = layout.channels;
  px.data.resize(layout.row_bytes * layout.height);
  if (!png_read_pixels(reader.png(), layout, px.data.data())) throw fail(io.message);
  return px;
}

std::string write_png(const Pixels& image) {
  if (image.width <= 0 || image.height <= 0 || image.channels < 1 || image.channels > 4 ||
      image.data.size() != static_cast<std::size_t>(image.width) *
                               static_cast<std::size_t>(image.height) *
                               static_cast<std::size_t>(image.channels)) {
    throw std::invalid_argument("write_png: image size and data do not agree");
  }
  const std::size_t row_bytes = static_cast<std::size_t>(image.width) * image.channels;
  return write_png(image.width, image.height, image.channels, [&](int r, std::uint8_t* out) {
    std::copy_n(image.data.data() + static_cast<std::size_t>(r) * row_bytes, row_bytes, out);
  });
}

std::string write_png(int width, int height, int channels,
                      const std::function<void(int, std::uint8_t*)>& fill_row) {
  if (width <= 0 || height <= 0 || channels < 1 || channels > 4) {
    throw std::invalid_argument("write_png: bad image size or channel count");
  }
  std::vector<std::uint8_t> row(static_cast<std::size_t>(width) * channels);
  std::string out;
  PngIo io;
  io.out = &out;
  const PngWriter writer(io);
  if (writer.info() == nullptr) throw std::runtime_error("PNG encoding failed: out of memory");
  png_set_write_fn(writer.png(), &io, write_to_string, flush_nothing);
  const PngRows rows{width, height, channels, &fill_row, row.data()};
  if (!png_encode(writer.png(), writer.info(), rows)) {
    throw std::runtime_error(std::string("PNG encoding failed: ") + io.message);
  }
  return out;
}

}  // namespace esfleet::detail
