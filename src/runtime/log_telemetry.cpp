#include "peha/runtime/log_telemetry.hpp"

#include "peha/models/units.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <stdexcept>
#include <string_view>

namespace peha::runtime {
namespace {

/// What a name can resolve to: a column, a column's degree view, an extra.
struct Available {
  std::string name;
  std::size_t source;
  double scale;
};

/// Every streamable name in the log's order: each column, then its degree view if it is in radians
/// (and the log has no column of that name), then the extras.
std::vector<Available> available_signals(const std::vector<std::string>& columns, const std::vector<std::string>& extras) {
  std::vector<Available> out;
  const double deg_per_rad = models::rad_to_deg(1.0);
  for (std::size_t c = 0; c < columns.size(); ++c) {
    const std::string& name = columns[c];
    out.push_back({name, c, 1.0});
    for (const auto& [rad, deg] : {std::pair{"_rad", "_deg"}, std::pair{"_radps", "_degps"}}) {
      if (!name.ends_with(rad)) continue;
      const std::string view = name.substr(0, name.size() - std::string_view(rad).size()) + deg;
      if (std::find(columns.begin(), columns.end(), view) == columns.end()) out.push_back({view, c, deg_per_rad});
    }
  }
  for (std::size_t e = 0; e < extras.size(); ++e) out.push_back({extras[e], columns.size() + e, 1.0});
  return out;
}

/// "A.B.C.D" of "A.B.C.D:PORT" (what Telemetry takes beside the port).
std::string host_of(const io::UdpEndpoint& e) {
  const std::string at = e.to_string();
  return at.substr(0, at.rfind(':'));
}

bool is_glob(std::string_view pattern) { return pattern.find_first_of("*?") != std::string_view::npos; }

/// `*` any run of characters, `?` one character; everything else literal.
bool glob_match(std::string_view pattern, std::string_view name) {
  std::size_t p = 0, n = 0, star = std::string_view::npos, resume = 0;
  while (n < name.size()) {
    if (p < pattern.size() && (pattern[p] == '?' || pattern[p] == name[n])) {
      ++p, ++n;
    } else if (p < pattern.size() && pattern[p] == '*') {
      star = p++, resume = n;
    } else if (star != std::string_view::npos) {
      p = star + 1, n = ++resume;
    } else {
      return false;
    }
  }
  while (p < pattern.size() && pattern[p] == '*') ++p;
  return p == pattern.size();
}

}  // namespace

TelemetryOptions read_telemetry(config::Map& root) {
  TelemetryOptions o;
  if (!root.has("telemetry")) return o;
  config::Map m = root.map("telemetry");
  if (m.has("signals")) o.signals = m.strings("signals", 1, Telemetry::kMaxSignals);
  o.rate_Hz = m.number_or("rate_Hz", o.rate_Hz, {0.1, 1000.0});
  if (m.has("destination")) {
    const std::string text = m.string("destination");
    try {
      o.destination = io::parse_udp_endpoint(text);
    } catch (const std::invalid_argument& e) {
      m.fail("destination", fmt::format("expected udp://127.0.0.1:PORT, found '{}': {}", text, e.what()));
    }
    // The stream is unencrypted: a file never sends it off this machine (--telemetry-remote does).
    if ((o.destination->address >> 24) != 127) {
      m.fail("destination", fmt::format("expected a loopback address (udp://127.0.0.1:PORT), found '{}': the stream is unencrypted "
                                        "and unauthenticated; a remote destination only with peha run --telemetry URL --telemetry-remote", text));
    }
  }
  m.finish();
  return o;
}

std::vector<std::string> default_telemetry_signals(const std::vector<std::string>& columns, const std::vector<std::string>& extras) {
  static constexpr std::string_view kJointColumn = "agonist_loadcell_N";
  std::vector<std::string> prefixes;
  for (const std::string& c : columns) {
    // A joint's prefix is "" or ends in '_' ("antagonist_loadcell_N" is no joint "ant").
    if (!c.ends_with(kJointColumn)) continue;
    const std::string prefix = c.substr(0, c.size() - kJointColumn.size());
    if (prefix.empty() || prefix.back() == '_') prefixes.push_back(prefix);
  }
  std::vector<std::string> out;
  const std::vector<Available> available = available_signals(columns, {});
  for (const std::string& p : prefixes) {
    for (const char* field : {"angle_deg", "agonist_loadcell_N", "antagonist_loadcell_N", "agonist_pressure_cmd_MPa",
                              "antagonist_pressure_cmd_MPa", "tau_motor_cmd_Nm"}) {
      const std::string name = p + field;
      if (std::any_of(available.begin(), available.end(), [&](const Available& a) { return a.name == name; })) out.push_back(name);
    }
  }
  out.insert(out.end(), extras.begin(), extras.end());
  return out;
}

TelemetrySelection select_telemetry(const std::vector<std::string>& wanted, const std::vector<std::string>& columns,
                                    const std::vector<std::string>& extras) {
  const std::vector<Available> available = available_signals(columns, extras);
  TelemetrySelection s;
  s.column_count = columns.size();
  auto add = [&s](const Available& a) {
    if (std::find(s.names.begin(), s.names.end(), a.name) != s.names.end()) return;
    s.names.push_back(a.name);
    s.sources.push_back(a.source);
    s.scales.push_back(a.scale);
  };
  std::vector<std::string> names;
  for (const Available& a : available) names.push_back(a.name);
  for (const std::string& w : wanted.empty() ? default_telemetry_signals(columns, extras) : wanted) {
    bool matched = false;
    for (const Available& a : available) {
      if (is_glob(w) ? glob_match(w, a.name) : a.name == w) add(a), matched = true;
    }
    if (matched) continue;
    if (is_glob(w)) throw std::invalid_argument(fmt::format("telemetry signal '{}' matches no column of the log", w));
    const std::string near = config::closest_name(w, names, w.size());
    throw std::invalid_argument(fmt::format("telemetry signal '{}' is not a column of the log{}", w,
                                            near.empty() ? std::string() : fmt::format(" (did you mean '{}'?)", near)));
  }
  if (s.names.empty() || s.names.size() > Telemetry::kMaxSignals) {
    throw std::invalid_argument(fmt::format("telemetry: {} signals chosen; 1 to {} can stream (narrow the globs)", s.names.size(),
                                            Telemetry::kMaxSignals));
  }
  return s;
}

void check_telemetry(const TelemetryOptions& options, const std::vector<std::string>& columns, const std::vector<std::string>& extras) {
  if (!options.destination) return;
  (void)select_telemetry(options.signals, columns, extras);
  Telemetry::check_destination(host_of(*options.destination), options.destination->port, options.allow_remote);
}

void pick_telemetry(const TelemetrySelection& selection, std::span<const double> row, std::span<const double> extras,
                    std::span<double> values) noexcept {
  const std::size_t n = std::min(values.size(), selection.sources.size());
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t from = selection.sources[i];
    const double v = from < selection.column_count ? (from < row.size() ? row[from] : 0.0)
                                                   : (from - selection.column_count < extras.size() ? extras[from - selection.column_count] : 0.0);
    values[i] = v * selection.scales[i];
  }
}

namespace {

const io::UdpEndpoint& checked_destination(const TelemetryOptions& options) {
  if (!options.destination) throw std::invalid_argument("LogTelemetry: no destination");
  return *options.destination;
}

}  // namespace

LogTelemetry::LogTelemetry(const TelemetryOptions& options, const std::vector<std::string>& columns, const std::vector<std::string>& extras,
                           std::string group, std::size_t queue_capacity)
    : selection_(select_telemetry(options.signals, columns, extras)),
      destination_(checked_destination(options)),
      values_(selection_.names.size()),
      telemetry_(host_of(destination_), destination_.port, options.rate_Hz, std::move(group), selection_.names, queue_capacity,
                 options.allow_remote) {}

void LogTelemetry::publish(std::span<const double> row, std::span<const double> extras) noexcept {
  if (row.empty()) return;
  pick_telemetry(selection_, row, extras, values_);
  telemetry_.publish(row[0], values_);
}

TelemetryTee::TelemetryTee(RowSink& log, const TelemetryOptions& options, const std::vector<std::string>& columns)
    // A simulation runs many times faster than real time: a longer queue rides out the sender
    // thread's pauses (10 simulated s at 100 Hz).
    : log_(log), telemetry_(options.destination ? std::make_unique<LogTelemetry>(options, columns, std::vector<std::string>{}, "peha", 1024)
                                                : nullptr) {}

void TelemetryTee::push_row(std::span<const double> row) noexcept {
  log_.push_row(row);
  if (telemetry_) telemetry_->publish(row);
}

}  // namespace peha::runtime
