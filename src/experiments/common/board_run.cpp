#include "peha/experiments/common/board_run.hpp"

#include <string>

namespace peha::experiments {

runtime::SupervisorParams supervisor_params(const mfb::LinkConfig& link, const runtime::RealtimeRunOptions& options) noexcept {
  runtime::SupervisorParams p;
  p.host_watchdog_s = link.host_watchdog_s;
  p.recovery_ramp_s = link.recovery_ramp_s;
  p.recover_after_s = options.recover_after_s;
  return p;
}

void add_link_fault_check(const runtime::RealtimeRunResult& run, safety::Verdict& verdict) {
  std::string reason;
  for (const std::string& e : run.lifecycle) {  // "t_s  from -> fault (reason)"
    const auto at = e.find("-> fault (");
    if (at == std::string::npos) continue;
    reason = e.substr(at + 10);
    if (!reason.empty() && reason.back() == ')') reason.pop_back();
    break;
  }
  const double n = static_cast<double>(run.faults);
  verdict.at_most(run.faults ? "link faults (first: " + reason + ")" : std::string("link faults"), "", n, 0.0);
}

}  // namespace peha::experiments
