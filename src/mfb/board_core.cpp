#include "peha/mfb/board_core.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace peha::mfb {
namespace {

mfb_channel_si channel_si(const AnalogChannel& ch) { return {ch.channel, ch.offset_SI, ch.scale_SI}; }

}  // namespace

mfb_board_config board_core_config(const ChannelMap& map, const LinkKey& key, double watchdog_s, double vent_s) {
  mfb_board_si si{};
  std::copy(key.bytes.begin(), key.bytes.end(), si.key);
  si.watchdog_s = watchdog_s;
  si.vent_s = vent_s;
  const BoardOutputs safe = map.safe_outputs();
  std::copy(safe.da.begin(), safe.da.end(), si.safe_da);
  si.safe_digital_out = safe.digital_out;
  si.estop_line = map.estop_line().line;
  si.estop_active_high = map.estop_line().active_high;
  si.procedure_key_line = map.procedure_key_line() ? map.procedure_key_line()->line : -1;
  si.procedure_key_active_high = map.procedure_key_line() && map.procedure_key_line()->active_high;
  si.joint_count = map.joint_count();
  const bool limited = map.has_board_limits();
  for (int j = 0; j < map.joint_count(); ++j) {
    const JointChannels& c = map.joint(j);
    const BoardLimits& l = c.board_limits;
    mfb_joint_si& js = si.joints[j];
    const AnalogChannel* valves[2] = {&c.agonist_valve, &c.antagonist_valve};
    const AnalogChannel* loadcells[2] = {&c.agonist_loadcell, &c.antagonist_loadcell};
    const double force[2] = {l.agonist_force_N, l.antagonist_force_N};
    const double pressure[2] = {l.agonist_pressure_Pa, l.antagonist_pressure_Pa};
    for (int m = 0; m < 2; ++m) {
      js.muscle[m].valve = channel_si(*valves[m]);
      js.muscle[m].loadcell = channel_si(*loadcells[m]);
      js.muscle[m].pressure_ceiling_Pa = limited ? pressure[m] : valves[m]->max_si();
      js.muscle[m].force_ceiling_N = force[m];
      // Without limits: a rise over the whole range in 1 us, i.e. none.
      js.muscle[m].pressure_rise_Pa_per_s = limited ? l.pressure_rise_Pa_per_s : std::abs(valves[m]->max_si() - valves[m]->min_si()) * 1e6;
      js.muscle[m].force_lead_s = limited ? l.force_lead_s : 0.0;
      if (!limited) js.muscle[m].loadcell.channel = -1;  // no trip without a configured ceiling
    }
    js.motor = channel_si(c.motor);
    js.motor_ceiling_Nm = limited ? l.motor_torque_Nm : std::max(std::abs(c.motor.min_si()), std::abs(c.motor.max_si()));
    js.encoder = {limited ? c.encoder.channel : -1, c.encoder.offset_rad, c.encoder.rad_per_count};
    js.min_angle_rad = l.min_angle_rad;
    js.max_angle_rad = l.max_angle_rad;
    js.range_vent = l.range_vent;
    js.angle_lead_s = l.angle_lead_s;
    js.brake_rad_per_s2 = l.brake_rad_per_s2;
    js.speed_ceiling_rad_per_s = limited ? l.speed_ceiling_rad_per_s : 0.0;
    js.speed_lead_s = l.speed_lead_s;
  }
  mfb_board_config cfg{};
  char error[200];
  if (!mfb_configure(&si, &cfg, error, sizeof error)) {
    // The core counts joints from 0 in the map's order; name the joint.
    std::string message = error;
    for (int j = 0; j < map.joint_count(); ++j) {
      const std::string at = fmt::format("joints[{}]", j);
      if (message.rfind(at, 0) == 0) message = fmt::format("joint '{}'{}", map.joint_names()[static_cast<std::size_t>(j)], message.substr(at.size()));
    }
    throw std::invalid_argument(fmt::format("board limits: {}", message));
  }
  return cfg;
}

std::vector<BoardLimitCheck> board_limit_checks(const ChannelMap& map, const std::vector<JointEnvelope>& envelopes) {
  std::vector<BoardLimitCheck> rows;
  if (!map.has_board_limits()) {
    rows.push_back({"-", "board_limits", 0, 0, "present: without it the board holds no limit of its own", false});
    return rows;
  }
  constexpr double kRad = 180.0 / 3.14159265358979323846;
  for (int j = 0; j < map.joint_count(); ++j) {
    const std::string& name = map.joint_names()[static_cast<std::size_t>(j)];
    const auto e = std::find_if(envelopes.begin(), envelopes.end(), [&](const JointEnvelope& x) { return x.joint == name; });
    if (e == envelopes.end()) throw std::invalid_argument(fmt::format("board limits: the scenario has no joint '{}'", name));
    const BoardLimits& b = map.joint(j).board_limits;
    // at_most: the board's value must not pass the scenario's (with a tolerance for the files' rounding).
    auto at_most = [&](const char* field, double board, double scenario, double tolerance, const char* what) {
      rows.push_back({name, field, board, scenario, fmt::format("board <= scenario ({})", what), board <= scenario + tolerance});
    };
    at_most("agonist_force_N", b.agonist_force_N, e->agonist_force_N, 0.5, "agonist max_force_N");
    at_most("antagonist_force_N", b.antagonist_force_N, e->antagonist_force_N, 0.5, "antagonist max_force_N");
    at_most("agonist_pressure_MPa", b.agonist_pressure_Pa * 1e-6, e->supply_pressure_Pa * 1e-6, 1e-4, "supply_pressure_MPa");
    at_most("antagonist_pressure_MPa", b.antagonist_pressure_Pa * 1e-6, e->supply_pressure_Pa * 1e-6, 1e-4, "supply_pressure_MPa");
    if (e->has_motor && map.joint(j).motor.mapped()) {
      at_most("motor_torque_Nm", b.motor_torque_Nm, e->motor_torque_Nm, 1e-3, "motor_max_torque_Nm");
    }
    const double wider = kBoardRangeWiderMax_rad * kRad;
    const double lo = b.min_angle_rad * kRad, hi = b.max_angle_rad * kRad, slo = e->min_angle_rad * kRad, shi = e->max_angle_rad * kRad;
    rows.push_back({name, "angle_deg[0]", lo, slo, fmt::format("scenario - {:g} <= board <= scenario (min_angle_deg)", wider),
                    lo <= slo + 1e-6 && lo >= slo - wider - 1e-6});
    rows.push_back({name, "angle_deg[1]", hi, shi, fmt::format("scenario <= board <= scenario + {:g} (max_angle_deg)", wider),
                    hi >= shi - 1e-6 && hi <= shi + wider + 1e-6});
    rows.push_back({name, "pressure_rise_MPa_per_s", b.pressure_rise_Pa_per_s * 1e-6, e->pressure_rate_Pa_per_s * 1e-6,
                    "board >= scenario (pressure_rate_MPa_per_s)", b.pressure_rise_Pa_per_s >= e->pressure_rate_Pa_per_s - 1.0});
  }
  return rows;
}

}  // namespace peha::mfb
