#pragma once
/// \file
/// What every experiment's run on hardware shares: the one run function (`run_on_hardware`: the
/// door's backend inside a RealtimeHarness), the supervision parameters from the scenario's `mfb:`
/// section and the command line, and the result with the link's counters.

#include "peha/hardware/door.hpp"
#include "peha/mfb/link_config.hpp"
#include "peha/runtime/realtime_harness.hpp"
#include "peha/safety/verdict.hpp"

#include <filesystem>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace peha::experiments {

/// A real-time run on the board: the harness's figures and the host's link counters.
struct BoardRunResult : runtime::RealtimeRunResult {
  mfb::UdpLinkStats link;  ///< summed over the boards when there are several
  /// Each board's link, when the run drove several (mfb::BoardsBackend); empty on one board.
  struct Board {
    std::string name;
    mfb::UdpLinkStats link;
    runtime::Histogram rtt;  ///< its round trips (BoardRtts, from mfb::BoardsBackend's sink)
  };
  std::vector<Board> boards;
};

/// A run on hardware: which backend (`--backend`, through the one door) and the real-time options.
struct HardwareRunOptions : runtime::RealtimeRunOptions {
  hardware::BackendUri backend;
};

/// The log of a run on hardware, and what its progress line says.
struct HardwareRunLog {
  std::string label;                 ///< the case, for the progress line
  double duration_s = 0;
  std::filesystem::path file;
  std::vector<std::string> columns;
  std::vector<std::string> comments; ///< the run's; the door's "on <where>" line is added
};

/// The experiment's loop on the opened hardware: its run_*_on with the harness's sink and hooks (a
/// copy: a fault-injection run may wrap them). Returns its verdict, to which the run's link faults
/// are added.
using HardwareLoop = std::function<safety::Verdict&(hardware::Hardware& hw, runtime::RowSink& sink, runtime::CycleHooks hooks)>;

/// The one way every experiment runs on hardware in real time: opens `options.backend` for
/// `request` through the door (hardware::open_backend), runs `loop` in a RealtimeHarness (1 kHz
/// absolute deadlines, the lifecycle supervisor with the scenario's `lifecycle` (its watchdog and
/// recovery ramp, as in process), the writer-thread log with fault dumps, telemetry), adds the run's lifecycle faults to
/// the verdict `loop` returns (add_link_fault_check), and returns the harness's and the links'
/// figures. Throws (set-up) as the door does, or when no board answers.
BoardRunResult run_on_hardware(const hardware::HardwareRequest& request, const runtime::SupervisorParams& lifecycle,
                               const HardwareRunOptions& options, const HardwareRunLog& log, const HardwareLoop& loop);

/// Each board's round trips during a run: set as the backend's sink (mfb::BoardsBackend::set_rtt_sink)
/// before the run; allocation-free while it runs.
class BoardRtts : public mfb::BoardsBackend::RttSink {
 public:
  explicit BoardRtts(std::size_t boards) : rtt_(boards) {}
  void add(std::size_t board, double rtt_s) noexcept override {
    if (board < rtt_.size()) rtt_[board].add(rtt_s);
  }
  const runtime::Histogram& board(std::size_t b) const { return rtt_.at(b); }

 private:
  std::vector<runtime::Histogram> rtt_;
};

/// `result.link` (and `result.boards` when there are several, with their round trips from `rtts`)
/// from the run's backend.
void record_links(const mfb::BoardsBackend& backend, const BoardRtts& rtts, BoardRunResult& result);

/// The supervisor's parameters of a run on hardware: the scenario's `lifecycle`, the unattended
/// recovery from the command line.
runtime::SupervisorParams supervisor_params(const runtime::SupervisorParams& lifecycle, const runtime::RealtimeRunOptions& options) noexcept;

/// The first "-> fault (reason)" entry of a run's lifecycle (RealtimeRunResult::lifecycle, entries
/// "t_s  from -> to (reason)"): its time, s, and reason (NaN and "" when the run never faulted).
std::pair<double, std::string> first_lifecycle_fault(const std::vector<std::string>& lifecycle);

/// Adds the run's lifecycle faults (the host watchdog: the board went silent; the board's own
/// watchdog or e-stop; a board reboot) to `verdict` as the figure "link faults" (at most 0, the
/// first fault's reason named), so that a run the runtime faulted never passes - as the
/// plausibility stage's "supervisor faults" does in process.
void add_link_fault_check(const runtime::RealtimeRunResult& run, safety::Verdict& verdict);

}  // namespace peha::experiments
