#pragma once
// Private to core: 64-bit FNV-1a, the hash behind the per-tile digests (tile_codec.cpp, the
// map.digest files leader and followers compare) and the SLAM snapshots' checksum
// (slam_snapshot.cpp). Both are stored or compared across versions: the function must not
// change.

#include <cstdint>
#include <string_view>

namespace esfleet::detail {

/// FNV-1a state: feed the bytes in order, then read value().
class Fnv1a {
 public:
  void add(std::uint8_t byte) {
    hash_ ^= byte;
    hash_ *= kPrime;
  }
  void add(std::string_view bytes) {
    for (const char c : bytes) add(static_cast<std::uint8_t>(c));
  }
  /// The four bytes of `v`, least significant first (little-endian, whatever the host).
  void add_le32(std::uint32_t v) {
    for (int shift = 0; shift < 32; shift += 8)
      add(static_cast<std::uint8_t>((v >> shift) & 0xFFu));
  }
  std::uint64_t value() const { return hash_; }

 private:
  static constexpr std::uint64_t kOffsetBasis = 0xcbf29ce484222325ull;
  static constexpr std::uint64_t kPrime = 0x100000001b3ull;
  std::uint64_t hash_ = kOffsetBasis;
};

/// FNV-1a of `bytes`.
inline std::uint64_t fnv1a(std::string_view bytes) {
  Fnv1a h;
  h.add(bytes);
  return h.value();
}

}  // namespace esfleet::detail
