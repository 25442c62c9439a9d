#pragma once
/// \file
/// Strict YAML reading into typed structs.
///
/// Every config file is read through `config::Map`: each accessor names the key, the allowed range
/// and (in the key's name) the unit. Anything the schema does not expect is an error: unknown keys
/// (reported by `Map::finish()`), missing keys, wrong types and out-of-range values. Errors carry the
/// file, line, column, the key path and expected-vs-found, e.g.
///
///     configs/e1.yaml:14:18: plant.valve.lag_s: expected a number in [0.0001, 1], found -0.02
///
/// Parsing is set-up code: it throws `config::Error`; nothing here is used in the control loop.

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace peha::config {

/// A configuration error, with where and why.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

/// Inclusive numeric range accepted for a value.
struct Range {
  double min;
  double max;
};

class Map;

/// The candidate with the fewest edits (insertions, deletions, substitutions, swaps) from `name`,
/// if at most `max_edits`; "" otherwise. For "did you mean" in messages.
std::string closest_name(std::string_view name, const std::vector<std::string>& candidates, std::size_t max_edits);

/// A parsed YAML document with the file name kept for error messages.
/// Largest YAML file read (a calibration with M = 2000 pseudo-inputs is about 100 MiB).
inline constexpr std::size_t kMaxFileBytes = std::size_t{256} << 20;

class Document {
 public:
  /// Reads and parses `path`; throws `Error` if the file is missing or not valid YAML.
  static Document load_file(const std::filesystem::path& path);
  /// Parses `text` as if it came from a file named `name` (for tests and embedded configs).
  static Document load_string(const std::string& text, const std::string& name = "<string>");

  /// The top-level mapping.
  Map root() const;
  const std::string& name() const { return *name_; }
  /// Directory the file lives in; relative paths inside the file are resolved against it.
  const std::filesystem::path& directory() const { return directory_; }

 private:
  YAML::Node node_;
  std::shared_ptr<const std::string> name_;
  std::filesystem::path directory_;
};

/// A YAML mapping under strict reading. Keeps track of the keys that were read so that
/// `finish()` can reject every key the schema did not ask for.
class Map {
 public:
  Map(YAML::Node node, std::shared_ptr<const std::string> file, std::string path,
      std::filesystem::path directory);

  /// True if `key` is present.
  bool has(std::string_view key) const;

  /// Required number within `range`.
  double number(std::string_view key, Range range);
  /// Optional number within `range`; `fallback` when absent.
  double number_or(std::string_view key, double fallback, Range range);
  /// Required integer within [min, max].
  long integer(std::string_view key, long min, long max);
  bool boolean(std::string_view key);
  bool boolean_or(std::string_view key, bool fallback);
  /// Required non-empty string.
  std::string string(std::string_view key);
  /// Required string that must be one of `options`.
  std::string choice(std::string_view key, const std::vector<std::string>& options);
  /// Required list of distinct strings, each one of `options`, with a length in [min_count, max_count].
  std::vector<std::string> choices(std::string_view key, const std::vector<std::string>& options, std::size_t min_count,
                                   std::size_t max_count);
  /// Required list of distinct non-empty strings, with a length in [min_count, max_count].
  std::vector<std::string> strings(std::string_view key, std::size_t min_count, std::size_t max_count);
  /// Required list of numbers, each within `range`, with a length in [min_count, max_count].
  std::vector<double> numbers(std::string_view key, Range range, std::size_t min_count,
                              std::size_t max_count);
  /// Required list of `cols`-long lists of numbers (a matrix, row by row), each within `range`.
  std::vector<std::vector<double>> number_rows(std::string_view key, Range range, std::size_t min_rows,
                                               std::size_t max_rows, std::size_t cols);
  /// Path value resolved relative to the file's directory.
  std::filesystem::path path_value(std::string_view key);

  /// Required nested mapping.
  Map map(std::string_view key);
  /// Required list of mappings, with a length in [min_count, max_count].
  std::vector<Map> maps(std::string_view key, std::size_t min_count, std::size_t max_count);

  /// Throws if the mapping holds a key that was never read.
  void finish() const;
  /// Refuses a key an older scenario format had (config::Error naming where it went: `now`), so an
  /// old file is not half read.
  void refuse_moved(std::string_view key, std::string_view now) const {
    if (node_[std::string(key)]) fail(key, "this key moved: " + std::string(now));
  }

  /// Throws `Error` about `key` (or the map itself when `key` is empty) with `reason`.
  [[noreturn]] void fail(std::string_view key, const std::string& reason) const;

  /// Dotted path of this mapping from the document root ("" for the root).
  const std::string& path() const { return path_; }
  const std::string& file() const { return *file_; }
  const std::filesystem::path& directory() const { return directory_; }

 private:
  YAML::Node required(std::string_view key);
  std::string key_path(std::string_view key) const;
  [[noreturn]] void fail_at(const YAML::Node& node, std::string_view key,
                            const std::string& reason) const;
  double to_number(const YAML::Node& value, std::string_view key, Range range) const;

  YAML::Node node_;
  std::shared_ptr<const std::string> file_;
  std::string path_;
  std::filesystem::path directory_;
  std::set<std::string, std::less<>> used_;
  /// Keys asked about with has() (optional keys of the schema): known too, for "did you mean".
  mutable std::set<std::string, std::less<>> asked_;
};

}  // namespace peha::config
