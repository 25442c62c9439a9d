#pragma once
/// \file
/// The controllers' start-up tare (AllocationParams::loadcell_check.tare_s > 0, docs/models.md):
/// the muscles vented for vent_s while the link is held, every joint's load cells averaged over
/// tare_s, then compensation; the wires are slack on purpose until refill_s after it starts. One
/// piece for the one-DOF controller and the arm's: the LoadcellCheck is the model, StartupTare the
/// data, the step a noexcept, allocation-free free function.

#include "peha/control/allocation.hpp"
#include "peha/io/backend.hpp"

#include <array>

namespace peha::control {

enum class StartupPhase { kVenting, kTaring, kCompensating };

struct StartupTare {
  StartupPhase phase = StartupPhase::kCompensating;
  bool started = false;
  double phase_start_s = 0;
  double compensating_since_s = -1;  ///< when compensation began (< 0 before)
  std::array<std::array<double, 2>, io::kMaxJoints> sum_N{};  ///< load-cell sums while taring (agonist, antagonist)
  long samples = 0;
};

/// The start-up of a controller with `check`: venting first when check.tare_s > 0, else compensating.
StartupTare start_tare(const LoadcellCheck& check) noexcept;

/// One control step of the start-up at sample `s`. Returns true while the muscles are to stay
/// vented (venting or taring); false once compensating - the step where it first returns false is
/// the one the offsets (tare_offset_N) are ready on. The tare completes on a finite sample only.
bool step_startup_tare(const LoadcellCheck& check, const io::SensorState& s, StartupTare& t) noexcept;

/// The averaged reading of joint `joint`'s muscle (0 agonist, 1 antagonist), N; 0 when beyond
/// check.max_tare_N (not believed) or before any sample.
double tare_offset_N(const LoadcellCheck& check, const StartupTare& t, int joint, int muscle) noexcept;

/// True while the wires are slack on purpose: a tare runs and compensation began less than
/// check.refill_s ago (or not yet). The experiments do not judge the wires' tension then.
bool wires_slack_on_purpose(const LoadcellCheck& check, const StartupTare& t, double t_s) noexcept;

}  // namespace peha::control
