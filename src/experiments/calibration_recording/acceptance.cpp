#include "peha/experiments/calibration_recording/acceptance.hpp"

#include "peha/experiments/common/mujoco_lock.hpp"
#include "peha/models/units.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

namespace peha::experiments {
namespace {

/// Keeps the log rows of the check (set-up side: it allocates when a row arrives, as CsvLog does).
class RowsKept final : public runtime::RowSink {
 public:
  void push_row(std::span<const double> row) noexcept override {
    try {
      rows.emplace_back(row.begin(), row.end());
    } catch (...) {
      ++dropped;
    }
  }
  std::vector<std::vector<double>> rows;
  std::size_t dropped = 0;
};


std::size_t column(const char* name) {
  const auto& c = e1_log_columns();
  return static_cast<std::size_t>(std::find(c.begin(), c.end(), name) - c.begin());
}

}  // namespace

std::string AcceptanceResult::failure(int i) const {
  std::string out;
  const char* name = i == 0 ? "agonist" : "antagonist";
  if (!(force_tracking_rms_N[i] <= max_rms_N[i])) {
    out += fmt::format("{} force tracking RMS {:.1f} N > {:.1f} N (request RMS {:.0f} N)", name, force_tracking_rms_N[i],
                       max_rms_N[i], force_request_rms_N[i]);
  }
  if (!(min_loadcell_N[i] >= min_tension_N)) {
    out += fmt::format("{}{} lowest load-cell force {:.1f} N < {:.1f} N (wire near slack)", out.empty() ? "" : "; ", name,
                       min_loadcell_N[i], min_tension_N);
  }
  return out;
}

AcceptanceResult run_acceptance_check(const E1Scenario& scenario, const CalibrationAcceptance& a,
                                      const std::function<sim::OneDofRigParams(const E1Scenario&, const E1Case&)>& plant_of) {
  E1Scenario s = scenario;
  s.controller.allocation.force_trim_rate_1ps = 0.0;  // the paper's pure feed-forward: the calibration alone
  use_calibration_loadcell_zero(s);
  const auto holds = a.angles_rad.size();
  s.duration_s = static_cast<double>(holds) * a.hold_s;
  // The link is clamped at each angle (a pin through the link on the rig): a stiff, strong "finger"
  // at the tip, so that each muscle's force follows only its own pressure at a known contraction,
  // whatever the other muscle's model does. 50 kN/m at 0.4 m is 8 kNm/rad: a 20 Nm torque error
  // moves the link 0.14 deg.
  s.plant.finger.stiffness_N_per_m = kClampStiffness_N_per_m;
  s.plant.finger.damping_Ns_per_m = kClampDamping_Ns_per_m;
  s.plant.finger.max_force_N = kClampMaxForce_N;
  s.plant.finger.pushes.clear();
  s.probe_direction.assign(holds, 0);
  for (std::size_t i = 0; i < holds; ++i) {
    sim::FingerPush p;
    p.name = fmt::format("check_{}", i);
    p.start_s = static_cast<double>(i) * a.hold_s;
    p.duration_s = a.hold_s;
    p.move_s = std::min(1.0, 0.5 * a.hold_s);
    p.target_angle_rad = a.angles_rad[i];
    p.clamp = true;
    s.plant.finger.pushes.push_back(p);
  }
  AcceptanceResult r;
  r.min_tension_N = a.min_tension_fraction * s.controller.joint.pretension_N;
  const std::size_t t_col = column("t_s"), angle_col = column("angle_rad");
  const std::size_t cmd_col[2] = {column("agonist_force_cmd_N"), column("antagonist_force_cmd_N")};
  const std::size_t lc_col[2] = {column("agonist_loadcell_N"), column("antagonist_loadcell_N")};
  const std::size_t p_col[2] = {column("agonist_pressure_cmd_MPa"), column("antagonist_pressure_cmd_MPa")};
  double sum[2] = {0, 0}, request_sum[2] = {0, 0};
  std::size_t count = 0;
  r.min_loadcell_N[0] = r.min_loadcell_N[1] = std::numeric_limits<double>::infinity();
  for (const E1Case& c : s.cases) {
    sim::OneDofRigParams params = plant_of(s, c);
    params.finger = s.plant.finger;
    std::unique_ptr<sim::OneDofRigBackend> rig;
    {
      const std::lock_guard lock(mujoco_load_mutex());
      rig = std::make_unique<sim::OneDofRigBackend>(params);
    }
    RowsKept rows;
    rows.rows.reserve(static_cast<std::size_t>(std::llround(s.duration_s / s.period_s)) + 2);
    // No simulator truth: the figures are what the rig's sensors give.
    run_e1_on(s, c, *rig, nullptr, &rows);
    const models::JointModel& joint = s.controller.joint;
    // The load cells as the controller reads them: less the zero the calibration's recording measured.
    const double zero_N[2] = {joint.agonist.loadcell_zero_N, joint.antagonist.loadcell_zero_N};
    for (std::size_t i = 0; i < holds; ++i) {
      const double t0 = static_cast<double>(i) * a.hold_s + a.settle_s, t1 = static_cast<double>(i + 1) * a.hold_s;
      AcceptancePoint p;
      p.case_name = c.name;
      p.min_loadcell_N[0] = p.min_loadcell_N[1] = std::numeric_limits<double>::infinity();
      std::size_t n = 0;
      for (const std::vector<double>& row : rows.rows) {
        if (row[t_col] < t0 || row[t_col] >= t1) continue;
        ++n;
        p.angle_deg += row[angle_col];
        for (int m = 0; m < 2; ++m) {
          const double loadcell_N = row[lc_col[m]] - zero_N[m];
          const double e = row[cmd_col[m]] - loadcell_N;
          sum[m] += e * e;
          request_sum[m] += row[cmd_col[m]] * row[cmd_col[m]];
          p.force_cmd_N[m] += row[cmd_col[m]];
          p.loadcell_N[m] += loadcell_N;
          p.pressure_cmd_Pa[m] += row[p_col[m]] * 1e6;
          p.min_loadcell_N[m] = std::min(p.min_loadcell_N[m], loadcell_N);
        }
      }
      if (n == 0) continue;
      count += n;
      const double k = 1.0 / static_cast<double>(n);
      p.angle_deg *= k;
      for (int m = 0; m < 2; ++m) {
        p.force_cmd_N[m] *= k;
        p.loadcell_N[m] *= k;
        p.pressure_cmd_Pa[m] *= k;
        r.min_loadcell_N[m] = std::min(r.min_loadcell_N[m], p.min_loadcell_N[m]);
        p.contraction[m] = models::rigid_contraction(m == 0 ? joint.agonist : joint.antagonist, joint.pulley_radius_m,
                                                     m == 0 ? +1 : -1, p.angle_deg);
      }
      p.angle_deg *= models::kDegPerRad;
      r.points.push_back(p);
    }
  }
  for (int m = 0; m < 2; ++m) {
    r.force_tracking_rms_N[m] = count ? std::sqrt(sum[m] / static_cast<double>(count)) : std::numeric_limits<double>::quiet_NaN();
    r.force_request_rms_N[m] = count ? std::sqrt(request_sum[m] / static_cast<double>(count)) : std::numeric_limits<double>::quiet_NaN();
    r.max_rms_N[m] = std::max(a.max_force_tracking_rms_N, a.max_force_tracking_rms_fraction * r.force_request_rms_N[m]);
    if (count == 0) r.min_loadcell_N[m] = std::numeric_limits<double>::quiet_NaN();
  }
  return r;
}

}  // namespace peha::experiments
