#pragma once
/// \file
/// Writing a file so that a reader never sees half of it and a failed write never replaces a good
/// file: the text goes to a sibling temporary (`<name>.tmp-<pid>`), is flushed and synced, and only
/// then renamed over the target (rename is atomic within a directory on POSIX file systems).

#include <filesystem>
#include <functional>
#include <ostream>

namespace peha::config {

/// Calls `body` with a stream to a temporary beside `path`; if `body` returns and every byte reached
/// the disk, renames the temporary to `path`. Otherwise removes the temporary, leaves `path` as it
/// was, and throws std::runtime_error naming `path` (an exception from `body` passes through).
void write_file_atomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& body);

/// Parses a plain decimal number, the only form peha reads from files and command lines:
/// [+-]digits[.digits][(e|E)[+-]digits]. No hex, inf, nan, spaces or separators; finite. The same
/// rule as config::Map::number.
bool parse_decimal(const std::string& text, double& out) noexcept;

}  // namespace peha::config
