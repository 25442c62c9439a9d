#pragma once
/// \file
/// The board core (firmware/core, C11) as the emulator configures it: the channel map's scaling,
/// safe outputs, e-stop line and `board_limits:` turned into the core's `mfb_board_config`.

#include "peha/mfb/channel_map.hpp"
#include "peha/mfb/protocol.hpp"

#include "mfb_board.h"

#include <string>
#include <vector>

namespace peha::mfb {

/// The core's configuration for a board with channel map `map`, link key `key`, watchdog and vent
/// times. Without `board_limits:` in the map the ceilings are the channels' full code ranges and
/// there are no trips (`map.has_board_limits()` tells). Throws std::invalid_argument with the
/// core's message (field, expected, found) and the joint's name.
mfb_board_config board_core_config(const ChannelMap& map, const LinkKey& key, double watchdog_s, double vent_s);

/// What a scenario holds one joint to: the host's own hard numbers, which the board's
/// `board_limits:` must agree with (`peha check-config`).
struct JointEnvelope {
  std::string joint;
  double agonist_force_N = 0, antagonist_force_N = 0;  ///< the muscles' ceilings (max_force_N)
  double supply_pressure_Pa = 0;                       ///< every valve command's ceiling
  bool has_motor = false;
  double motor_torque_Nm = 0;                          ///< the motor's rating at the joint
  double min_angle_rad = 0, max_angle_rad = 0;         ///< the joint's range (the host's limits)
  double pressure_rate_Pa_per_s = 0;                   ///< the host's own pressure rate limit
};

/// How far the board's range may reach past the scenario's at either end: the arm's maps widen it
/// by 5 deg past the mechanical stops so that a limb resting on one does not trip; 10 deg more than
/// the scenario's no longer holds the joint near its range.
inline constexpr double kBoardRangeWiderMax_rad = 10.0 * 3.14159265358979323846 / 180.0;

/// One comparison of a board limit with the scenario, in the units of the map's files.
struct BoardLimitCheck {
  std::string joint, field;  ///< "joint", "agonist_force_N"
  double board = 0, scenario = 0;
  std::string rule;          ///< what must hold, e.g. "board <= scenario (max_force_N)"
  bool agrees = true;
};

/// Every board limit of `map` against the scenario's `envelopes` (one per map joint, by name):
/// force ceilings at most the muscles' max_force_N, pressure ceilings at most the supply, the motor
/// ceiling at most its rating, the range containing the scenario's and at most
/// kBoardRangeWiderMax_rad wider at either end, the pressure rise at least the host's own rate
/// (else the board slews the host's legitimate commands). A map without `board_limits:` is one row
/// that disagrees: the board would hold nothing of its own. A joint without an envelope throws
/// std::invalid_argument.
std::vector<BoardLimitCheck> board_limit_checks(const ChannelMap& map, const std::vector<JointEnvelope>& envelopes);

}  // namespace peha::mfb
