// Files in and out: whole regular files read with a size limit, and output written so that it
// appears complete or not at all, to special files directly, with temporaries removed on
// SIGINT and SIGTERM.
#include "util/files.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>

namespace basalt {

namespace {

namespace fs = std::filesystem;

/// The reason for errno, as text.
std::string reason(int err) { return std::strerror(err); }

/// What a stat mode is, for messages about files that are not regular.
std::string kind_of(mode_t m) {
  if (S_ISDIR(m)) return "is a directory";
  if (S_ISFIFO(m)) return "is a FIFO, not a regular file";
  if (S_ISCHR(m) || S_ISBLK(m)) return "is a device, not a regular file";
  if (S_ISSOCK(m)) return "is a socket, not a regular file";
  return "is not a regular file";
}

/// Pending temporary files, for the signal handler: fixed storage, no allocation in the handler.
constexpr int kSlots = 8;
char g_temp_names[kSlots][4096];
std::atomic<int> g_temp_used[kSlots];

/// Removes every pending temporary, then dies of the same signal (async-signal-safe calls only).
extern "C" void cleanup_and_die(int sig) {
  for (int i = 0; i < kSlots; ++i)
    if (g_temp_used[i].load() == 1) ::unlink(g_temp_names[i]);
  std::signal(sig, SIG_DFL);
  std::raise(sig);
}

/// Registers a temporary file name; returns its slot (or -1 when all are taken or it is too long).
int register_temp(const std::string& name) {
  if (name.size() >= sizeof(g_temp_names[0])) return -1;
  for (int i = 0; i < kSlots; ++i) {
    int expected = 0;  // claim (2), fill, then publish (1) to the handler
    if (g_temp_used[i].compare_exchange_strong(expected, 2)) {
      std::memcpy(g_temp_names[i], name.c_str(), name.size() + 1);
      g_temp_used[i].store(1);
      return i;
    }
  }
  return -1;
}

/// Writes all of \p bytes to the descriptor; returns 0 or the errno of the failure.
int write_all(int fd, const std::string& bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    done += std::size_t(n);
  }
  return 0;
}

/// Test hook: BASALT_TEST_SLOW_WRITE=S sleeps S seconds while a temporary file exists, so that
/// the CLI test can deliver a signal at that moment (tests/cli_special_test.sh).
void test_pause() {
  if (const char* s = std::getenv("BASALT_TEST_SLOW_WRITE")) ::sleep(unsigned(std::atoi(s)));
}

}  // namespace

std::uint64_t regular_file_size(const std::string& path, std::uint64_t max_bytes) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw FileError(reason(errno));
  if (!S_ISREG(st.st_mode)) throw FileError(kind_of(st.st_mode));
  if (std::uint64_t(st.st_size) > max_bytes)
    throw FileError("is " + std::to_string(st.st_size) + " bytes, more than basalt's limit of " +
                    std::to_string(max_bytes));
  return std::uint64_t(st.st_size);
}

std::string read_regular_file(const std::string& path, std::uint64_t max_bytes) {
  // O_NONBLOCK: opening a FIFO must not wait for a writer; fstat then checks what was opened.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) throw FileError(reason(errno));
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw FileError(reason(errno));
  if (!S_ISREG(st.st_mode)) throw FileError(kind_of(st.st_mode));
  if (std::uint64_t(st.st_size) > max_bytes)
    throw FileError("is " + std::to_string(st.st_size) + " bytes, more than basalt's limit of " +
                    std::to_string(max_bytes));
  std::string data(std::size_t(st.st_size), '\0');
  std::size_t done = 0;
  while (done < data.size()) {
    const ssize_t n = ::read(fd, data.data() + done, data.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw FileError(reason(errno));
    }
    if (n == 0) break;  // shrank while read: keep what is there
    done += std::size_t(n);
  }
  data.resize(done);
  return data;
}

void check_writable(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) {
    if (S_ISDIR(st.st_mode)) throw FileError("is a directory");
    if (::access(path.c_str(), W_OK) != 0) throw FileError(reason(errno));
    if (!S_ISREG(st.st_mode)) return;  // special files are written in place
  }
  // A new or replaced regular file: its directory must take the temporary file.
  fs::path dir = fs::path(path).parent_path();
  if (dir.empty()) dir = ".";
  struct stat ds {};
  if (::stat(dir.c_str(), &ds) != 0) throw FileError("directory " + dir.string() + ": " + reason(errno));
  if (!S_ISDIR(ds.st_mode)) throw FileError(dir.string() + " is not a directory");
  if (::access(dir.c_str(), W_OK | X_OK) != 0)
    throw FileError("directory " + dir.string() + ": " + reason(errno));
}

void install_cleanup_handlers() {
  static std::atomic<bool> done{false};
  if (done.exchange(true)) return;
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
    struct sigaction old {};
    if (::sigaction(sig, nullptr, &old) != 0 || old.sa_handler == SIG_IGN) continue;
    struct sigaction sa {};
    sa.sa_handler = cleanup_and_die;
    sigemptyset(&sa.sa_mask);
    ::sigaction(sig, &sa, nullptr);
  }
}

void write_file_bytes(const std::string& path, const std::string& bytes) {
  install_cleanup_handlers();
  struct stat st {};
  const bool exists = ::stat(path.c_str(), &st) == 0;
  if (exists && S_ISDIR(st.st_mode)) throw FileError("is a directory");
  if (exists && !S_ISREG(st.st_mode)) {
    // A FIFO, terminal or device (or a link to one, as /dev/stdout): write straight into it.
    const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
    if (fd < 0) throw FileError(reason(errno));
    const int err = write_all(fd, bytes);
    const int cerr = ::close(fd) != 0 ? errno : 0;
    if (err || cerr) throw FileError(reason(err ? err : cerr));
    return;
  }
  // A regular file: replace the link's target, not the link.
  std::string target = path;
  struct stat ls {};
  if (exists && ::lstat(path.c_str(), &ls) == 0 && S_ISLNK(ls.st_mode)) {
    std::error_code ec;
    const fs::path resolved = fs::canonical(path, ec);
    if (!ec) target = resolved.string();
  }
  static std::atomic<unsigned> counter{0};
  const std::string tmp = target + ".tmp-" + std::to_string(::getpid()) + "-" +
                          std::to_string(counter.fetch_add(1));
  const int slot = register_temp(tmp);
  auto release = [&] {
    if (slot >= 0) g_temp_used[slot].store(0);
  };
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
  if (fd < 0) {
    const int err = errno;
    release();
    throw FileError(reason(err));
  }
  int err = write_all(fd, bytes);
  test_pause();
  if (::close(fd) != 0 && !err) err = errno;
  if (!err && ::rename(tmp.c_str(), target.c_str()) != 0) err = errno;
  if (err) {
    ::unlink(tmp.c_str());
    release();
    throw FileError(reason(err));
  }
  release();
}

}  // namespace basalt
