#include "peha/config/reader.hpp"

#include "peha/config/atomic_file.hpp"
#include "peha/config/input_file.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

namespace peha::config {
namespace {

std::string describe(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Null:
      return "null";
    case YAML::NodeType::Scalar:
      return fmt::format("'{}'", node.Scalar());
    case YAML::NodeType::Sequence:
      return fmt::format("a list of {}", node.size());
    case YAML::NodeType::Map:
      return "a mapping";
    default:
      return "nothing";
  }
}

std::string position(const std::string& file, const YAML::Mark& mark) {
  if (mark.is_null()) return file;
  return fmt::format("{}:{}:{}", file, mark.line + 1, mark.column + 1);
}

// Edit distance (Levenshtein, with a swap of two neighbours counting one) between two keys.
std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
  for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    for (std::size_t j = 1; j <= b.size(); ++j) {
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  }
  return d[a.size()][b.size()];
}

}  // namespace

std::string closest_name(std::string_view name, const std::vector<std::string>& candidates, std::size_t max_edits) {
  std::string best;
  std::size_t best_d = max_edits + 1;
  for (const std::string& c : candidates) {
    const std::size_t d = edit_distance(name, c);
    if (d < best_d) best_d = d, best = c;
  }
  return best;
}

namespace {

// The candidate nearest to `key` if it is near enough to be a misspelling of it: at most 2 edits, or
// a quarter of the key's length for long keys ("pressure_rate_MPa_s" for "pressure_rate_MPa_per_s").
std::string nearest(std::string_view key, const std::vector<std::string>& candidates) {
  return closest_name(key, candidates, std::max<std::size_t>(2, key.size() / 4));
}

}  // namespace

Document Document::load_file(const std::filesystem::path& path) {
  std::string text;
  try {
    text = read_input_file(path, InputKind::kConfig);
  } catch (const InputFileError& e) {
    throw Error(e.what());
  }
  Document doc = load_string(text, path.string());
  doc.directory_ = path.parent_path();
  return doc;
}

Document Document::load_string(const std::string& text, const std::string& name) {
  Document doc;
  doc.name_ = std::make_shared<const std::string>(name);
  doc.directory_ = ".";
  try {
    doc.node_ = YAML::Load(text);
  } catch (const YAML::ParserException& e) {
    throw Error(fmt::format("{}: not valid YAML: {}", position(name, e.mark), e.msg));
  }
  if (!doc.node_.IsMap()) {
    throw Error(fmt::format("{}: expected a mapping at the top level, found {}", name,
                            describe(doc.node_)));
  }
  return doc;
}

Map Document::root() const { return Map(node_, name_, "", directory_); }

Map::Map(YAML::Node node, std::shared_ptr<const std::string> file, std::string path,
         std::filesystem::path directory)
    : node_(std::move(node)),
      file_(std::move(file)),
      path_(std::move(path)),
      directory_(std::move(directory)) {}

bool Map::has(std::string_view key) const {
  asked_.emplace(key);  // a key the schema knows, present or not: a candidate for "did you mean"
  return static_cast<bool>(node_[std::string(key)]);
}

std::string Map::key_path(std::string_view key) const {
  if (key.empty()) return path_.empty() ? "<root>" : path_;
  return path_.empty() ? std::string(key) : fmt::format("{}.{}", path_, key);
}

void Map::fail_at(const YAML::Node& node, std::string_view key, const std::string& reason) const {
  throw Error(fmt::format("{}: {}: {}", position(*file_, node.Mark()), key_path(key), reason));
}

void Map::fail(std::string_view key, const std::string& reason) const {
  const YAML::Node value = key.empty() ? node_ : node_[std::string(key)];
  fail_at(value ? value : node_, key, reason);
}

YAML::Node Map::required(std::string_view key) {
  used_.emplace(key);
  YAML::Node value = node_[std::string(key)];
  if (!value) {
    // A key present but not (yet) read that is one or two typing errors away is most likely this one.
    std::vector<std::string> unread;
    for (const auto& item : node_) {
      if (!used_.contains(item.first.Scalar())) unread.push_back(item.first.Scalar());
    }
    const std::string near = nearest(key, unread);
    fail_at(node_, key, near.empty() ? "missing required key" : fmt::format("missing required key (did you mean '{}', given here?)", near));
  }
  return value;
}


double Map::to_number(const YAML::Node& value, std::string_view key, Range range) const {
  const std::string expected = fmt::format("expected a number in [{}, {}]", range.min, range.max);
  if (!value.IsScalar()) fail_at(value, key, fmt::format("{}, found {}", expected, describe(value)));
  double x = 0.0;
  if (!parse_decimal(value.Scalar(), x)) {
    fail_at(value, key, fmt::format("{} (decimal, e.g. 0.25 or 2.5e-3), found {}", expected, describe(value)));
  }
  if (!std::isfinite(x) || x < range.min || x > range.max) {
    fail_at(value, key, fmt::format("{}, found {}", expected, value.Scalar()));
  }
  return x;
}

double Map::number(std::string_view key, Range range) {
  return to_number(required(key), key, range);
}

double Map::number_or(std::string_view key, double fallback, Range range) {
  return has(key) ? number(key, range) : (used_.emplace(key), fallback);
}

long Map::integer(std::string_view key, long min, long max) {
  const YAML::Node value = required(key);
  const double x = to_number(value, key, {static_cast<double>(min), static_cast<double>(max)});
  if (std::floor(x) != x) {
    fail_at(value, key, fmt::format("expected an integer in [{}, {}], found {}", min, max,
                                    value.Scalar()));
  }
  return static_cast<long>(x);
}

bool Map::boolean(std::string_view key) {
  const YAML::Node value = required(key);
  if (value.IsScalar()) {
    const std::string& s = value.Scalar();
    if (s == "true") return true;
    if (s == "false") return false;
  }
  fail_at(value, key, fmt::format("expected true or false, found {}", describe(value)));
}

bool Map::boolean_or(std::string_view key, bool fallback) {
  return has(key) ? boolean(key) : (used_.emplace(key), fallback);
}

std::string Map::string(std::string_view key) {
  const YAML::Node value = required(key);
  if (!value.IsScalar() || value.Scalar().empty()) {
    fail_at(value, key, fmt::format("expected a non-empty string, found {}", describe(value)));
  }
  return value.Scalar();
}

std::string Map::choice(std::string_view key, const std::vector<std::string>& options) {
  const YAML::Node value = required(key);
  const std::string s = value.IsScalar() ? value.Scalar() : std::string();
  for (const auto& option : options) {
    if (s == option) return s;
  }
  fail_at(value, key,
          fmt::format("expected one of {{{}}}, found {}", fmt::join(options, ", "), describe(value)));
}

std::vector<std::string> Map::choices(std::string_view key, const std::vector<std::string>& options, std::size_t min_count,
                                      std::size_t max_count) {
  const YAML::Node value = required(key);
  if (!value.IsSequence() || value.size() < min_count || value.size() > max_count) {
    fail_at(value, key, fmt::format("expected a list of {} to {} of {{{}}}, found {}", min_count, max_count, fmt::join(options, ", "),
                                    describe(value)));
  }
  std::vector<std::string> out;
  for (std::size_t i = 0; i < value.size(); ++i) {
    const YAML::Node item = value[i];
    const std::string s = item.IsScalar() ? item.Scalar() : std::string();
    const std::string item_key = fmt::format("{}[{}]", key, i);
    if (std::find(options.begin(), options.end(), s) == options.end()) {
      fail_at(item, item_key, fmt::format("expected one of {{{}}}, found {}", fmt::join(options, ", "), describe(item)));
    }
    if (std::find(out.begin(), out.end(), s) != out.end()) fail_at(item, item_key, fmt::format("'{}' is listed twice", s));
    out.push_back(s);
  }
  return out;
}

std::vector<std::string> Map::strings(std::string_view key, std::size_t min_count, std::size_t max_count) {
  const YAML::Node value = required(key);
  if (!value.IsSequence() || value.size() < min_count || value.size() > max_count) {
    fail_at(value, key, fmt::format("expected a list of {} to {} strings, found {}", min_count, max_count, describe(value)));
  }
  std::vector<std::string> out;
  for (std::size_t i = 0; i < value.size(); ++i) {
    const YAML::Node item = value[i];
    const std::string item_key = fmt::format("{}[{}]", key, i);
    if (!item.IsScalar() || item.Scalar().empty()) fail_at(item, item_key, fmt::format("expected a non-empty string, found {}", describe(item)));
    if (std::find(out.begin(), out.end(), item.Scalar()) != out.end()) fail_at(item, item_key, fmt::format("'{}' is listed twice", item.Scalar()));
    out.push_back(item.Scalar());
  }
  return out;
}

std::vector<double> Map::numbers(std::string_view key, Range range, std::size_t min_count,
                                 std::size_t max_count) {
  const YAML::Node value = required(key);
  if (!value.IsSequence() || value.size() < min_count || value.size() > max_count) {
    fail_at(value, key,
            fmt::format("expected a list of {} to {} numbers, found {}", min_count, max_count,
                        describe(value)));
  }
  std::vector<double> out;
  out.reserve(value.size());
  for (std::size_t i = 0; i < value.size(); ++i) {
    out.push_back(to_number(value[i], fmt::format("{}[{}]", key, i), range));
  }
  return out;
}

std::vector<std::vector<double>> Map::number_rows(std::string_view key, Range range, std::size_t min_rows,
                                                  std::size_t max_rows, std::size_t cols) {
  const YAML::Node value = required(key);
  if (!value.IsSequence() || value.size() < min_rows || value.size() > max_rows) {
    fail_at(value, key, fmt::format("expected a list of {} to {} rows, found {}", min_rows, max_rows, describe(value)));
  }
  std::vector<std::vector<double>> out;
  out.reserve(value.size());
  for (std::size_t i = 0; i < value.size(); ++i) {
    const YAML::Node row = value[i];
    const std::string row_key = fmt::format("{}[{}]", key, i);
    if (!row.IsSequence() || row.size() != cols) {
      fail_at(row, row_key, fmt::format("expected a list of {} numbers, found {}", cols, describe(row)));
    }
    std::vector<double> r;
    r.reserve(cols);
    for (std::size_t j = 0; j < cols; ++j) r.push_back(to_number(row[j], fmt::format("{}[{}]", row_key, j), range));
    out.push_back(std::move(r));
  }
  return out;
}

std::filesystem::path Map::path_value(std::string_view key) {
  std::filesystem::path p = string(key);
  return p.is_absolute() ? p : directory_ / p;
}

Map Map::map(std::string_view key) {
  const YAML::Node value = required(key);
  if (!value.IsMap()) fail_at(value, key, fmt::format("expected a mapping, found {}", describe(value)));
  return Map(value, file_, key_path(key), directory_);
}

std::vector<Map> Map::maps(std::string_view key, std::size_t min_count, std::size_t max_count) {
  const YAML::Node value = required(key);
  if (!value.IsSequence() || value.size() < min_count || value.size() > max_count) {
    fail_at(value, key,
            fmt::format("expected a list of {} to {} mappings, found {}", min_count, max_count,
                        describe(value)));
  }
  std::vector<Map> out;
  for (std::size_t i = 0; i < value.size(); ++i) {
    const std::string item_key = fmt::format("{}[{}]", key, i);
    if (!value[i].IsMap()) {
      fail_at(value[i], item_key, fmt::format("expected a mapping, found {}", describe(value[i])));
    }
    out.emplace_back(value[i], file_, key_path(item_key), directory_);
  }
  return out;
}

void Map::finish() const {
  std::set<std::string, std::less<>> seen;
  for (const auto& item : node_) {
    const std::string key = item.first.Scalar();
    if (!used_.contains(key)) {
      std::vector<std::string> known(used_.begin(), used_.end());
      for (const std::string& k : asked_) {
        if (!used_.contains(k)) known.push_back(k);
      }
      const std::string near = nearest(key, known);
      fail_at(item.first, key, near.empty() ? fmt::format("unknown key; known keys here: {}", fmt::join(known, ", "))
                                            : fmt::format("unknown key; did you mean '{}'?", near));
    }
    // yaml-cpp keeps both entries of a repeated key and reads the first: say so instead.
    if (!seen.insert(key).second) fail_at(item.first, key, "duplicate key");
  }
}

}  // namespace peha::config
