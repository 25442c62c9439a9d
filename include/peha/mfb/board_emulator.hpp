#pragma once
/// \file
/// `peha mfb-emulator`: the board's side of the MFB protocol over UDP, with a simulated exoskeleton
/// behind it. AD codes come from the simulated sensors and encoder counts from its joint angles
/// (through the channel map's inverse), DA codes drive the simulated valves and motor drivers.
///
/// Timing: the emulator advances its simulation by one control period per command it applies and
/// replies with the new sample at once, so a host at 1 kHz sees the same plant as the in-process
/// simulator (the first command of a new session is answered with the initial sample, without a
/// step). When commands stop for two periods the simulation runs on by itself, one period per
/// period of wall time, and a state packet goes to the last host every period.
///
/// Everything the board decides is the board core's (firmware/core, the C11 code a real board runs;
/// docs/porting.md): packet checks, the session, arming, the watchdog, the safe outputs (motor
/// torque cut at once, valve setpoints ramped linearly to 0 Pa over `vent_s`) and the board's own
/// limits from the channel map's `board_limits:`. This class is the core's HAL over the simulated
/// plant (inputs: the channel map's encoding of the plant's sensors; outputs: decoded into the
/// plant's command), the UDP socket, and the emulator's extras. A new session puts the simulated
/// exoskeleton back into its initial state.
///
/// Fault injection on the state packets it sends: loss, duplication, reordering, delay and
/// corruption (a flipped bit after the CRC), each with its probability, drawn from a seed; and an
/// e-stop input asserted over a time window of the simulation.

#include "peha/io/backend.hpp"
#include "peha/io/udp_socket.hpp"
#include "peha/mfb/board_core.hpp"
#include "peha/mfb/channel_map.hpp"
#include "peha/mfb/protocol.hpp"

#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace peha::mfb {

struct FaultInjection {
  double loss = 0;          ///< probability a state packet is not sent
  double duplicate = 0;     ///< probability it is sent twice
  double reorder = 0;       ///< probability it is held back and sent after the next one
  double corrupt = 0;       ///< probability one random bit of it is flipped (after the CRC)
  double delay_s = 0;       ///< every state packet leaves this much later
  std::uint64_t seed = 1;
  double estop_from_s = -1; ///< simulated time the e-stop input goes active (< 0: never)
  double estop_for_s = 0;   ///< and how long it stays active
  /// A loss burst: from the simulated time burst_from_s on, the next burst_packets state packets
  /// are not sent (0: none is sent from then on). burst_from_s < 0: no burst.
  double burst_from_s = -1;
  std::uint64_t burst_packets = 0;
  bool any() const {
    return loss > 0 || duplicate > 0 || reorder > 0 || corrupt > 0 || delay_s > 0 || estop_from_s >= 0 || burst_from_s >= 0;
  }
};

struct EmulatorParams {
  io::UdpEndpoint bind{0x7F000001u, 0};  ///< where the board listens (port 0 = any)
  LinkKey key;                           ///< the link's pre-shared key (mfb::load_link_key)
  double period_s = 1e-3;                ///< the simulation's step per command
  double watchdog_s = 0.05;              ///< no accepted command this long -> safe outputs
  double vent_s = 2.0;                   ///< valve setpoints ramp to 0 Pa over this after a trip
  double max_runtime_s = 0;              ///< stop after this much wall time (0 = until stopped)
  int sessions = 0;                      ///< stop after this many sessions ended by the watchdog (0 = never)
  FaultInjection faults;
  /// Record the plant's sensors (the emulator's truth) every step, for `truth()` (fixed capacity:
  /// this many steps; 0 = none).
  std::size_t truth_steps = 0;
};

/// What the board saw and did.
struct EmulatorStats {
  ReceiveCounters received;              ///< the CommandFilter's verdicts
  std::uint64_t oversized = 0;
  std::uint64_t steps_on_command = 0;    ///< simulation periods advanced by commands
  std::uint64_t steps_free_running = 0;  ///< ... by the wall clock while no command came
  std::uint64_t states_sent = 0;
  std::uint64_t sessions = 0;            ///< sessions adopted (each resets the simulation)
  std::uint64_t watchdog_trips = 0;
  std::uint64_t estop_cycles = 0;
  std::uint64_t injected_burst = 0;      ///< state packets dropped by the loss burst
  std::int64_t burst_ns = 0;             ///< host monotonic ns of the burst's first dropped packet (0: none yet)
  /// The watchdog's first trip while the outputs were armed (a host loss): host monotonic ns and
  /// simulated time (0, -1 if none).
  std::int64_t host_loss_ns = 0;
  double host_loss_t_s = -1;
  std::uint64_t injected_loss = 0, injected_duplicate = 0, injected_reorder = 0, injected_corrupt = 0, injected_delay = 0;
  /// The board's own limits (firmware core): muscles vented by their load cell's ceiling, joints
  /// tripped by their range, DA codes clamped to their ceilings, valve codes held by the slew limit.
  std::uint64_t force_trips = 0, range_trips = 0, speed_trips = 0, clamped_codes = 0, slewed_codes = 0;
  /// Per joint (the channel map's order), the least margin of its led angle (as the range vent
  /// judges it: the speed x lead + the stopping distance) inside its board range while the outputs
  /// were armed, deg; negative: it tripped; +inf: never armed, or no range (mfb_board_range_margin).
  std::array<double, MFB_MAX_JOINTS> closest_range_deg;
  /// Per joint, the highest |speed| the board measured (its speed ceiling's judgement, the rate
  /// window) while the outputs were armed, deg/s (mfb_board_speed).
  std::array<double, MFB_MAX_JOINTS> peak_speed_degps{};
  int joints = 0;  ///< joints of the map: the entries of closest_range_deg and peak_speed_degps that count
  EmulatorStats() { closest_range_deg.fill(std::numeric_limits<double>::infinity()); }
  std::string table() const;
};

class BoardEmulator {
 public:
  /// `make_plant` builds the simulated exoskeleton in its initial state (called per session).
  BoardEmulator(const EmulatorParams& params, ChannelMap map, std::function<std::unique_ptr<io::Backend>()> make_plant);

  /// The bound address (port chosen by the kernel when asked for 0).
  const io::UdpEndpoint& local() const noexcept { return socket_.local(); }
  /// Inputs the simulator does not have (e.g. a person's goniometer for E4): called with the
  /// simulated time (s) after the channel map has encoded the simulator's sensors, before sending.
  void set_input_hook(std::function<void(double t_s, BoardInputs& inputs)> hook) { input_hook_ = std::move(hook); }
  /// Called right before each simulation step with the command it applies (nullptr: a free-running
  /// step, no command came): a plant shared by several boards (mfb::SharedPlant) groups the boards'
  /// steps by the host's cycle.
  void set_step_hook(std::function<void(const CommandPacket* command)> hook) { step_hook_ = std::move(hook); }
  /// Serves until `stop` is set, max_runtime_s passes or `sessions` sessions have ended.
  void run(const std::atomic<bool>& stop);
  const EmulatorStats& stats() const noexcept { return stats_; }
  /// The board's boot id (random, nonzero, drawn at construction: one per power-on).
  std::uint32_t boot_id() const noexcept { return mfb_board_boot_id(&core_); }
  /// One simulation step as the plant saw it (EmulatorParams::truth_steps).
  struct TruthRow {
    double t_s;              ///< simulated time
    std::int64_t mono_ns;    ///< host monotonic clock at the step
    bool armed;              ///< the outputs followed the command
    bool motor_off;          ///< every motor DA channel at its zero-torque code, digital outputs low
  };
  /// One joint of a TruthRow: the plant's angle and load cells (with their noise).
  struct TruthJoint {
    double angle_rad;
    double agonist_N, antagonist_N;
  };
  const std::vector<TruthRow>& truth() const noexcept { return truth_; }
  /// Joint `joint` (the channel map's order) of truth row `row`.
  const TruthJoint& truth_joint(std::size_t row, int joint) const noexcept {
    return truth_joints_[row * static_cast<std::size_t>(map_.joint_count()) + static_cast<std::size_t>(joint)];
  }
  const ChannelMap& channel_map() const noexcept { return map_; }

 private:
  void apply_and_step(bool by_command) noexcept;
  void send_state(std::int64_t now) noexcept;
  void transmit(const std::uint8_t* bytes, std::size_t n, std::int64_t at_ns) noexcept;
  void flush_delayed(std::int64_t now) noexcept;
  void note_core_counters() noexcept;
  double uniform() noexcept;
  /// The injected e-stop input at simulated time t_s.
  bool estop_at(double t_s) const noexcept {
    return params_.faults.estop_from_s >= 0 && t_s >= params_.faults.estop_from_s &&
           t_s < params_.faults.estop_from_s + params_.faults.estop_for_s;
  }
  // The core's HAL over the simulated plant.
  static void hal_read_inputs(void* ctx, mfb_inputs* out);
  static void hal_write_outputs(void* ctx, const std::uint16_t da[MFB_DA_CHANNELS], std::uint8_t digital_out);
  static std::uint64_t hal_now_us(void* ctx);
  static void hal_mac(void* ctx, const std::uint8_t key[MFB_KEY_SIZE], const std::uint8_t* data, std::size_t size,
                      std::uint8_t out[MFB_MAC_SIZE]);
  static std::uint32_t hal_random(void* ctx);

  EmulatorParams params_;
  ChannelMap map_;
  std::function<std::unique_ptr<io::Backend>()> make_plant_;
  std::function<void(double, BoardInputs&)> input_hook_;
  std::function<void(const CommandPacket*)> step_hook_;
  io::UdpSocket socket_;
  std::unique_ptr<io::Backend> plant_;
  io::SensorState state_;
  mfb_board_config core_config_;
  mfb_hal hal_;
  mfb_board core_;
  BoardOutputs applied_{};               ///< what the DA is driving now (the core's outputs)
  CommandPacket last_command_{};         ///< the newest accepted command (the step hook's)
  bool have_host_ = false;
  io::UdpEndpoint host_;
  std::uint64_t rng_state_;
  std::uint64_t burst_left_ = 0;         ///< state packets the loss burst still drops
  bool burst_started_ = false;
  bool reported_armed_ = false;          ///< "outputs armed" printed (once, for a supervising process)
  std::vector<TruthRow> truth_;          ///< reserved to truth_steps
  std::vector<TruthJoint> truth_joints_; ///< reserved to truth_steps x the map's joints, row-major
  struct Pending {
    std::int64_t at_ns;
    std::size_t size;
    std::array<std::uint8_t, kMaxPacketSize> bytes;
  };
  std::vector<Pending> pending_;         ///< delayed datagrams (fixed capacity)
  bool have_held_ = false;               ///< a reordered packet waiting for the next
  Pending held_{};
  EmulatorStats stats_;
};

}  // namespace peha::mfb
