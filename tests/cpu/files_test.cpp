// util/files: regular files only on input, and output that appears whole or not at all, goes
// straight into special files and reports write errors (issue 11, defects 2 and 8).
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <thread>

#include "common/scratch_dir.h"
#include "util/files.h"

namespace fs = std::filesystem;

namespace {

/// A fresh empty directory of this process (removed at exit).
fs::path temp_dir(const std::string& name) { return basalt::test::fresh_scratch_dir("files-" + name); }

/// The whole content of a file.
std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// The message of the FileError that f throws ("" if none).
template <typename F>
std::string file_error(F f) {
  try {
    f();
  } catch (const basalt::FileError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Files, ReadsRegularFilesOnlyAndNeverBlocks) {
  const fs::path d = temp_dir("read");
  std::ofstream(d / "a.txt") << "hello";
  EXPECT_EQ(basalt::read_regular_file((d / "a.txt").string()), "hello");
  EXPECT_EQ(file_error([&] { basalt::read_regular_file((d / "a.txt").string(), 4); }),
            "is 5 bytes, more than basalt's limit of 4");
  EXPECT_EQ(file_error([&] { basalt::read_regular_file(d.string()); }), "is a directory");
  EXPECT_EQ(file_error([] { basalt::read_regular_file("/dev/zero"); }),
            "is a device, not a regular file");
  EXPECT_EQ(file_error([&] { basalt::read_regular_file((d / "none").string()); }),
            "No such file or directory");
  // A FIFO without a writer: refused at once (opening it would wait for ever).
  ASSERT_EQ(::mkfifo((d / "f").c_str(), 0600), 0);
  EXPECT_EQ(file_error([&] { basalt::read_regular_file((d / "f").string()); }),
            "is a FIFO, not a regular file");
  EXPECT_EQ(file_error([&] { basalt::regular_file_size((d / "f").string()); }),
            "is a FIFO, not a regular file");
}

TEST(Files, RegularOutputIsReplacedWholeAndLinksAreKept) {
  const fs::path d = temp_dir("write");
  basalt::write_file_bytes((d / "out.bin").string(), "first");
  basalt::write_file_bytes((d / "out.bin").string(), "second");
  EXPECT_EQ(slurp(d / "out.bin"), "second");
  fs::create_symlink("out.bin", d / "link.bin");
  basalt::write_file_bytes((d / "link.bin").string(), "third");
  EXPECT_TRUE(fs::is_symlink(d / "link.bin"));
  EXPECT_EQ(slurp(d / "out.bin"), "third");
  // Nothing but the outputs is left in the directory (no temporary files).
  EXPECT_EQ(std::distance(fs::directory_iterator(d), fs::directory_iterator()), 2);
  // A directory, or a missing directory, is an error that leaves nothing behind.
  EXPECT_EQ(file_error([&] { basalt::write_file_bytes(d.string(), "x"); }), "is a directory");
  EXPECT_EQ(file_error([&] { basalt::write_file_bytes((d / "no/x.bin").string(), "x"); }),
            "No such file or directory");
  EXPECT_EQ(std::distance(fs::directory_iterator(d), fs::directory_iterator()), 2);
}

TEST(Files, SpecialFilesGetTheBytesDirectly) {
  const fs::path d = temp_dir("special");
  // A FIFO keeps being a FIFO, and its reader gets every byte.
  ASSERT_EQ(::mkfifo((d / "p").c_str(), 0600), 0);
  std::string got;
  std::thread reader([&] { got = slurp(d / "p"); });
  const std::string big(1 << 20, 'x');  // more than a pipe buffer
  basalt::write_file_bytes((d / "p").string(), big);
  reader.join();
  EXPECT_EQ(got.size(), big.size());
  struct stat st {};
  ASSERT_EQ(::stat((d / "p").c_str(), &st), 0);
  EXPECT_TRUE(S_ISFIFO(st.st_mode));
  // /dev/full (through a link, as /dev/stdout is one): the write error is reported, and the
  // device is left alone.
  fs::create_symlink("/dev/full", d / "full");
  EXPECT_EQ(file_error([&] { basalt::write_file_bytes((d / "full").string(), "x"); }),
            "No space left on device");
  ASSERT_EQ(::stat("/dev/full", &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));
  basalt::write_file_bytes("/dev/null", "discarded");
  ASSERT_EQ(::stat("/dev/null", &st), 0);
  EXPECT_TRUE(S_ISCHR(st.st_mode));
}

TEST(Files, WritabilityIsCheckedBeforeTheWork) {
  const fs::path d = temp_dir("check");
  EXPECT_EQ(file_error([&] { basalt::check_writable((d / "new.exr").string()); }), "");
  EXPECT_EQ(file_error([] { basalt::check_writable("/dev/null"); }), "");
  EXPECT_EQ(file_error([&] { basalt::check_writable(d.string()); }), "is a directory");
  EXPECT_NE(file_error([&] { basalt::check_writable((d / "no/such/x.exr").string()); })
                .find("No such file or directory"),
            std::string::npos);
  std::ofstream(d / "file") << "x";
  EXPECT_NE(file_error([&] { basalt::check_writable((d / "file/x.exr").string()); })
                .find("is not a directory"),
            std::string::npos);
}
