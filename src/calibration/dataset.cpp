#include "peha/calibration/dataset.hpp"

#include "peha/config/csv_sidecar.hpp"
#include "peha/config/input_file.hpp"

#include <openssl/evp.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>
#include <optional>
#include <string_view>
#include <system_error>

// Calibration CSV reader/writer (docs/calibration.md). Set-up code: everything is checked, every problem is a
// DataError whose message says where (file:line, column) and what to do about it, and nothing
// half-read is ever returned (the result is assembled locally and only returned when complete).

namespace peha::calibration {
namespace {

// ---- columns -----------------------------------------------------------------------------------

enum Column : std::size_t { kPressure = 0, kContraction, kForce, kTime, kAngle, kWireVelocity, kColumnCount };

struct ColumnInfo {
  std::string_view name;
  std::string_view quantity;  ///< part before the unit suffix ("pressure" of "pressure_MPa")
  std::string_view unit;      ///< unit suffix as written ("MPa"); empty for dimensionless
  bool required;
};

constexpr std::array<ColumnInfo, kColumnCount> kColumns{{
    {"pressure_MPa", "pressure", "MPa", true},
    {"contraction", "contraction", "", true},
    {"force_N", "force", "N", true},
    {"t_s", "t", "s", false},
    {"angle_rad", "angle", "rad", false},
    {"wire_velocity_mps", "wire_velocity", "mps", false},
}};

// Plausibility limits (docs/calibration.md / dataset.hpp). Values chosen for 0..0.8 MPa muscles.
constexpr double kMaxPressureMPa = kMaxPlausiblePressure_MPa;  ///< above: a unit mistake, not a reading
constexpr double kKPaCeiling = 2000.0;           ///< max in (1.2, 2000] looks like kPa, above like Pa
constexpr double kMinPressureMPa = -0.02;        ///< below: more than sensor noise
constexpr double kMaxAbsContraction = 1.0;       ///< above: percent, not a fraction
constexpr double kMinForceN = -50.0;             ///< below: more than load-cell noise
constexpr double kMaxLoadcellZeroN = 1000.0;     ///< a vented reading beyond this is a broken cell, not a zero
constexpr std::size_t kMaxRows = 5'000'000;      ///< 83 min at 1 kHz; more is a wrong file or needs decimation
constexpr double kMaxAbsAngleRad = 2.0 * 3.14159265358979323846;  ///< above: degrees, not radians

std::string accepted_list() {
  std::string s;
  for (const auto& c : kColumns) {
    if (!s.empty()) s += ", ";
    s += c.name;
    if (!c.required) s += " (optional)";
  }
  return s;
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (auto& ch : out) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return out;
}

// Short, readable number for messages.
std::string num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

// Full-precision number for the file (%.9g, as docs/calibration.md specifies for peha CSVs).
std::string num9(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

std::string_view trim(std::string_view s) {
  const auto ws = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; };
  while (!s.empty() && ws(s.front())) s.remove_prefix(1);
  while (!s.empty() && ws(s.back())) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  while (true) {
    const auto comma = line.find(',', start);
    if (comma == std::string_view::npos) {
      out.push_back(trim(line.substr(start)));
      return out;
    }
    out.push_back(trim(line.substr(start, comma - start)));
    start = comma + 1;
  }
}

// ---- strict number parsing ---------------------------------------------------------------------

enum class ParseStatus { kOk, kEmpty, kNotANumber, kNotFinite, kOutOfRange };

ParseStatus parse_double(std::string_view s, double& out) {
  if (s.empty()) return ParseStatus::kEmpty;
  std::string_view body = s;
  // from_chars rejects a leading '+'; "+0.5" is still a plain number, so accept exactly one.
  if (body.front() == '+') {
    body.remove_prefix(1);
    if (body.empty() || body.front() == '+' || body.front() == '-') return ParseStatus::kNotANumber;
  }
  double v = 0.0;
  const auto [ptr, ec] = std::from_chars(body.data(), body.data() + body.size(), v, std::chars_format::general);
  if (ec == std::errc::result_out_of_range) return ParseStatus::kOutOfRange;
  if (ec != std::errc{} || ptr != body.data() + body.size()) return ParseStatus::kNotANumber;
  if (!std::isfinite(v)) return ParseStatus::kNotFinite;
  out = v;
  return ParseStatus::kOk;
}

bool looks_numeric(std::string_view s) {
  double v = 0.0;
  const auto st = parse_double(s, v);
  return st == ParseStatus::kOk || st == ParseStatus::kOutOfRange;
}

// ---- SHA-256 (OpenSSL EVP) ---------------------------------------------------------------------

struct MdCtxDeleter {
  void operator()(EVP_MD_CTX* ctx) const { EVP_MD_CTX_free(ctx); }
};

class Sha256 {
 public:
  Sha256() : ctx_(EVP_MD_CTX_new()) {
    if (!ctx_ || EVP_DigestInit_ex(ctx_.get(), EVP_sha256(), nullptr) != 1) {
      throw DataError("sha256: OpenSSL EVP_DigestInit_ex(EVP_sha256) failed");
    }
  }
  void update(const void* data, std::size_t n) {
    if (n > 0 && EVP_DigestUpdate(ctx_.get(), data, n) != 1) throw DataError("sha256: EVP_DigestUpdate failed");
  }
  std::string hex() {
    std::array<unsigned char, EVP_MAX_MD_SIZE> md{};
    unsigned int len = 0;
    if (EVP_DigestFinal_ex(ctx_.get(), md.data(), &len) != 1) throw DataError("sha256: EVP_DigestFinal_ex failed");
    static constexpr char kHex[] = "0123456789abcdef";
    std::string out;
    out.reserve(2 * len);
    for (unsigned int i = 0; i < len; ++i) {
      out += kHex[md[i] >> 4];
      out += kHex[md[i] & 0x0f];
    }
    return out;
  }

 private:
  std::unique_ptr<EVP_MD_CTX, MdCtxDeleter> ctx_;
};

// ---- header ------------------------------------------------------------------------------------

// What to say when a header name is close to an accepted one but in another unit.
std::string unit_hint(std::string_view accepted_unit, std::string_view given_unit) {
  const std::string g = lower(given_unit);
  if (accepted_unit == "MPa") {
    if (g == "kpa") return ": divide kPa by 1000";
    if (g == "pa") return ": divide Pa by 1e6";
    if (g == "bar") return ": divide bar by 10";
    if (g == "psi") return ": multiply psi by 0.00689476";
    return "";
  }
  if (accepted_unit == "rad" && (g == "deg" || g == "degree" || g == "degrees")) return ": multiply degrees by pi/180";
  if (accepted_unit == "s" && g == "ms") return ": divide ms by 1000";
  if (accepted_unit == "N" && g == "kn") return ": multiply kN by 1000";
  return "";
}

// Index into kColumns for one header name, or throws a DataError explaining the fix.
std::size_t classify_header_name(std::string_view name, const std::string& where, std::size_t field) {
  for (std::size_t c = 0; c < kColumns.size(); ++c) {
    if (name == kColumns[c].name) return c;
  }
  const std::string lname = lower(name);
  const std::string prefix = where + ": column " + std::to_string(field) + " '" + std::string(name) + "': ";
  // Same name in another case: "Force_N".
  for (const auto& c : kColumns) {
    if (lname == lower(c.name)) {
      throw DataError(prefix + "unknown column; did you mean '" + std::string(c.name) +
                      "'? (names are case-sensitive). Accepted columns: " + accepted_list());
    }
  }
  // A known quantity in another unit: "pressure_kPa", "pressure", "angle_deg".
  for (const auto& c : kColumns) {
    const std::string q = lower(c.quantity);
    const bool bare = lname == q;
    const bool other_unit = lname.size() > q.size() + 1 && lname.compare(0, q.size() + 1, q + "_") == 0;
    if (c.unit.empty() || !(bare || other_unit)) continue;
    const std::string given_unit = bare ? "" : std::string(name.substr(q.size() + 1));
    const std::string what =
        bare ? "has no unit" : "is in " + given_unit + ", but peha reads " + std::string(c.quantity) + " in " + std::string(c.unit);
    throw DataError(prefix + what + "; convert to " + std::string(c.unit) + " (" + std::string(c.name) + ")" +
                    unit_hint(c.unit, given_unit) + ". Accepted columns: " + accepted_list());
  }
  throw DataError(prefix + "unknown column (remove it or rename it). Accepted columns: " + accepted_list());
}

// ---- plausibility helpers ----------------------------------------------------------------------

struct Row {
  std::size_t line;
  std::array<double, kColumnCount> v;
};

template <class Pred>
const Row* first_where(const std::vector<Row>& rows, Pred pred) {
  for (const auto& r : rows) {
    if (pred(r)) return &r;
  }
  return nullptr;
}

std::string value_prefix(const std::string& file, std::size_t line, std::size_t col, double value) {
  return file + ":" + std::to_string(line) + ": column '" + std::string(kColumns[col].name) + "': value " + num(value) + " ";
}


// ---- reading -----------------------------------------------------------------------------------

// The file's bytes through the one checked opener (a folder, a device, a pipe, too large: refused).
// All bytes are read once: the hash is of exactly the bytes that were parsed.
std::string read_csv_bytes(const std::filesystem::path& path) {
  try {
    return config::read_input_file(path, config::InputKind::kCalibrationCsv);
  } catch (const config::InputFileError& e) {
    throw DataError(e.what());
  }
}

// What the lines of a calibration CSV say, before the plausibility checks.
struct CsvContent {
  std::vector<std::size_t> field_to_col;                             ///< header field index -> Column
  std::array<std::optional<std::size_t>, kColumnCount> col_field{};  ///< Column -> header field index
  std::size_t header_line = 0;                                       ///< 0 = none yet
  std::vector<Row> rows;
  std::size_t zero_line = 0;  ///< the `# loadcell_zero_N:` comment, 0 = none
  double loadcell_zero_N = 0.0;
};

// A '#' comment line: only `# loadcell_zero_N: <N>` means something, and only once.
void read_comment(std::string_view line, const std::string& file, std::size_t line_no, CsvContent& csv) {
  constexpr std::string_view kZeroKey = "loadcell_zero_N:";
  const std::string_view body = trim(line.substr(1));
  if (body.substr(0, kZeroKey.size()) != kZeroKey) return;
  double v = 0.0;
  const std::string_view value = trim(body.substr(kZeroKey.size()));
  if (parse_double(value, v) != ParseStatus::kOk || std::abs(v) > kMaxLoadcellZeroN) {
    throw DataError(file + ":" + std::to_string(line_no) + ": loadcell_zero_N: expected a number of newtons within +-" +
                    num(kMaxLoadcellZeroN) + " (the load cell's reading with the muscle vented), found '" +
                    std::string(value) + "'");
  }
  if (csv.zero_line != 0) {
    throw DataError(file + ":" + std::to_string(line_no) + ": loadcell_zero_N given twice (first on line " +
                    std::to_string(csv.zero_line) + ")");
  }
  csv.zero_line = line_no;
  csv.loadcell_zero_N = v;
}

// The header row: which column each field holds; every required column present, none twice.
void read_header(std::string_view line, const std::string& where, CsvContent& csv) {
  const auto names = split(line);
  if (names.size() == 1 && (line.find(';') != std::string_view::npos || line.find('\t') != std::string_view::npos)) {
    throw DataError(where + ": header is not comma-separated; the separator must be ',' (e.g. "
                    "pressure_MPa,contraction,force_N)");
  }
  if (std::all_of(names.begin(), names.end(), looks_numeric)) {
    throw DataError(where + ": header row missing (this line is numbers); the first line that is not a '#' "
                    "comment must name the columns, e.g. pressure_MPa,contraction,force_N");
  }
  for (std::size_t f = 0; f < names.size(); ++f) {
    if (names[f].empty()) {
      throw DataError(where + ": header field " + std::to_string(f + 1) +
                      " is empty (stray comma?); every column needs a name. Accepted columns: " + accepted_list());
    }
    const std::size_t c = classify_header_name(names[f], where, f + 1);
    if (csv.col_field[c]) {
      throw DataError(where + ": duplicate column '" + std::string(kColumns[c].name) + "' (header fields " +
                      std::to_string(*csv.col_field[c] + 1) + " and " + std::to_string(f + 1) +
                      "); keep one of them");
    }
    csv.col_field[c] = f;
    csv.field_to_col.push_back(c);
  }
  std::string missing;
  for (std::size_t c = 0; c < kColumnCount; ++c) {
    if (kColumns[c].required && !csv.col_field[c]) missing += (missing.empty() ? "" : ", ") + std::string(kColumns[c].name);
  }
  if (!missing.empty()) {
    throw DataError(where + ": missing required column(s) " + missing + " (header has '" + std::string(line) +
                    "'); required: pressure_MPa, contraction, force_N");
  }
}

// One data row: as many fields as the header, each a finite number.
Row read_row(std::string_view line, const std::string& where, std::size_t line_no, const CsvContent& csv) {
  const auto fields = split(line);
  if (fields.size() != csv.field_to_col.size()) {
    throw DataError(where + ": expected " + std::to_string(csv.field_to_col.size()) + " fields (as in the header on line " +
                    std::to_string(csv.header_line) + "), found " + std::to_string(fields.size()));
  }
  Row row{line_no, {}};
  for (std::size_t f = 0; f < fields.size(); ++f) {
    const std::size_t c = csv.field_to_col[f];
    double v = 0.0;
    const auto st = parse_double(fields[f], v);
    if (st == ParseStatus::kOk) {
      row.v[c] = v;
      continue;
    }
    const std::string at = where + ": column '" + std::string(kColumns[c].name) + "': ";
    const std::string field(fields[f]);
    switch (st) {
      case ParseStatus::kEmpty: throw DataError(at + "empty field; every field must be a number");
      case ParseStatus::kNotFinite: throw DataError(at + "not finite '" + field + "'; drop or repair the row");
      case ParseStatus::kOutOfRange: throw DataError(at + "out of range '" + field + "'");
      default: throw DataError(at + "not a number '" + field + "' (expected a decimal number such as 0.25)");
    }
  }
  return row;
}

// All lines of the file's text (BOM removed): comments, the header, then data rows up to kMaxRows.
CsvContent read_csv_lines(std::string_view text, const std::string& file) {
  CsvContent csv;
  std::size_t line_no = 0;
  std::size_t pos = 0;
  while (pos < text.size()) {
    const auto nl = text.find('\n', pos);
    const std::string_view raw = text.substr(pos, nl == std::string_view::npos ? std::string_view::npos : nl - pos);
    pos = nl == std::string_view::npos ? text.size() : nl + 1;
    ++line_no;
    const std::string_view line = trim(raw);
    if (!line.empty() && line.front() == '#') {
      read_comment(line, file, line_no, csv);
      continue;
    }
    if (line.empty()) continue;
    const std::string where = file + ":" + std::to_string(line_no);
    if (csv.header_line == 0) {
      csv.header_line = line_no;
      read_header(line, where, csv);
      continue;
    }
    const Row row = read_row(line, where, line_no, csv);
    if (csv.rows.size() == kMaxRows) {
      throw DataError(where + ": more than " + std::to_string(kMaxRows) +
                      " data rows; decimate the log (250 Hz is plenty for a calibration) or split it");
    }
    csv.rows.push_back(row);
  }
  // A file cut off inside its last number still parses ("0.31" of "0.3124"): a CSV that peha reads
  // ends with a line end, so a missing one is a cut, not a style.
  if (!csv.rows.empty() && !text.empty() && text.back() != '\n') {
    throw DataError(file + ":" + std::to_string(line_no) + ": the last line has no line end: the file looks cut off "
                    "(an interrupted copy or write?); if it is complete, add a newline at its end");
  }
  if (csv.header_line == 0) {
    throw DataError(file + ": no header row (file is empty or only comments); expected a header such as "
                    "pressure_MPa,contraction,force_N followed by data rows");
  }
  if (csv.rows.empty()) {
    throw DataError(file + ": no data rows after the header on line " + std::to_string(csv.header_line));
  }
  return csv;
}

// The load-cell zero from the sidecar `<csv>.meta.json`, where peha writes it. A recording from
// before the sidecar carries it in a `# loadcell_zero_N:` line instead; both at once is an error.
void read_sidecar_zero(const std::filesystem::path& path, const std::string& file, CsvContent& csv) {
  try {
    const std::optional<config::Document> meta = config::read_csv_sidecar(path);
    if (!meta) return;
    config::Map root = meta->root();
    if (!root.has("loadcell_zero_N")) return;
    const double v = root.number("loadcell_zero_N", {-kMaxLoadcellZeroN, kMaxLoadcellZeroN});
    if (csv.zero_line != 0) {
      throw DataError(file + ":" + std::to_string(csv.zero_line) + ": loadcell_zero_N given twice: in this '#' line and in " +
                      config::csv_sidecar_path(path).string() + "; keep one (peha writes it to the sidecar)");
    }
    csv.loadcell_zero_N = v;
  } catch (const config::Error& e) {
    throw DataError(std::string(e.what()) + " (the sidecar of the calibration CSV; loadcell_zero_N is the load cell's reading "
                    "with the muscle vented, N)");
  }
}

// ---- plausibility (after all rows are read; first offender's line) -----------------------------

double column_max(const std::vector<Row>& rows, std::size_t c, bool absolute) {
  double m = -std::numeric_limits<double>::infinity();
  for (const auto& r : rows) m = std::max(m, absolute ? std::abs(r.v[c]) : r.v[c]);
  return m;
}

struct Range {
  double lo, hi;
};

Range column_range(const std::vector<Row>& rows, std::size_t c) {
  double lo = rows.front().v[c], hi = lo;
  for (const auto& r : rows) lo = std::min(lo, r.v[c]), hi = std::max(hi, r.v[c]);
  return {lo, hi};
}

// Values beyond what a muscle test gives, each named as the unit mistake it most likely is.
void check_units(const CsvContent& csv, const DatasetRules& rules, const std::string& file) {
  const std::vector<Row>& rows = csv.rows;
  if (const Row* r = first_where(rows, [](const Row& x) { return x.v[kPressure] > kMaxPressureMPa; })) {
    const double mx = column_max(rows, kPressure, false);
    const bool kpa = mx <= kKPaCeiling;
    throw DataError(value_prefix(file, r->line, kPressure, r->v[kPressure]) + "is above " + num(kMaxPressureMPa) +
                    " MPa: looks like " + (kpa ? "kPa" : "Pa") + " (max " + num(mx) + "); convert to MPa (" +
                    (kpa ? "divide by 1000" : "divide by 1e6") + ")");
  }
  if (const Row* r = first_where(rows, [](const Row& x) { return x.v[kPressure] < kMinPressureMPa; })) {
    throw DataError(value_prefix(file, r->line, kPressure, r->v[kPressure]) + "is below " + num(kMinPressureMPa) +
                    " MPa: negative gauge pressure beyond sensor noise; check the pressure sensor's offset and sign");
  }
  if (const Row* r = first_where(rows, [](const Row& x) { return std::abs(x.v[kContraction]) > kMaxAbsContraction; })) {
    throw DataError(value_prefix(file, r->line, kContraction, r->v[kContraction]) +
                    "has magnitude above 1: looks like percent (max |contraction| " +
                    num(column_max(rows, kContraction, true)) +
                    "); contraction is a fraction (L0 - L) / L0: divide by 100");
  }
  if (const Row* r = first_where(rows, [&](const Row& x) { return x.v[kForce] > rules.max_force_N; })) {
    throw DataError(value_prefix(file, r->line, kForce, r->v[kForce]) + "is above " + num(rules.max_force_N) + " N (" +
                    rules.max_force_reason + "): a unit mistake or a load-cell glitch");
  }
  if (const Row* r = first_where(rows, [](const Row& x) { return x.v[kForce] < kMinForceN; })) {
    throw DataError(value_prefix(file, r->line, kForce, r->v[kForce]) + "is below " + num(kMinForceN) +
                    " N: a muscle only pulls; check the load cell's sign and offset (small negative noise above " +
                    num(kMinForceN) + " N is accepted)");
  }
  if (csv.col_field[kAngle]) {
    if (const Row* r = first_where(rows, [](const Row& x) { return std::abs(x.v[kAngle]) > kMaxAbsAngleRad; })) {
      throw DataError(value_prefix(file, r->line, kAngle, r->v[kAngle]) +
                      "has magnitude above 2*pi: looks like degrees (max |angle| " + num(column_max(rows, kAngle, true)) +
                      "); convert to rad (multiply by pi/180)");
    }
  }
}

// t_s, when given, strictly increasing: rows out of order or two logs in one file are not one sweep.
void check_time_order(const CsvContent& csv, const std::string& file) {
  if (!csv.col_field[kTime]) return;
  const std::vector<Row>& rows = csv.rows;
  for (std::size_t i = 1; i < rows.size(); ++i) {
    if (!(rows[i].v[kTime] > rows[i - 1].v[kTime])) {
      throw DataError(value_prefix(file, rows[i].line, kTime, rows[i].v[kTime]) + "is not after the previous " +
                      num(rows[i - 1].v[kTime]) + " (line " + std::to_string(rows[i - 1].line) +
                      "): t_s must be strictly increasing (rows out of order, or a duplicated/concatenated log?)");
    }
  }
}

// Enough rows, and pressure and force swept far enough to fit anything (the rules' limits).
void check_excitation(const std::vector<Row>& rows, const DatasetRules& rules, const std::string& file) {
  if (rows.size() < rules.min_rows) {
    throw DataError(file + ": too few points (" + std::to_string(rows.size()) + " < " + std::to_string(rules.min_rows) +
                    "); a calibration needs at least " + std::to_string(rules.min_rows) +
                    " data rows: log a longer excitation (or lower DatasetRules::min_rows)");
  }
  const auto [lo_MPa, hi_MPa] = column_range(rows, kPressure);
  const double span_Pa = (hi_MPa - lo_MPa) * 1e6;
  if (!(span_Pa > rules.min_pressure_span_Pa)) {
    throw DataError(file + ": column 'pressure_MPa': no excitation: pressure spans only " + num(hi_MPa - lo_MPa) +
                    " MPa (" + num(lo_MPa) + " .. " + num(hi_MPa) + " MPa, need more than " +
                    num(rules.min_pressure_span_Pa / 1e6) +
                    " MPa); sweep the pressure (e.g. a triangle wave, as peha record-calibration does) while logging");
  }
  const auto [lo_N, hi_N] = column_range(rows, kForce);
  if (!(hi_N - lo_N > rules.min_force_span_N)) {
    throw DataError(file + ": column 'force_N': no excitation: force spans only " + num(hi_N - lo_N) + " N (" +
                    num(lo_N) + " .. " + num(hi_N) + " N, need more than " + num(rules.min_force_span_N) +
                    " N); is the load cell connected and the muscle loaded?");
  }
}

// ---- assembly (only after every check: nothing half-read escapes) -----------------------------

Dataset assemble_dataset(const CsvContent& csv, const std::string& file, const std::string& bytes) {
  Dataset d;
  const std::size_t n = csv.rows.size();
  d.pressure_Pa.reserve(n);
  d.contraction.reserve(n);
  d.force_N.reserve(n);
  for (const auto& r : csv.rows) {
    d.pressure_Pa.push_back(r.v[kPressure] * 1e6);
    d.contraction.push_back(r.v[kContraction]);
    d.force_N.push_back(r.v[kForce]);
  }
  const auto fill_optional = [&](std::size_t c, std::vector<double>& out) {
    if (!csv.col_field[c]) return;
    out.reserve(n);
    for (const auto& r : csv.rows) out.push_back(r.v[c]);
  };
  fill_optional(kTime, d.t_s);
  fill_optional(kAngle, d.angle_rad);
  fill_optional(kWireVelocity, d.wire_velocity_mps);
  d.source = file;
  d.loadcell_zero_N = csv.loadcell_zero_N;
  d.sha256 = sha256_hex(bytes);
  return d;
}

}  // namespace

// ---- public API --------------------------------------------------------------------------------

std::string recorded_muscle(const std::filesystem::path& path) {
  try {
    const std::optional<config::Document> meta = config::read_csv_sidecar(path);
    if (!meta) return "";
    config::Map root = meta->root();
    return root.has("muscle") ? root.string("muscle") : "";
  } catch (const config::Error& e) {
    throw DataError(std::string(e.what()) + " (the sidecar of the calibration CSV; muscle: the muscle recorded)");
  }
}

std::string sha256_file(const std::filesystem::path& path) { return sha256_hex(read_csv_bytes(path)); }

std::string sha256_hex(std::string_view bytes) {
  Sha256 sha;
  sha.update(bytes.data(), bytes.size());
  return sha.hex();
}

Dataset read_dataset(const std::filesystem::path& path, const DatasetRules& rules) {
  const std::string file = path.string();
  const std::string bytes = read_csv_bytes(path);
  std::string_view text(bytes);
  if (text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);  // UTF-8 BOM (spreadsheet exports)
  CsvContent csv = read_csv_lines(text, file);
  read_sidecar_zero(path, file, csv);
  check_units(csv, rules, file);
  check_time_order(csv, file);
  check_excitation(csv.rows, rules, file);
  Dataset d = assemble_dataset(csv, file, bytes);
  d.muscle = recorded_muscle(path);
  return d;
}

void write_dataset(const std::filesystem::path& path, const Dataset& data, const std::vector<std::string>& comments) {
  const std::string file = path.string();
  const std::size_t n = data.size();
  struct Out {
    std::string_view name;
    const std::vector<double>* values;
    double scale;
  };
  std::vector<Out> cols{{"pressure_MPa", &data.pressure_Pa, 1e-6}, {"contraction", &data.contraction, 1.0},
                        {"force_N", &data.force_N, 1.0}};
  if (!data.t_s.empty()) cols.push_back({"t_s", &data.t_s, 1.0});
  if (!data.angle_rad.empty()) cols.push_back({"angle_rad", &data.angle_rad, 1.0});
  if (!data.wire_velocity_mps.empty()) cols.push_back({"wire_velocity_mps", &data.wire_velocity_mps, 1.0});
  for (const auto& c : cols) {
    if (c.values->size() != n) {
      throw DataError(file + ": cannot write dataset: column '" + std::string(c.name) + "' has " +
                      std::to_string(c.values->size()) + " values but pressure has " + std::to_string(n));
    }
    for (std::size_t i = 0; i < n; ++i) {
      if (!std::isfinite((*c.values)[i])) {
        throw DataError(file + ": cannot write dataset: column '" + std::string(c.name) + "' row " +
                        std::to_string(i + 1) + " is not finite (" + num((*c.values)[i]) + ")");
      }
    }
  }

  // Write to a sibling temporary and rename, so a reader never sees a half-written file. The header
  // is the first line (numpy, pandas, spreadsheets open the file as it is); the comments and the
  // load-cell zero go to the sidecar.
  std::filesystem::path tmp = path;
  tmp += ".tmp";
  std::vector<std::string> names;
  for (const auto& c : cols) names.emplace_back(c.name);
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw DataError(file + ": cannot write calibration file (does the directory exist and is it writable?)");
    std::string line;
    for (std::size_t c = 0; c < names.size(); ++c) {
      if (c) line += ',';
      line += names[c];
    }
    out << line << '\n';
    for (std::size_t i = 0; i < n; ++i) {
      line.clear();
      for (std::size_t c = 0; c < cols.size(); ++c) {
        if (c) line += ',';
        line += num9((*cols[c].values)[i] * cols[c].scale);
      }
      out << line << '\n';
    }
    out.flush();
    if (!out) {
      std::error_code ec;
      std::filesystem::remove(tmp, ec);
      throw DataError(file + ": write error (disk full?)");
    }
  }
  std::vector<std::string> notes = comments;
  notes.emplace_back("loadcell_zero_N: the load cell's reading with the muscle vented, already subtracted from force_N");
  try {
    config::remove_csv_sidecar(path);  // a stop before the new sidecar leaves no other recording's zero here
  } catch (const std::runtime_error& e) {
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    throw DataError(e.what());
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    throw DataError(file + ": cannot replace file: " + ec.message());
  }
  try {
    config::CsvMeta meta{names, n, notes, {{"loadcell_zero_N", data.loadcell_zero_N}}};
    if (!data.muscle.empty()) meta.texts.emplace_back("muscle", data.muscle);
    config::write_csv_sidecar(path, meta);
  } catch (const std::runtime_error& e) {
    throw DataError(e.what());
  }
}

}  // namespace peha::calibration
