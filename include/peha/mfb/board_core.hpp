#pragma once
/// \file
/// The board core (firmware/core, C11) as the emulator configures it: the channel map's scaling,
/// safe outputs, e-stop line and `board_limits:` turned into the core's `mfb_board_config`.

#include "peha/mfb/channel_map.hpp"
#include "peha/mfb/protocol.hpp"

#include "mfb_board.h"

namespace peha::mfb {

/// The core's configuration for a board with channel map `map`, link key `key`, watchdog and vent
/// times. Without `board_limits:` in the map the ceilings are the channels' full code ranges and
/// there are no trips (`map.has_board_limits()` tells). Throws std::invalid_argument with the
/// core's message (field, expected, found) and the joint's name.
mfb_board_config board_core_config(const ChannelMap& map, const LinkKey& key, double watchdog_s, double vent_s);

}  // namespace peha::mfb
