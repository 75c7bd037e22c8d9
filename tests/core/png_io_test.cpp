// The PNG reader and writer of core (core/src/png_io.hpp, private to core), through
// decode_image where the structural check belongs to the contract. The test images are built
// by hand with zlib here, independently of libpng.
#include "png_io.hpp"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cstdint>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "image_decoder.hpp"

namespace esfleet::detail {
namespace {

std::string be32(std::uint32_t v) {
  std::string out;
  for (int shift = 24; shift >= 0; shift -= 8) out += static_cast<char>((v >> shift) & 0xff);
  return out;
}

/// A PNG chunk: length, type, data, CRC.
std::string chunk(const std::string& type, const std::string& data) {
  const std::string body = type + data;
  const uLong crc = crc32(crc32(0L, Z_NULL, 0), reinterpret_cast<const Bytef*>(body.data()),
                          static_cast<uInt>(body.size()));
  return be32(static_cast<std::uint32_t>(data.size())) + body +
         be32(static_cast<std::uint32_t>(crc));
}

std::string deflate(const std::string& raw) {
  std::vector<Bytef> z(compressBound(static_cast<uLong>(raw.size())));
  uLongf z_len = static_cast<uLongf>(z.size());
  EXPECT_EQ(compress(z.data(), &z_len, reinterpret_cast<const Bytef*>(raw.data()),
                     static_cast<uLong>(raw.size())),
            Z_OK);
  return {reinterpret_cast<const char*>(z.data()), z_len};
}

/// Every `row_bytes` bytes of `packed` as a row with filter type 0 in front.
std::string unfiltered_rows(const std::string& packed, std::size_t row_bytes) {
  std::string raw;
  for (std::size_t at = 0; at < packed.size(); at += row_bytes) {
    raw += '\0';
    raw += packed.substr(at, row_bytes);
  }
  return raw;
}

struct Header {
  std::uint32_t width = 1;
  std::uint32_t height = 1;
  int depth = 8;
  int colour = 0;  ///< 0 grey, 2 RGB, 3 palette, 4 grey+alpha, 6 RGBA
  bool interlaced = false;
};

/// A PNG of `raw` (the filtered rows, deflated into one IDAT) with `extra` chunks between IHDR
/// and IDAT.
std::string make_png(const Header& h, const std::string& raw, const std::string& extra = "") {
  const std::string ihdr = be32(h.width) + be32(h.height) + static_cast<char>(h.depth) +
                           static_cast<char>(h.colour) + '\0' + '\0' +
                           static_cast<char>(h.interlaced ? 1 : 0);
  return std::string("\x89PNG\r\n\x1a\n", 8) + chunk("IHDR", ihdr) + extra +
         chunk("IDAT", deflate(raw)) + chunk("IEND", "");
}

std::string random_bytes(std::size_t n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::string out(n, '\0');
  for (char& c : out) c = static_cast<char>(rng() % 256);
  return out;
}

std::vector<std::uint8_t> bytes(const std::string& s) { return {s.begin(), s.end()}; }

TEST(PngIo, WrittenImagesReadBackUnchanged) {
  std::uint32_t seed = 1;
  for (int channels = 1; channels <= 4; ++channels) {
    for (const auto& [w, h] : {std::pair{1, 1}, std::pair{37, 5}, std::pair{3, 64}}) {
      Pixels px;
      px.width = w;
      px.height = h;
      px.channels = channels;
      px.data = bytes(random_bytes(static_cast<std::size_t>(w * h * channels), ++seed));
      const std::string png = write_png(px);
      const Pixels back = decode_image("round.png", png);
      EXPECT_EQ(back.width, w);
      EXPECT_EQ(back.height, h);
      EXPECT_EQ(back.channels, channels);
      EXPECT_EQ(back.data, px.data) << channels << " channels, " << w << "x" << h;
    }
  }
}

TEST(PngIo, WriteRefusesDataOfTheWrongSize) {
  Pixels px;
  px.width = 2;
  px.height = 2;
  px.channels = 3;
  px.data.resize(11);
  EXPECT_THROW(write_png(px), std::invalid_argument);
  px.data.resize(12);
  px.channels = 5;
  EXPECT_THROW(write_png(px), std::invalid_argument);
}

TEST(PngIo, SixteenBitSamplesRoundToEightBits) {
  // Every 16-bit value once: 256 x 256 grey, value = row * 256 + column, big-endian.
  std::string packed;
  for (int v = 0; v < 65536; ++v) packed += be32(static_cast<std::uint32_t>(v)).substr(2);
  const Pixels px =
      decode_image("g16.png", make_png({256, 256, 16, 0}, unfiltered_rows(packed, 512)));
  ASSERT_EQ(px.channels, 1);
  ASSERT_EQ(px.data.size(), 65536u);
  for (int v = 0; v < 65536; ++v) {
    // round(v / 257), never a tie (257 is odd).
    ASSERT_EQ(px.data[static_cast<std::size_t>(v)], (2 * v + 257) / 514) << v;
  }
  // RGBA, 16 bits: each channel alike.
  const std::string rgba(std::string("\x00\x80\x80\x80\xff\x7f\xff\xff", 8));
  const Pixels c = decode_image("c16.png", make_png({1, 1, 16, 6}, unfiltered_rows(rgba, 8)));
  EXPECT_EQ(c.channels, 4);
  EXPECT_EQ(c.data, (std::vector<std::uint8_t>{0, 128, 255, 255}));
}

TEST(PngIo, LowBitDepthGreyScalesUp) {
  // 1 bit: 1 0 1 1 0 0 0 0; 2 bits: 0 1 2 3; 4 bits: 0 15 7 10.
  EXPECT_EQ(decode_image("g1.png", make_png({8, 1, 1, 0}, unfiltered_rows("\xb0", 1))).data,
            (std::vector<std::uint8_t>{255, 0, 255, 255, 0, 0, 0, 0}));
  EXPECT_EQ(decode_image("g2.png", make_png({4, 1, 2, 0}, unfiltered_rows("\x1b", 1))).data,
            (std::vector<std::uint8_t>{0, 85, 170, 255}));
  EXPECT_EQ(decode_image("g4.png", make_png({4, 1, 4, 0}, unfiltered_rows("\x0f\x7a", 2))).data,
            (std::vector<std::uint8_t>{0, 255, 119, 170}));
}

TEST(PngIo, PaletteAndTransparency) {
  const std::string palette = chunk("PLTE", std::string("\x10\x20\x30\x40\x50\x60\x70\x80\x90", 9));
  const std::string indices = unfiltered_rows(std::string("\x02\x00\x01", 3), 3);
  // Palette: expanded to RGB.
  const Pixels rgb = decode_image("p.png", make_png({3, 1, 8, 3}, indices, palette));
  EXPECT_EQ(rgb.channels, 3);
  EXPECT_EQ(rgb.data,
            (std::vector<std::uint8_t>{0x70, 0x80, 0x90, 0x10, 0x20, 0x30, 0x40, 0x50, 0x60}));
  // Palette with tRNS (alpha of the first two entries): RGBA, the third entry opaque.
  const Pixels rgba = decode_image(
      "pt.png",
      make_png({3, 1, 8, 3}, indices, palette + chunk("tRNS", std::string("\x00\x80", 2))));
  EXPECT_EQ(rgba.channels, 4);
  EXPECT_EQ(rgba.data, (std::vector<std::uint8_t>{0x70, 0x80, 0x90, 255, 0x10, 0x20, 0x30, 0, 0x40,
                                                  0x50, 0x60, 0x80}));
  // RGB with a tRNS key colour: RGBA, alpha 0 where the colour is the key.
  const Pixels keyed = decode_image(
      "rt.png",
      make_png({2, 1, 8, 2}, unfiltered_rows(std::string("\x01\x02\x03\x01\x02\x04", 6), 6),
               chunk("tRNS", std::string("\0\x01\0\x02\0\x03", 6))));
  EXPECT_EQ(keyed.channels, 4);
  EXPECT_EQ(keyed.data, (std::vector<std::uint8_t>{1, 2, 3, 0, 1, 2, 4, 255}));
  // Grey with a tRNS key: the key is ignored (one channel), as the OpenCV decoder did before.
  const Pixels grey =
      decode_image("gt.png", make_png({2, 1, 8, 0}, unfiltered_rows(std::string("\x05\x06", 2), 2),
                                      chunk("tRNS", std::string("\0\x05", 2))));
  EXPECT_EQ(grey.channels, 1);
  EXPECT_EQ(grey.data, (std::vector<std::uint8_t>{5, 6}));
}

TEST(PngIo, InterlacedEqualsNonInterlaced) {
  const std::uint32_t w = 13, h = 11;
  const std::string packed = random_bytes(w * h, 5);
  // Adam7: seven passes over sub-images, each row filtered on its own; empty passes omitted.
  constexpr int kPass[7][4] = {{0, 0, 8, 8}, {4, 0, 8, 8}, {0, 4, 4, 8}, {2, 0, 4, 4},
                               {0, 2, 2, 4}, {1, 0, 2, 2}, {0, 1, 1, 2}};
  std::string raw;
  for (const auto& [x0, y0, dx, dy] : kPass) {
    for (std::uint32_t y = static_cast<std::uint32_t>(y0); y < h; y += dy) {
      std::string row;
      for (std::uint32_t x = static_cast<std::uint32_t>(x0); x < w; x += dx) {
        row += packed[y * w + x];
      }
      if (!row.empty()) raw += '\0' + row;
    }
  }
  const Pixels plain =
      decode_image("plain.png", make_png({w, h, 8, 0}, unfiltered_rows(packed, w)));
  const Pixels adam7 = decode_image("adam7.png", make_png({w, h, 8, 0, true}, raw));
  EXPECT_EQ(plain.data, bytes(packed));
  EXPECT_EQ(adam7.data, bytes(packed));
}

TEST(PngIo, TruncatedImagesAreRefusedNamingThePath) {
  const std::string packed = random_bytes(32 * 32 * 3, 9);  // incompressible
  const std::string png = make_png({32, 32, 8, 2}, unfiltered_rows(packed, 96));
  ASSERT_EQ(decode_image("whole.png", png).data, bytes(packed));
  const auto error = [](const std::string& path, const std::string& data) -> std::string {
    try {
      decode_image(path, data);
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    return "(no error)";
  };
  // The file cut short: the chunk check refuses it.
  for (const std::size_t keep : {std::size_t{40}, png.size() / 2, png.size() - 1}) {
    const std::string msg = error("/maps/cut.png", png.substr(0, keep));
    EXPECT_EQ(msg.rfind("/maps/cut.png: bad PNG image: truncated", 0), 0u) << keep << ": " << msg;
  }
  // Whole chunks, but the compressed stream stops halfway: libpng runs out of image data.
  const std::string z = deflate(unfiltered_rows(packed, 96));
  const std::string half = std::string("\x89PNG\r\n\x1a\n", 8) + chunk("IHDR", png.substr(16, 13)) +
                           chunk("IDAT", z.substr(0, z.size() / 2)) + chunk("IEND", "");
  const std::string msg = error("/maps/half.png", half);
  EXPECT_EQ(msg.rfind("/maps/half.png: cannot decode PNG image: ", 0), 0u) << msg;
}

TEST(PngIo, LibpngWarningsStayOffStderr) {
  // One row more than the header's: libpng warns ("extra compressed data") and decodes.
  ::testing::internal::CaptureStderr();
  const Pixels px = decode_image("extra.png", make_png({2, 1, 8, 0}, unfiltered_rows("abcd", 2)));
  EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
  EXPECT_EQ(px.data, bytes("ab"));
}

}  // namespace
}  // namespace esfleet::detail
