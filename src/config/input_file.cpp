#include "peha/config/input_file.hpp"

#include "peha/config/reader.hpp"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace peha::config {

std::size_t max_input_bytes(InputKind kind) noexcept {
  switch (kind) {
    case InputKind::kConfig: return kMaxFileBytes;
    case InputKind::kCalibrationCsv: return std::size_t{512} << 20;
    case InputKind::kCsv: return std::size_t{64} << 20;
    case InputKind::kLog: return std::size_t{1} << 30;
    case InputKind::kKey: return 4096;
  }
  return 0;
}

const char* input_kind_name(InputKind kind) noexcept {
  switch (kind) {
    case InputKind::kConfig: return "config file";
    case InputKind::kCalibrationCsv: return "calibration CSV";
    case InputKind::kCsv: return "CSV file";
    case InputKind::kLog: return "log";
    case InputKind::kKey: return "key file";
  }
  return "file";
}

namespace {

std::string size_text(std::size_t bytes) {
  constexpr std::size_t kMiB = std::size_t{1} << 20;
  if (bytes < kMiB) return fmt::format("{} bytes", bytes);
  return bytes % kMiB == 0 ? fmt::format("{} MiB", bytes / kMiB) : fmt::format("{:.1f} MiB", static_cast<double>(bytes) / kMiB);
}

const char* file_type(mode_t mode) {
  if (S_ISDIR(mode)) return "a folder";
  if (S_ISFIFO(mode)) return "a pipe (FIFO)";
  if (S_ISCHR(mode) || S_ISBLK(mode)) return "a device";
  if (S_ISSOCK(mode)) return "a socket";
  return "a special file";
}

}  // namespace

std::string read_input_file(const std::filesystem::path& path, InputKind kind) {
  const std::string name = path.string();
  const char* what = input_kind_name(kind);
  const std::size_t limit = max_input_bytes(kind);
  // O_NONBLOCK: opening a FIFO without a writer returns at once (and is refused below) instead of
  // waiting forever. The type is judged on the descriptor that is read, not on a name that may change.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    const int err = errno;
    throw InputFileError(fmt::format("{}: cannot open the {}: {}", name, what,
                                     err == ENOENT ? "no such file" : std::strerror(err)));
  }
  struct Close {
    int fd;
    ~Close() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw InputFileError(fmt::format("{}: cannot read the {}: {}", name, what, std::strerror(errno)));
  if (!S_ISREG(st.st_mode)) {
    throw InputFileError(fmt::format("{}: not a regular file ({}): a {} must be a regular file", name, file_type(st.st_mode), what));
  }
  if (static_cast<std::uintmax_t>(st.st_size) > limit) {
    throw InputFileError(fmt::format("{}: {} is larger than the {} a {} may have (is this the right file?)", name,
                                     size_text(static_cast<std::size_t>(st.st_size)), size_text(limit), what));
  }
  // A regular file never blocks; clear O_NONBLOCK anyway so a read is never short for that reason.
  ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) & ~O_NONBLOCK);
  std::string bytes;
  bytes.reserve(static_cast<std::size_t>(st.st_size));
  char chunk[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, chunk, sizeof chunk);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw InputFileError(fmt::format("{}: read error in the {}: {}", name, what, std::strerror(errno)));
    }
    if (n == 0) break;
    bytes.append(chunk, static_cast<std::size_t>(n));
    if (bytes.size() > limit) {
      throw InputFileError(fmt::format("{}: grew beyond the {} a {} may have while it was read", name, size_text(limit), what));
    }
  }
  return bytes;
}

}  // namespace peha::config
