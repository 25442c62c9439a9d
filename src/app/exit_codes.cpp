#include "peha/app/commands.hpp"

#include "peha/app/cli_checks.hpp"
#include "peha/calibration/calibration_file.hpp"
#include "peha/calibration/dataset.hpp"
#include "peha/config/input_file.hpp"
#include "peha/config/reader.hpp"

#include <fmt/format.h>

namespace peha::app {

int with_exit_codes(const std::function<int()>& body) {
  try {
    return body();
  } catch (const config::Error& e) {
    fmt::print(stderr, "config error: {}\n", e.what());
    return 2;
  } catch (const UsageError& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return 2;
  } catch (const calibration::CalibrationRejected& e) {
    fmt::print(stderr, "calibration refused: {}\n", e.what());
    return 2;
  } catch (const calibration::DataError& e) {
    fmt::print(stderr, "data error: {}\n", e.what());
    return 2;
  } catch (const config::InputFileError& e) {
    fmt::print(stderr, "input error: {}\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return 1;
  }
}

}  // namespace peha::app
