// Scratch directories for the files a test writes: one per tag and process (ctest runs the
// tests as parallel processes), removed with their contents when the process exits, so a
// test run leaves nothing in the temporary directory.
#pragma once
#include <unistd.h>

#include <filesystem>
#include <mutex>
#include <set>
#include <string>
#include <system_error>

namespace basalt::test {

/// The directory basalt-<tag>-<pid> under the system's temporary directory, created empty on
/// the first call for \p tag and removed, with everything in it, at exit; later calls keep its
/// files unless \p fresh, which empties it again.
inline std::filesystem::path scratch_dir(const std::string& tag, bool fresh = false) {
  struct Made {
    std::mutex mutex;
    std::set<std::filesystem::path> dirs;
    ~Made() {
      for (const std::filesystem::path& d : dirs) {
        std::error_code ec;
        std::filesystem::remove_all(d, ec);
      }
    }
  };
  static Made made;
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("basalt-" + tag + "-" + std::to_string(::getpid()));
  std::lock_guard<std::mutex> lock(made.mutex);
  const bool first = made.dirs.insert(dir).second;
  if (fresh || first) {
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
  }
  return dir;
}

/// scratch_dir(tag) emptied: a fresh directory for one test.
inline std::filesystem::path fresh_scratch_dir(const std::string& tag) {
  return scratch_dir(tag, true);
}

}  // namespace basalt::test
