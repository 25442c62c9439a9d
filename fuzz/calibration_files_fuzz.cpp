// libFuzzer target: the calibration CSV reader and the calibration YAML loader on arbitrary bytes.
// The first byte picks the reader (bit 0: YAML; bit 1, for the CSV: the bytes after the first NUL
// are its sidecar <csv>.meta.json); the rest is the file. Every input either loads or is rejected
// with calibration::DataError / config::Error; nothing else may escape, crash or leak.
#include "peha/calibration/calibration_file.hpp"
#include "peha/calibration/dataset.hpp"
#include "peha/config/reader.hpp"

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <string>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  static const std::string path = "/tmp/peha_fuzz_calibration_" + std::to_string(::getpid());
  const bool yaml = data[0] & 1;
  const std::string_view body(reinterpret_cast<const char*>(data + 1), size - 1);
  const std::size_t nul = (data[0] & 2) && !yaml ? body.find('\0') : std::string_view::npos;
  {
    std::ofstream f(path + (yaml ? ".yaml" : ".csv"), std::ios::binary | std::ios::trunc);
    f << body.substr(0, nul);
  }
  if (nul != std::string_view::npos) {
    std::ofstream(path + ".csv.meta.json", std::ios::binary | std::ios::trunc) << body.substr(nul + 1);
  } else {
    std::remove((path + ".csv.meta.json").c_str());
  }
  try {
    if (yaml) {
      (void)peha::calibration::read_calibration(path + ".yaml");
    } else {
      peha::calibration::DatasetRules rules;
      rules.min_rows = 1;
      (void)peha::calibration::read_dataset(path + ".csv", rules);
    }
  } catch (const peha::config::Error&) {
  } catch (const peha::calibration::DataError&) {
  } catch (const peha::calibration::CalibrationRejected&) {  // integrity refused (no hash, an edit, no data)
  }
  return 0;
}
