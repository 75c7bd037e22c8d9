#pragma once
// Whole-file I/O with the guarantees the map files and stats.json need: atomic replacement on
// write, a size bound and precise messages on read.

#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>

namespace esfleet {

/// Writes `contents` to `path` so that a reader sees the old file or the complete new one,
/// never a partial file: writes "<path>.tmp.<pid>.<n>" in the same directory (n counts calls
/// in this process), flushes and closes it, then renames it over `path`. No fsync: this
/// protects against crashes of the writer and concurrent readers, not against power loss.
/// The directory must exist. Throws std::runtime_error naming `path` on failure, after
/// removing the temporary file.
void write_file_atomically(const std::string& path, const std::string& contents);

/// A file written in pieces with the guarantees of write_file_atomically, for contents too large
/// to hold whole: the bytes go to the temporary file, commit() flushes, closes and renames it
/// over `path`. Destroyed without commit() (an exception while producing the bytes), it removes
/// the temporary file and leaves `path` as it was. The constructor, write() and commit() throw
/// std::runtime_error naming `path` as write_file_atomically does, after removing the temporary
/// file.
class AtomicFile {
 public:
  explicit AtomicFile(std::string path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  void write(std::string_view bytes);
  void commit();
  std::uint64_t bytes_written() const { return written_; }

 private:
  [[noreturn]] void fail(int err);

  std::string path_;
  std::string tmp_;
  std::FILE* file_ = nullptr;
  std::uint64_t written_ = 0;
};

/// The whole of the regular file `path`, at most `max_bytes` long (a file that shrinks while
/// being read yields what was there). Throws std::runtime_error
/// "<path>: cannot read <what><context>: <reason>" when it is missing, not a regular file,
/// larger than `max_bytes` or unreadable; `what` names the file's role ("map file"),
/// `context` (optional) adds where it was named (" named in map.yaml").
std::string read_whole_file(const std::string& path, std::uintmax_t max_bytes,
                            const std::string& what, const std::string& context = {});

}  // namespace esfleet
