#pragma once
/// \file
/// The one hardware door: every experiment and procedure gets its io::Backend here, from a
/// BackendUri (`--backend`) and what the run declares (its joints, period, the scenario's `mfb:`
/// section, its simulated plant). The only place the host's board backends are constructed, so a
/// new kind of hardware (an EtherCAT master, a DAQ card) is one more case here and one more URI
/// form in backend_uri.hpp - no experiment changes (docs/architecture.md, "Where new work plugs in").

#include "peha/hardware/backend_uri.hpp"
#include "peha/hardware/replay_backend.hpp"
#include "peha/io/backend.hpp"
#include "peha/mfb/boards_backend.hpp"
#include "peha/mfb/link_config.hpp"

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace peha::hardware {

/// What a run declares to the door.
struct HardwareRequest {
  double period_s = 1e-3;
  std::vector<std::string> joint_names;  ///< the io joints, in io order
  /// Each joint's column prefix in the run's logs (replay:); empty: "" for every joint.
  std::vector<std::string> log_prefixes;
  const mfb::LinkConfig* link = nullptr;  ///< the scenario's `mfb:` section (udp:// needs it)
  /// The run's simulated plant, in its initial state (sim:). Empty: the run has no simulated form.
  std::function<std::unique_ptr<io::Backend>()> simulate;
  /// Refuses more than one board (an experiment whose board-side inputs live on one board, e.g. E4's goniometer).
  bool one_board = false;
  /// The run drives joints onto their stops on purpose (the calibration recording): a board whose
  /// map has a procedure key needs it turned; every other run refuses a turned key.
  bool drives_onto_stops = false;
};

/// The hardware a run drives. `backend` owns it; `boards` / `replay` point into it when it is one.
struct Hardware {
  std::unique_ptr<io::Backend> backend;
  mfb::BoardsBackend* boards = nullptr;
  ReplayBackend* replay = nullptr;
  /// One line for log headers: "sim:", "udp://127.0.0.1:50000, session 1a2b3c4d", "replay:<log>".
  std::string where() const;
};

/// Opens the backend `uri` for `request`, not yet configured (udp://: configure() is the session
/// handshake, done by the run's supervisor). Throws std::invalid_argument on a URI the request
/// cannot take (no `mfb:` section, no simulated form, the wrong number of board addresses),
/// config::Error on a bad channel map, std::runtime_error on a bad key file, a board no interface
/// reaches, or a log a replay cannot use.
Hardware open_backend(const BackendUri& uri, const HardwareRequest& request);

}  // namespace peha::hardware
