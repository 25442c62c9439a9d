#include "peha/mfb/udp_backend.hpp"
#include "peha/mfb/link_config.hpp"

#include <fmt/format.h>
#include <sodium.h>
#include <spdlog/spdlog.h>

#include <arpa/inet.h>
#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <limits>
#include <netinet/in.h>
#include <stdexcept>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

namespace peha::mfb {
namespace {

std::uint32_t random_session(std::uint32_t previous) {
  if (sodium_init() < 0) throw std::runtime_error("libsodium failed to initialise (no entropy source?)");
  std::uint32_t s = 0;
  while (s == 0 || s == previous) s = randombytes_random();
  return s;
}

/// Where the host binds: `params.local`, or with address 0 the address of the interface the
/// kernel routes to the board through (connect() on a UDP socket sends nothing; it only picks the
/// route and the source address).
io::UdpEndpoint bind_endpoint(const UdpBackendParams& params) {
  if (params.local.address != 0) return params.local;
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw std::runtime_error(fmt::format("UDP socket: {}", std::strerror(errno)));
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_addr.s_addr = htonl(params.board.address);
  to.sin_port = htons(params.board.port);
  sockaddr_in source{};
  socklen_t len = sizeof source;
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&to), sizeof to) != 0 ||
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&source), &len) != 0) {
    const int err = errno;
    ::close(fd);
    throw std::runtime_error(fmt::format("the MFB at {} cannot be reached from this machine: {} (no interface of this machine may send "
                                         "to it: check the board's address in --backend and the network set-up, 'ip route get {}')",
                                         params.board.to_string(), std::strerror(err),
                                         params.board.to_string().substr(0, params.board.to_string().rfind(':'))));
  }
  ::close(fd);
  return {ntohl(source.sin_addr.s_addr), params.local.port};
}

}  // namespace

UdpBackend::UdpBackend(const UdpBackendParams& params, ChannelMap map)
    : params_(params),
      map_(std::move(map)),
      socket_(bind_endpoint(params)),
      session_(params.session_id ? params.session_id : random_session(0)),
      filter_(session_, params.key),
      last_rtt_s_(std::numeric_limits<double>::quiet_NaN()) {
  require_private_key_off_loopback(params.key, params.board.address, "board");
  if (static_cast<int>(params.joint_names.size()) != map_.joint_count()) {
    throw std::invalid_argument(fmt::format("UdpBackend: {} joint names for a channel map of {} joints", params.joint_names.size(),
                                            map_.joint_count()));
  }
  info_.name = "mfb:udp://" + params.board.to_string();
  info_.joint_names = params.joint_names;
  info_.period_s = params.period_s;
}

io::BackendStatus UdpBackend::status() const noexcept {
  io::BackendStatus s;
  s.active = enable_ && !(last_.status & kStatusOutputsSafe);
  s.estop = (last_.status & kStatusEstop) || estop_input() || estop_latched_;
  s.watchdog_tripped = (last_.status & (kStatusWatchdogTripped | kStatusHostLost)) != 0;
  s.ready_to_arm = acked_disable_;
  s.rebooted = rebooted_;
  s.last_sample_ns = last_sample_ns_;
  s.last_rtt_s = last_rtt_s_;
  s.rtt_samples = rtt_samples_;
  return s;
}

void UdpBackend::connect() {
  enable_ = false;
  const std::int64_t give_up = io::monotonic_ns() + static_cast<std::int64_t>(params_.connect_timeout_s * 1e9);
  io::Command idle;
  idle.joint_count = map_.joint_count();
  while (io::monotonic_ns() < give_up) {
    // Without the board's nonce of this session, send() says hello; its answer brings the nonce.
    const bool hello = board_nonce_ == 0;
    send_and_wait(idle);
    // Only the reply to this very command counts: state packets the board sent while the host was
    // busy (free-running, perhaps with a watchdog trip the command has since acknowledged) do not.
    if (!last_was_reply_) drain(io::monotonic_ns() + 20'000'000);  // 20 ms per attempt
    // The board holds the session once it replies to a command of it (a board holding another
    // host's session drops ours until its watchdog lets that one go).
    if (last_was_reply_ && !hello && board_nonce_ != 0 && !(last_.status & kStatusNoSession)) {
      if (last_.status & kStatusHostLost) {
        host_lost_latched_ = true;
        spdlog::warn("the MFB at {} lost its previous host while its outputs were armed: it stays disarmed until the operator "
                     "arms it (type 'r' + Enter after the fault, or run with --recover-after S); see docs/mfb-protocol.md",
                     params_.board.to_string());
      }
      check_procedure_key();
      return;
    }
  }
  throw std::runtime_error(fmt::format("no MFB answered at {} within {} s (session {:08x}): is the board (or peha mfb-emulator "
                                       "--port {}) running?",
                                       params_.board.to_string(), params_.connect_timeout_s, session_, params_.board.port));
}

void UdpBackend::check_procedure_key() const {
  const std::optional<DigitalLine>& key = map_.procedure_key_line();
  if (!key) return;
  const bool turned = key->active(last_.digital_in);
  if (turned && !params_.procedure_key_wanted) {
    throw std::runtime_error(fmt::format("the procedure key at the MFB at {} (input line {}) is turned: with it the board's range does not "
                                         "vent, which only a procedure that drives the joints onto their stops (peha record-calibration) "
                                         "may ask for. Turn it back, then start the run again",
                                         params_.board.to_string(), key->line));
  }
  if (!turned && params_.procedure_key_wanted) {
    throw std::runtime_error(fmt::format("this procedure drives the joints onto their stops: turn the procedure key at the MFB at {} (input "
                                         "line {}) first, or the board's range vents a muscle on the stop",
                                         params_.board.to_string(), key->line));
  }
}

void UdpBackend::drain(std::int64_t deadline_ns) noexcept {
  std::array<std::uint8_t, 512> buffer;
  for (;;) {
    io::UdpEndpoint from;
    const long n = socket_.receive(buffer, from);
    if (n >= 0) {
      if (static_cast<std::size_t>(n) > buffer.size()) {
        ++stats_.oversized;
        continue;
      }
      StatePacket packet;
      const Verdict v = filter_.accept(std::span<const std::uint8_t>(buffer.data(), static_cast<std::size_t>(n)), from == params_.board,
                                       packet);
      if (v != Verdict::kAccept) continue;
      if (packet.board_nonce != board_nonce_) {
        // The answer to a hello, or 0: the board holds no session of ours (it restarted), and the
        // next send() says hello. Either way a session of its own, whose edge starts afresh.
        board_nonce_ = packet.board_nonce;
        acked_disable_ = false;
      }
      if (filter_.counters().reboots != reboots_seen_) {  // a new boot id: the board restarted under the run
        reboots_seen_ = filter_.counters().reboots;
        rebooted_ = true;
      }
      last_ = packet;
      have_new_ = true;
      last_sample_ns_ = io::monotonic_ns();
      if (packet.ack_sequence == disable_sequence_ && sequence_ != 0) acked_disable_ = true;
      if (packet.echo_host_time_ns != 0) {
        last_rtt_s_ = static_cast<double>(last_sample_ns_ - static_cast<std::int64_t>(packet.echo_host_time_ns)) * 1e-9;
        ++rtt_samples_;
        ++stats_.rtt_count;
        stats_.rtt_sum_s += last_rtt_s_;
        stats_.rtt_max_s = std::max(stats_.rtt_max_s, last_rtt_s_);
      }
      if (packet.ack_sequence == sequence_) {
        last_was_reply_ = true;
        return;  // the reply to the newest command: nothing newer can be waiting for
      }
      continue;
    }
    const std::int64_t left = deadline_ns - io::monotonic_ns();
    if (left <= 0 || !socket_.wait_readable(left)) return;
  }
}

bool UdpBackend::read(io::SensorState& state) noexcept {
  // write() waited for the reply to the last command; whatever came since is taken without waiting.
  drain(io::monotonic_ns());
  stats_.received = filter_.counters();
  if (!have_new_) {
    ++stats_.replies_missing;
    return false;
  }
  have_new_ = false;
  BoardInputs in;
  in.ad = last_.ad;
  in.encoder = last_.encoder;
  in.digital_in = last_.digital_in;
  last_inputs_ = in;
  if (!map_.decode_inputs(in, state)) {
    ++stats_.implausible_samples;
    return false;
  }
  state.time_s = static_cast<double>(last_.board_time_ns) * 1e-9;
  state.sequence = last_.sequence;
  for (int j = 0; j < map_.joint_count(); ++j) {  // the board core's joints are the map's, in its order
    const auto vented = static_cast<unsigned>(last_.limit_vented >> (2 * j)) & 3u;
    const auto motor_off = static_cast<unsigned>(last_.limit_motor_off >> j) & 1u;
    state.joints[static_cast<std::size_t>(j)].board_limits = static_cast<std::uint8_t>(vented | (motor_off ? io::kBoardMotorOff : 0u));
  }
  return true;
}

bool UdpBackend::write(const io::Command& command) noexcept {
  if (!send(command)) return false;
  await_reply(io::monotonic_ns() + static_cast<std::int64_t>(params_.receive_timeout_s * 1e9));
  return true;
}

void UdpBackend::await_reply(std::int64_t deadline_ns) noexcept {
  if (!last_was_reply_) drain(deadline_ns);
  if (!last_was_reply_) ++stats_.late_replies;
}

bool UdpBackend::send_and_wait(const io::Command& command) noexcept {
  if (!send(command)) return false;
  drain(io::monotonic_ns() + static_cast<std::int64_t>(params_.receive_timeout_s * 1e9));
  return true;
}

bool UdpBackend::send(const io::Command& command) noexcept {
  CommandPacket packet;
  packet.session_id = session_;
  packet.sequence = ++sequence_;
  packet.host_time_ns = static_cast<std::uint64_t>(io::monotonic_ns());
  if (board_nonce_ == 0) {  // a hello (all outputs zero): the board answers with its nonce
    packet.type = PacketType::kHello;
    return send_packet(packet);
  }
  BoardOutputs out;
  const int clamped = map_.encode_outputs(command, enable_, out);
  if (clamped > 0) stats_.clamped_outputs += static_cast<std::uint64_t>(clamped);
  packet.da = out.da;
  packet.digital_out = out.digital_out;
  // While the board reports a host loss, enabled commands carry the operator's arming: activate()
  // lets them through only after connect()'s latch was cleared by deactivate(), i.e. on the
  // supervisor's recover path, which only the operator starts.
  packet.flags = enable_ ? static_cast<std::uint8_t>(kCommandEnable | ((last_.status & kStatusHostLost) ? kCommandOperatorArm : 0)) : 0;
  packet.board_nonce = board_nonce_;
  if (!enable_) disable_sequence_ = packet.sequence;
  return send_packet(packet);
}

bool UdpBackend::send_packet(const CommandPacket& packet) noexcept {
  std::array<std::uint8_t, kMaxPacketSize> bytes;
  const std::size_t n = encode(packet, params_.key, bytes);
  ++stats_.commands_sent;
  if (n == 0 || !socket_.send_to(params_.board, std::span<const std::uint8_t>(bytes.data(), n))) {
    ++stats_.send_failures;
    return false;
  }
  // The board answers each command with its next sample: the caller waits for it (send_and_wait,
  // await_reply), so the round trip is measured when it happens and the next read() finds it ready.
  last_was_reply_ = false;
  return true;
}

}  // namespace peha::mfb
