#include "peha/experiments/common/board_run.hpp"

namespace peha::experiments {

runtime::SupervisorParams supervisor_params(const mfb::LinkConfig& link, const runtime::RealtimeRunOptions& options) noexcept {
  runtime::SupervisorParams p;
  p.host_watchdog_s = link.host_watchdog_s;
  p.recovery_ramp_s = link.recovery_ramp_s;
  p.recover_after_s = options.recover_after_s;
  return p;
}

}  // namespace peha::experiments
