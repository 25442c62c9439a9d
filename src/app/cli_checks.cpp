#include "peha/app/cli_checks.hpp"

#include "peha/config/atomic_file.hpp"
#include "peha/config/input_file.hpp"

#include <yaml-cpp/yaml.h>

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <stdexcept>

namespace peha::app {
namespace {

bool all_digits(const std::string& s, std::size_t from) {
  return s.size() > from && std::all_of(s.begin() + static_cast<std::ptrdiff_t>(from), s.end(),
                                        [](unsigned char c) { return std::isdigit(c) != 0; });
}

}  // namespace

const CLI::Validator& decimal() {
  static const CLI::Validator v(
      [](std::string& text) -> std::string {
        double x = 0;
        return config::parse_decimal(text, x) ? std::string() : fmt::format("expected a decimal number (e.g. 0.25 or 2.5e-3), found '{}'", text);
      },
      "DECIMAL");
  return v;
}

const CLI::Validator& unsigned_integer() {
  static const CLI::Validator v(
      [](std::string& text) -> std::string {
        return all_digits(text, 0) && text.size() <= 19 ? std::string()
                                                        : fmt::format("expected a non-negative integer (digits only), found '{}'", text);
      },
      "UINT");
  return v;
}

const CLI::Validator& signed_integer() {
  static const CLI::Validator v(
      [](std::string& text) -> std::string {
        const std::size_t from = !text.empty() && text[0] == '-' ? 1 : 0;
        return all_digits(text, from) && text.size() <= 18 ? std::string() : fmt::format("expected an integer, found '{}'", text);
      },
      "INT");
  return v;
}

const CLI::Validator& run_name() {
  static const CLI::Validator v(
      [](std::string& text) -> std::string {
        const bool chars_ok = std::all_of(text.begin(), text.end(), [](unsigned char c) {
          return std::isalnum(c) != 0 || c == '.' || c == '_' || c == '+' || c == '-';
        });
        if (text.empty() || text.size() > 100 || !chars_ok || text[0] == '.' || text[0] == '-') {
          return fmt::format("expected one folder name of letters, digits and . _ + - (not starting with . or -, "
                             "at most 100 characters), found '{}'", text);
        }
        return {};
      },
      "NAME");
  return v;
}

void refuse_unsafe_output(const std::filesystem::path& out, const std::vector<std::filesystem::path>& inputs, const char* option) {
  std::error_code ec;
  // symlink_status: a link is judged by what it points at below (equivalent), a dangling one is new.
  const std::filesystem::file_status st = std::filesystem::status(out, ec);
  if (std::filesystem::exists(st) && !std::filesystem::is_regular_file(st)) {
    const char* what = std::filesystem::is_directory(st) ? "a folder" : std::filesystem::is_fifo(st) ? "a pipe (FIFO)"
                     : std::filesystem::is_character_file(st) || std::filesystem::is_block_file(st) ? "a device" : "not a regular file";
    throw UsageError(fmt::format("{} {} is {}: an output file replaces only a regular file; choose another file", option, out.string(), what));
  }
  const std::filesystem::path out_resolved = std::filesystem::weakly_canonical(out, ec);
  for (const std::filesystem::path& in : inputs) {
    if (in.empty()) continue;
    std::error_code e1;
    const bool same = std::filesystem::exists(out, e1) ? std::filesystem::equivalent(out, in, e1)
                                                       : out_resolved == std::filesystem::weakly_canonical(in, e1);
    if (same) {
      throw UsageError(fmt::format("{} {} is the input {}: refusing to overwrite it; choose another file", option, out.string(), in.string()));
    }
  }
}

namespace {

// Every string value of `node` that, resolved against `directory`, is an existing regular file.
void collect_files(const YAML::Node& node, const std::filesystem::path& directory, std::vector<std::filesystem::path>& out) {
  if (node.IsMap()) {
    for (const auto& kv : node) collect_files(kv.second, directory, out);
  } else if (node.IsSequence()) {
    for (const auto& item : node) collect_files(item, directory, out);
  } else if (node.IsScalar()) {
    const std::string& text = node.Scalar();
    if (text.empty() || text.size() > 4096 || text.find('\n') != std::string::npos) return;
    std::filesystem::path p = text;
    if (p.is_relative()) p = directory / p;
    std::error_code ec;
    if (std::filesystem::is_regular_file(p, ec)) out.push_back(p);
  }
}

// `file` and the files it names, the YAML ones among them in turn, `depth` levels deep.
void collect_inputs(const std::filesystem::path& file, int depth, std::vector<std::filesystem::path>& out) {
  out.push_back(file);
  const std::string ext = file.extension().string();
  if (depth == 0 || (ext != ".yaml" && ext != ".yml")) return;
  std::vector<std::filesystem::path> named;
  try {
    collect_files(YAML::Load(config::read_input_file(file, config::InputKind::kConfig)), file.parent_path(), named);
  } catch (const std::exception&) {
    return;  // not this function's to judge: the file's own reader reports it with its schema
  }
  for (const std::filesystem::path& p : named) collect_inputs(p, depth - 1, out);
}

}  // namespace

std::vector<std::filesystem::path> scenario_inputs(const std::filesystem::path& config) {
  std::vector<std::filesystem::path> inputs;
  collect_inputs(config, 3, inputs);
  return inputs;
}

}  // namespace peha::app
