#include "peha/experiments/common/board_run.hpp"

#include <cstdlib>
#include <limits>
#include <optional>
#include <string>

namespace peha::experiments {

runtime::SupervisorParams supervisor_params(const runtime::SupervisorParams& lifecycle, const runtime::RealtimeRunOptions& options) noexcept {
  runtime::SupervisorParams p = lifecycle;
  p.recover_after_s = options.recover_after_s;
  return p;
}

std::pair<double, std::string> first_lifecycle_fault(const std::vector<std::string>& lifecycle) {
  for (const std::string& e : lifecycle) {
    const auto at = e.find("-> fault (");
    if (at == std::string::npos) continue;
    const auto close = e.rfind(')');
    return {std::strtod(e.c_str(), nullptr), e.substr(at + 10, close == std::string::npos || close < at + 10 ? std::string::npos : close - at - 10)};
  }
  return {std::numeric_limits<double>::quiet_NaN(), ""};
}

void record_links(const mfb::BoardsBackend& backend, const BoardRtts& rtts, BoardRunResult& result) {
  result.link = backend.stats();
  result.boards.clear();
  if (backend.board_count() < 2) return;
  for (std::size_t b = 0; b < backend.board_count(); ++b) result.boards.push_back({backend.board_name(b), backend.board(b).stats(), rtts.board(b)});
}

BoardRunResult run_on_hardware(const hardware::HardwareRequest& request, const runtime::SupervisorParams& lifecycle,
                               const HardwareRunOptions& options, const HardwareRunLog& log, const HardwareLoop& loop) {
  hardware::Hardware hw = hardware::open_backend(options.backend, request);
  std::optional<BoardRtts> rtts;
  if (hw.boards) {
    rtts.emplace(hw.boards->board_count());
    hw.boards->set_rtt_sink(&*rtts);
  }
  std::vector<std::string> comments = log.comments;
  comments.insert(comments.begin(), "on " + hw.where());
  BoardRunResult result;
  {
    runtime::RealtimeHarness harness(*hw.backend, supervisor_params(lifecycle, options), options, request.period_s, log.duration_s, log.label, log.file,
                                     log.columns, comments);
    const runtime::CycleHooks hooks = harness.start();
    safety::Verdict& verdict = loop(hw, harness.sink(), hooks);
    harness.finish(result);
    add_link_fault_check(result, verdict);
  }
  if (hw.boards) {
    record_links(*hw.boards, *rtts, result);
    hw.boards->set_rtt_sink(nullptr);
  }
  return result;
}

void add_link_fault_check(const runtime::RealtimeRunResult& run, safety::Verdict& verdict) {
  const std::string reason = first_lifecycle_fault(run.lifecycle).second;
  const double n = static_cast<double>(run.faults);
  verdict.at_most(run.faults ? "link faults (first: " + reason + ")" : std::string("link faults"), "", n, 0.0);
}

}  // namespace peha::experiments
