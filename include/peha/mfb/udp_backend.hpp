#pragma once
/// \file
/// The host side of the MFB link: an io::Backend that drives a multifunction board (or
/// `peha mfb-emulator`) over UDP with the protocol of docs/mfb-protocol.md and a channel map
/// (docs/channel-maps.md). Per control cycle the loop calls read() (the newest sample, without
/// waiting) and write() (one command datagram, then waiting at most `receive_timeout_s` for the
/// board's reply, which the next read() returns).
///
/// Only state packets from the configured board address and the host's session, newer than the
/// last accepted one, intact (CRC) and authentic (MAC under the link key) are applied; every other datagram is counted and dropped
/// (mfb::StateFilter). A sample whose AD codes are implausible (a sensor at its rail) is dropped too.
/// read()/write() are noexcept and allocation-free; construction and connect() throw.

#include "peha/io/backend.hpp"
#include "peha/io/udp_socket.hpp"
#include "peha/mfb/channel_map.hpp"
#include "peha/mfb/protocol.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace peha::mfb {

struct UdpBackendParams {
  io::UdpEndpoint board;                     ///< where the board listens
  /// Host's bind address (port 0 = any). Address 0: the address of the interface that reaches the
  /// board (the kernel's route to it), so a board on any network this machine is on works.
  io::UdpEndpoint local{0, 0};
  LinkKey key;                               ///< the link's pre-shared key (mfb::load_link_key)
  std::uint32_t session_id = 0;              ///< 0 = random nonzero (libsodium's randombytes)
  double period_s = 1e-3;                    ///< control period
  double receive_timeout_s = 0.0008;         ///< how long read() waits for the reply to the last command
  double connect_timeout_s = 2.0;            ///< connect() gives up after this
  std::vector<std::string> joint_names;      ///< io joint order (the channel map's joints)
  /// The run drives joints onto their stops on purpose (the calibration recording): the rig's
  /// procedure key (the map's `procedure_key_input`) must be turned. Every other run refuses a
  /// turned key: with it the board's range does not vent.
  bool procedure_key_wanted = false;
};

/// What the host has seen of the link.
struct UdpLinkStats {
  ReceiveCounters received;                  ///< the StateFilter's verdict counters
  std::uint64_t commands_sent = 0;          ///< commands and hellos sent
  std::uint64_t send_failures = 0;
  std::uint64_t replies_missing = 0;         ///< read() calls that found no new sample (the loop held its command)
  std::uint64_t late_replies = 0;            ///< commands whose reply did not come within receive_timeout_s
  std::uint64_t implausible_samples = 0;     ///< accepted packets whose AD codes were implausible
  std::uint64_t clamped_outputs = 0;         ///< DA codes clamped to 0..65535
  std::uint64_t oversized = 0;               ///< datagrams longer than any MFB packet
  std::uint64_t rtt_count = 0;               ///< round trips measured (accepted samples echoing a send time)
  double rtt_sum_s = 0;                      ///< their sum, s (mean = rtt_sum_s / rtt_count)
  double rtt_max_s = 0;                      ///< the longest, s
};

class UdpBackend final : public io::Backend {
 public:
  UdpBackend(const UdpBackendParams& params, ChannelMap map);

  /// Opens (or re-confirms) the session: says hello (docs/mfb-protocol.md#the-handshake), and with
  /// the board's nonce from its answer sends commands with outputs disabled until the board
  /// answers one of them with its reply (a state packet of this session acknowledging that
  /// command). The disabled command also acknowledges a watchdog trip the board may have latched
  /// meanwhile, so the reply carries the board's status as of now, not a stale one. Calling it
  /// again re-confirms the session (same id). Until an enabled command follows, the board holds
  /// its safe outputs: send the enable edge right after.
  /// If the board reports `kStatusHostLost` (its previous host fell silent while the outputs were
  /// armed), the operator must arm it: activate() is refused until deactivate(), exactly like an
  /// e-stop, and status() reports the board's watchdog as tripped, so the run faults at once and
  /// the operator's recover (`r` + Enter, or --recover-after) sends the arming edge with
  /// `kCommandOperatorArm`. Throws std::runtime_error after connect_timeout_s, and when the
  /// map's procedure key is not as the run needs it (`procedure_key_wanted`).
  void connect();

  const io::BackendInfo& info() const override { return info_; }
  /// The lifecycle on the board: configure() = connect(); activate() = the enable edge (the board
  /// arms on clear -> set, once it has seen a disabled command; with the operator's arm bit while
  /// it reports a host loss); deactivate() = enable clear (the board holds its safe outputs and
  /// vents); estop() = enable clear, latched until deactivate(). A host loss found by connect()
  /// latches like estop().
  void configure() override { connect(); }
  void activate() noexcept override { enable_ = !estop_latched_ && !host_lost_latched_; }
  void deactivate() noexcept override {
    enable_ = false;
    estop_latched_ = false;
    host_lost_latched_ = false;
    rebooted_ = false;
  }
  void estop() noexcept override {
    enable_ = false;
    estop_latched_ = true;
  }
  /// From the newest accepted state packet: active = enabled and the board's outputs armed; e-stop
  /// from its status bit, its input line or estop(); its watchdog's trip; ready_to_arm once it has
  /// acknowledged a disabled command; when the sample arrived and its command's round trip.
  io::BackendStatus status() const noexcept override;
  /// The newest accepted sample not returned before (normally the reply write() waited for).
  /// False if none arrived (the caller holds its command and counts it).
  bool read(io::SensorState& state) noexcept override;
  /// Encodes and sends one command with the current enable flag, then waits up to
  /// receive_timeout_s for the board's reply (noted for the next read()).
  bool write(const io::Command& command) noexcept override;
  /// write() in two halves, for a host driving several boards in one cycle (mfb::BoardsBackend):
  /// send() sends the command without waiting; await_reply() then waits until the board's reply
  /// to it arrived or the monotonic clock reaches `deadline_ns`, and counts a late reply.
  bool send(const io::Command& command) noexcept;
  void await_reply(std::int64_t deadline_ns) noexcept;

  bool enabled() const noexcept { return enable_; }
  /// Status bits of the newest accepted state packet (kStatus...).
  std::uint8_t board_status() const noexcept { return last_.status; }
  /// True once the board has acknowledged a command sent with enable clear (needed before an enable edge).
  bool board_saw_disable() const noexcept { return acked_disable_; }
  /// Host monotonic ns when the last sample was accepted (0 before any).
  std::int64_t last_sample_ns() const noexcept { return last_sample_ns_; }
  /// Round-trip time of the newest accepted sample's command (host now - its echoed send time), s
  /// (NaN before any).
  double last_rtt_s() const noexcept { return last_rtt_s_; }
  const UdpLinkStats& stats() const noexcept { return stats_; }
  std::uint32_t session_id() const noexcept { return session_; }
  const ChannelMap& channel_map() const noexcept { return map_; }
  const io::UdpEndpoint& local() const noexcept { return socket_.local(); }
  /// Where the board listens.
  const io::UdpEndpoint& board() const noexcept { return params_.board; }
  /// The goniometer of io joint `joint` in the newest sample, rad (NaN if the map has none).
  double goniometer_rad(int joint) const noexcept { return map_.goniometer_rad(last_inputs_, joint); }
  /// A sample's e-stop input (from the last accepted packet's digital lines).
  bool estop_input() const noexcept { return map_.estop_active(last_inputs_); }

 private:
  void drain(std::int64_t deadline_ns) noexcept;
  /// Throws unless the procedure key is as `procedure_key_wanted` asks (maps without a key: nothing).
  void check_procedure_key() const;
  /// write() without counting a late reply (the handshake's commands are not the loop's).
  bool send_and_wait(const io::Command& command) noexcept;
  /// Encodes and sends one command or hello.
  bool send_packet(const CommandPacket& packet) noexcept;

  UdpBackendParams params_;
  ChannelMap map_;
  io::BackendInfo info_;
  io::UdpSocket socket_;
  std::uint32_t session_ = 0;
  StateFilter filter_;
  std::uint32_t sequence_ = 0;
  std::uint64_t board_nonce_ = 0;            ///< the board's nonce of this session (0: say hello)
  bool enable_ = false;
  bool acked_disable_ = false;
  bool have_new_ = false;
  bool last_was_reply_ = false;
  bool estop_latched_ = false;
  bool host_lost_latched_ = false;           ///< connect() found the board's kStatusHostLost
  bool rebooted_ = false;                    ///< the StateFilter saw a new boot id since deactivate()
  std::uint64_t reboots_seen_ = 0;           ///< the StateFilter's reboot count when last looked at
  std::uint64_t rtt_samples_ = 0;            ///< round trips measured
  std::uint32_t disable_sequence_ = 0;       ///< a command sent with enable clear
  StatePacket last_{};
  BoardInputs last_inputs_{};
  std::int64_t last_sample_ns_ = 0;
  double last_rtt_s_;
  UdpLinkStats stats_;
};

}  // namespace peha::mfb
