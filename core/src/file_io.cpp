#include "esfleet/core/file_io.hpp"

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <system_error>

namespace esfleet {
namespace {

namespace fs = std::filesystem;

std::string errno_text(int err) { return std::error_code(err, std::generic_category()).message(); }

}  // namespace

void write_file_atomically(const std::string& path, const std::string& contents) {
  static std::atomic<std::uint64_t> counter{0};
  const std::string tmp =
      path + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++);
  const std::string prefix = "cannot write '" + path + "': ";
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (f == nullptr) {
    throw std::runtime_error(prefix + "cannot create '" + tmp + "': " + errno_text(errno));
  }
  int err = 0;
  if (!contents.empty() && std::fwrite(contents.data(), 1, contents.size(), f) != contents.size()) {
    err = errno != 0 ? errno : EIO;
  }
  if (std::fflush(f) != 0 && err == 0) err = errno != 0 ? errno : EIO;
  if (std::fclose(f) != 0 && err == 0) err = errno != 0 ? errno : EIO;
  if (err == 0 && std::rename(tmp.c_str(), path.c_str()) != 0) err = errno != 0 ? errno : EIO;
  if (err != 0) {
    std::remove(tmp.c_str());
    throw std::runtime_error(prefix + errno_text(err));
  }
}

std::string read_whole_file(const std::string& path, std::uintmax_t max_bytes,
                            const std::string& what, const std::string& context) {
  const std::string prefix = path + ": cannot read " + what + context + ": ";
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (ec) throw std::runtime_error(prefix + ec.message());
  if (!fs::is_regular_file(st)) throw std::runtime_error(prefix + "not a regular file");
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec) throw std::runtime_error(prefix + ec.message());
  if (size > max_bytes) {
    throw std::runtime_error(prefix + "file is " + std::to_string(size) + " bytes, more than the " +
                             std::to_string(max_bytes) + " allowed");
  }
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) throw std::runtime_error(prefix + errno_text(errno));
  std::string data(static_cast<std::size_t>(size), '\0');
  const std::size_t got = data.empty() ? 0 : std::fread(data.data(), 1, data.size(), f);
  const bool failed = std::ferror(f) != 0;
  std::fclose(f);
  if (failed) throw std::runtime_error(prefix + "read error");
  data.resize(got);  // the file may have shrunk meanwhile
  return data;
}

}  // namespace esfleet
