#include "peha/app/cli_checks.hpp"

#include "peha/config/atomic_file.hpp"

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

void refuse_output_equal_to_input(const std::filesystem::path& out, std::initializer_list<std::filesystem::path> inputs,
                                  const char* option) {
  std::error_code ec;
  const std::filesystem::path out_resolved = std::filesystem::weakly_canonical(out, ec);
  for (const std::filesystem::path& in : inputs) {
    if (in.empty()) continue;
    std::error_code e1;
    const bool same = std::filesystem::exists(out, e1) ? std::filesystem::equivalent(out, in, e1)
                                                       : out_resolved == std::filesystem::weakly_canonical(in, e1);
    if (same) {
      throw UsageError(fmt::format("{} {} is the input {}: refusing to overwrite it; choose another file",
                                              option, out.string(), in.string()));
    }
  }
}

}  // namespace peha::app
