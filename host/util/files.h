// Files in and out: whole regular files read with a size limit, and output written so that it
// appears complete or not at all, to special files directly, with temporaries removed on
// SIGINT and SIGTERM (issue 11, defects 2, 5 and 8).
#pragma once
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace basalt {

/// Largest input file basalt reads whole (scene, Include, PLY, images): 4 GiB.
constexpr std::uint64_t kMaxInputBytes = std::uint64_t(1) << 32;

/// \brief Why reading or writing a file failed: the system's reason, without the path (the
///        caller adds the path and where it was named).
struct FileError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// \brief Size in bytes of the regular file \p path.
/// \throws FileError for a missing file, a directory, a FIFO, socket or device (which could
///         block or never end), or a file larger than \p max_bytes.
std::uint64_t regular_file_size(const std::string& path, std::uint64_t max_bytes = kMaxInputBytes);

/// \brief The whole content of the regular file \p path (checked as regular_file_size).
std::string read_regular_file(const std::string& path, std::uint64_t max_bytes = kMaxInputBytes);

/// \brief Checks, before any work, that \p path can be written: an existing special file
///        (FIFO, terminal, /dev/null) opened for writing, or a regular file or new name whose
///        directory exists and is writable.
/// \throws FileError with the reason.
void check_writable(const std::string& path);

/// \brief Writes \p bytes to \p path. A special file (FIFO, character device, or a symlink to
///        one, such as /dev/stdout) receives them directly; a regular file (or a symlink to one:
///        the link is kept, its target replaced) gets a temporary file in the same directory,
///        renamed into place, so it appears complete or not at all. The temporary is removed on
///        failure and when SIGINT or SIGTERM arrives while it exists.
/// \throws FileError naming the reason (write errors such as ENOSPC included).
void write_file_bytes(const std::string& path, const std::string& bytes);

/// \brief Installs the SIGINT/SIGTERM/SIGHUP handler that removes pending temporaries and then
///        dies of the signal (idempotent; write_file_bytes calls it).
void install_cleanup_handlers();

}  // namespace basalt
