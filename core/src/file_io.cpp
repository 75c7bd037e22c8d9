#include "esfleet/core/file_io.hpp"

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <system_error>
#include <utility>

namespace esfleet {
namespace {

namespace fs = std::filesystem;

std::string errno_text(int err) { return std::error_code(err, std::generic_category()).message(); }

}  // namespace

void write_file_atomically(const std::string& path, const std::string& contents) {
  AtomicFile f(path);
  f.write(contents);
  f.commit();
}

AtomicFile::AtomicFile(std::string path) : path_(std::move(path)) {
  static std::atomic<std::uint64_t> counter{0};
  tmp_ = path_ + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++);
  file_ = std::fopen(tmp_.c_str(), "wb");
  if (file_ == nullptr) {
    throw std::runtime_error("cannot write '" + path_ + "': cannot create '" + tmp_ +
                             "': " + errno_text(errno));
  }
}

AtomicFile::~AtomicFile() {
  if (file_ != nullptr) {  // not committed
    std::fclose(file_);
    std::remove(tmp_.c_str());
  }
}

void AtomicFile::write(std::string_view bytes) {
  if (file_ == nullptr) throw std::logic_error("AtomicFile::write after commit: " + path_);
  if (!bytes.empty() && std::fwrite(bytes.data(), 1, bytes.size(), file_) != bytes.size()) {
    fail(errno != 0 ? errno : EIO);
  }
  written_ += bytes.size();
}

void AtomicFile::commit() {
  if (file_ == nullptr) throw std::logic_error("AtomicFile::commit twice: " + path_);
  int err = 0;
  if (std::fflush(file_) != 0) err = errno != 0 ? errno : EIO;
  if (std::fclose(file_) != 0 && err == 0) err = errno != 0 ? errno : EIO;
  file_ = nullptr;
  if (err == 0 && std::rename(tmp_.c_str(), path_.c_str()) != 0) err = errno != 0 ? errno : EIO;
  if (err != 0) fail(err);
}

void AtomicFile::fail(int err) {
  if (file_ != nullptr) std::fclose(file_);
  file_ = nullptr;
  std::remove(tmp_.c_str());
  throw std::runtime_error("cannot write '" + path_ + "': " + errno_text(err));
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
