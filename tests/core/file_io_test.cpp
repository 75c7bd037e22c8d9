#include "esfleet/core/file_io.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "map_files_fixture.hpp"

namespace esfleet {
namespace {

using FileIoTest = testing::MapFilesTest;
namespace fs = std::filesystem;

// --- write_file_atomically ---------------------------------------------------------------------

TEST_F(FileIoTest, AtomicWriteRoundTripsAndLeavesNoTemporary) {
  const std::string file = path("stats.json");
  const std::string binary("a\0b\nc\xff", 6);
  write_file_atomically(file, binary);
  EXPECT_EQ(slurp(file), binary);
  write_file_atomically(file, "second, shorter");
  EXPECT_EQ(slurp(file), "second, shorter");
  write_file_atomically(file, "");
  EXPECT_EQ(slurp(file), "");
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir_)) names.push_back(e.path().filename().string());
  EXPECT_EQ(names, std::vector<std::string>{"stats.json"});
}

TEST_F(FileIoTest, AtomicWriteIntoMissingDirectoryThrowsNamingPath) {
  const std::string file = path("missing/stats.json");
  try {
    write_file_atomically(file, "{}");
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(file), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(path("missing")));
}

TEST_F(FileIoTest, AtomicWriteOverADirectoryFailsAndCleansUp) {
  fs::create_directories(dir_ / "taken");
  EXPECT_THROW(write_file_atomically(path("taken"), "x"), std::runtime_error);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 1);
}

TEST_F(FileIoTest, AtomicFileInPiecesAppearsOnlyOnCommit) {
  const std::string file = path("blob.bin");
  write_file_atomically(file, "old");
  {
    AtomicFile f(file);
    f.write("new ");
    f.write("");
    f.write(std::string("con\0tents", 9));
    EXPECT_EQ(slurp(file), "old");  // not yet
    f.commit();
    EXPECT_EQ(f.bytes_written(), 13u);
  }
  EXPECT_EQ(slurp(file), std::string("new con\0tents", 13));
  {
    AtomicFile abandoned(file);  // e.g. the producer threw
    abandoned.write("half");
  }
  EXPECT_EQ(slurp(file), std::string("new con\0tents", 13));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 1);
  EXPECT_THROW(AtomicFile(path("missing/blob.bin")), std::runtime_error);
}

// --- read_whole_file ---------------------------------------------------------------------------

TEST_F(FileIoTest, ReadWholeFileReadsUpToTheBoundAndNamesTheFileOtherwise) {
  const std::string binary("a\0b\nc\xff", 6);
  write_bytes("data.bin", binary);
  EXPECT_EQ(read_whole_file(path("data.bin"), 6, "data file"), binary);
  const auto error = [&](const std::string& file, std::uintmax_t max_bytes) -> std::string {
    try {
      read_whole_file(file, max_bytes, "data file", " named in test.yaml");
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    return "(no error)";
  };
  EXPECT_EQ(error(path("data.bin"), 5), path("data.bin") +
                                            ": cannot read data file named in test.yaml: file is 6 "
                                            "bytes, more than the 5 allowed");
  EXPECT_EQ(error(path("missing.bin"), 5).rfind(path("missing.bin") + ": cannot read data file", 0),
            0u);
  EXPECT_EQ(error(dir_.string(), 5),
            dir_.string() + ": cannot read data file named in test.yaml: not a regular file");
}

}  // namespace
}  // namespace esfleet
