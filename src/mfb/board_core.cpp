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

}  // namespace peha::mfb
