#include "peha/config/atomic_file.hpp"

#include <fmt/format.h>

#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <fcntl.h>
#include <fstream>
#include <stdexcept>
#include <unistd.h>

namespace peha::config {

void write_file_atomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& body) {
  std::filesystem::path tmp = path;
  tmp += fmt::format(".tmp-{}", ::getpid());
  struct Remove {
    const std::filesystem::path& p;
    bool armed = true;
    ~Remove() {
      std::error_code ec;
      if (armed) std::filesystem::remove(p, ec);
    }
  } cleanup{tmp};
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw std::runtime_error(fmt::format("{}: cannot write (does the directory exist and is it writable?)", path.string()));
    body(out);
    out.flush();
    if (!out) throw std::runtime_error(fmt::format("{}: write failed (disk full?); the previous file is unchanged", path.string()));
  }
  // The bytes must be on the disk before the name points at them.
  const int fd = ::open(tmp.c_str(), O_RDONLY);
  const bool synced = fd >= 0 && ::fsync(fd) == 0;
  if (fd >= 0) ::close(fd);
  if (!synced) throw std::runtime_error(fmt::format("{}: fsync failed; the previous file is unchanged", path.string()));
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) throw std::runtime_error(fmt::format("{}: cannot replace: {}", path.string(), ec.message()));
  cleanup.armed = false;
}

bool parse_decimal(const std::string& text, double& out) noexcept {
  std::size_t i = 0;
  const std::size_t n = text.size();
  const auto digits_from = [&](std::size_t& k) {
    std::size_t count = 0;
    while (k < n && std::isdigit(static_cast<unsigned char>(text[k]))) ++k, ++count;
    return count;
  };
  if (i < n && (text[i] == '+' || text[i] == '-')) ++i;
  std::size_t digits = digits_from(i);
  if (i < n && text[i] == '.') {
    ++i;
    digits += digits_from(i);
  }
  if (digits == 0) return false;
  if (i < n && (text[i] == 'e' || text[i] == 'E')) {
    ++i;
    if (i < n && (text[i] == '+' || text[i] == '-')) ++i;
    if (digits_from(i) == 0) return false;
  }
  if (i != n) return false;
  const char* first = text.data() + (text[0] == '+' ? 1 : 0);
  const auto [end, ec] = std::from_chars(first, text.data() + n, out, std::chars_format::general);
  return ec == std::errc() && end == text.data() + n && std::isfinite(out);
}

}  // namespace peha::config
