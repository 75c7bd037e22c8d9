#pragma once
// Files and directories a test program writes under the test temp dir, removed when it ends
// (a test run leaves nothing behind in /tmp).

#include <filesystem>
#include <system_error>
#include <vector>

namespace esfleet::test {

class ScratchPaths {
 public:
  ScratchPaths() = default;
  ScratchPaths(const ScratchPaths&) = delete;
  ScratchPaths& operator=(const ScratchPaths&) = delete;
  ~ScratchPaths() {
    for (const std::filesystem::path& p : paths_) {
      std::error_code ignored;
      std::filesystem::remove_all(p, ignored);
    }
  }
  /// Registers `p` (a file or a directory) for removal at exit and returns it.
  std::filesystem::path add(const std::filesystem::path& p) {
    paths_.push_back(p);
    return p;
  }

 private:
  std::vector<std::filesystem::path> paths_;
};

/// The program's registry (destroyed, and its paths removed, at normal exit).
inline ScratchPaths& scratch_paths() {
  static ScratchPaths paths;
  return paths;
}

}  // namespace esfleet::test
