#include "peha/mfb/board_emulator.hpp"
#include "peha/mfb/link_config.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <sodium.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <time.h>

namespace peha::mfb {
namespace {

constexpr std::size_t kMaxPending = 4096;

/// The core's command as the host's type (the step hook's argument).
CommandPacket command_packet(const mfb_command& c) {
  CommandPacket p;
  p.type = static_cast<PacketType>(c.type);
  p.session_id = c.session_id;
  p.sequence = c.sequence;
  p.host_time_ns = c.host_time_ns;
  std::copy(c.da, c.da + kDaChannels, p.da.begin());
  p.digital_out = c.digital_out;
  p.flags = c.flags;
  p.board_nonce = c.board_nonce;
  return p;
}

}  // namespace

std::string EmulatorStats::table() const {
  return fmt::format(
      "commands: accepted {}, foreign source {}, foreign session {}, duplicate {}, stale {}, malformed {}, unauthenticated {}, gaps {}, "
      "oversized {}; hellos answered {}, unknown session (replays) {}\n"
      "simulation: {} periods on command, {} free-running; {} session(s), {} watchdog trip(s), {} e-stop cycles\n"
      "state packets: {} sent; injected loss {}, duplicate {}, reorder {}, corrupt {}, delay {}, burst {}\n"
      "board limits: {} muscle(s) vented at their force ceiling, {} joint(s) (about to be) out of range, {} over their speed ceiling, "
      "{} DA code(s) clamped, {} slewed\n"
      "range margin while armed (the led angle's least distance inside the board range, per joint): {:.1f} deg\n"
      "peak speed while armed (as the board's speed ceiling measures it, per joint): {:.0f} deg/s",
      received.accepted, received.foreign_source, received.foreign_session, received.duplicate, received.stale, received.malformed,
      received.unauthenticated, received.gaps, oversized, received.hellos, received.unknown_session,
      steps_on_command, steps_free_running, sessions, watchdog_trips, estop_cycles, states_sent, injected_loss, injected_duplicate,
      injected_reorder, injected_corrupt, injected_delay, injected_burst, force_trips, range_trips, speed_trips, clamped_codes,
      slewed_codes, fmt::join(closest_range_deg.begin(), closest_range_deg.begin() + joints, ", "),
      fmt::join(peak_speed_degps.begin(), peak_speed_degps.begin() + joints, ", "));
}

BoardEmulator::BoardEmulator(const EmulatorParams& params, ChannelMap map, std::function<std::unique_ptr<io::Backend>()> make_plant)
    : params_(params), map_(std::move(map)), make_plant_(std::move(make_plant)), socket_(params.bind), rng_state_(params.faults.seed * 0x9E3779B97F4A7C15ull + 1) {
  if (!(params.period_s > 0) || !(params.watchdog_s > params.period_s) || !(params.vent_s >= 0)) {
    throw std::invalid_argument(fmt::format("mfb-emulator: need period > 0, watchdog > period, vent >= 0 (got {}, {}, {} s)",
                                            params.period_s, params.watchdog_s, params.vent_s));
  }
  if (sodium_init() < 0) throw std::runtime_error("mfb-emulator: libsodium failed to initialise (no entropy source?)");
  require_private_key_off_loopback(params.key, params.bind.address, "emulator's bind");
  core_config_ = board_core_config(map_, params.key, params.watchdog_s, params.vent_s);
  stats_.joints = map_.joint_count();
  hal_ = mfb_hal{this, &BoardEmulator::hal_read_inputs, &BoardEmulator::hal_write_outputs, &BoardEmulator::hal_now_us,
                 &BoardEmulator::hal_mac, &BoardEmulator::hal_random};
  pending_.reserve(kMaxPending);
  truth_.reserve(params.truth_steps);
  truth_joints_.reserve(params.truth_steps * static_cast<std::size_t>(map_.joint_count()));
  plant_ = make_plant_();
  plant_->activate();  // the plant is the world behind the board's outputs: always driven
  plant_->read(state_);
  for (int j = 0; j < map_.joint_count(); ++j) {
    if (map_.joint(j).redundant_encoder.channel >= 0 && !std::isfinite(state_.joints[static_cast<std::size_t>(j)].redundant_angle_rad)) {
      throw std::invalid_argument(fmt::format("mfb-emulator: the channel map has a redundant encoder for joint '{}' (counter {}), but the "
                                              "scenario's plant measures none: set plant joint_encoder_counts_per_rev (docs/configuration.md)",
                                              map_.joint_names()[static_cast<std::size_t>(j)], map_.joint(j).redundant_encoder.channel));
    }
  }
  mfb_board_init(&core_, &core_config_, &hal_);  // power-on: a boot id, safe outputs, the first sample
}

void BoardEmulator::hal_read_inputs(void* ctx, mfb_inputs* out) {
  auto* self = static_cast<BoardEmulator*>(ctx);
  BoardInputs in;
  self->map_.encode_inputs(self->state_, self->estop_at(self->state_.time_s), in);
  if (self->input_hook_) self->input_hook_(self->state_.time_s, in);
  std::copy(in.ad.begin(), in.ad.end(), out->ad);
  std::copy(in.encoder.begin(), in.encoder.end(), out->encoder);
  out->digital_in = in.digital_in;
  out->time_ns = static_cast<std::uint64_t>(std::llround(self->state_.time_s * 1e9));
}

void BoardEmulator::hal_write_outputs(void* ctx, const std::uint16_t da[MFB_DA_CHANNELS], std::uint8_t digital_out) {
  auto* self = static_cast<BoardEmulator*>(ctx);
  std::copy(da, da + MFB_DA_CHANNELS, self->applied_.da.begin());
  self->applied_.digital_out = digital_out;
}

std::uint64_t BoardEmulator::hal_now_us(void*) { return static_cast<std::uint64_t>(io::monotonic_ns() / 1000); }

void BoardEmulator::hal_mac(void*, const std::uint8_t key[MFB_KEY_SIZE], const std::uint8_t* data, std::size_t size,
                            std::uint8_t out[MFB_MAC_SIZE]) {
  crypto_generichash(out, MFB_MAC_SIZE, data, size, key, MFB_KEY_SIZE);  // libsodium: the same MAC as the host's packet_mac
}

std::uint32_t BoardEmulator::hal_random(void*) { return randombytes_random(); }

void BoardEmulator::note_core_counters() noexcept {
  const mfb_counters& c = *mfb_board_counters(&core_);
  stats_.received.accepted = c.accepted;
  stats_.received.foreign_source = c.foreign_source;
  stats_.received.foreign_session = c.foreign_session;
  stats_.received.duplicate = c.duplicate;
  stats_.received.stale = c.stale;
  stats_.received.malformed = c.malformed;
  stats_.received.unauthenticated = c.unauthenticated;
  stats_.received.unknown_session = c.unknown_session;
  stats_.received.hellos = c.hellos;
  stats_.received.gaps = c.gaps;
  stats_.force_trips = c.force_trips;
  stats_.range_trips = c.range_trips;
  stats_.speed_trips = c.speed_trips;
  stats_.clamped_codes = c.clamped;
  stats_.slewed_codes = c.slewed;
}

double BoardEmulator::uniform() noexcept {
  // xorshift64*: the same faults for the same seed, independent of the standard library.
  rng_state_ ^= rng_state_ >> 12;
  rng_state_ ^= rng_state_ << 25;
  rng_state_ ^= rng_state_ >> 27;
  return static_cast<double>((rng_state_ * 0x2545F4914F6CDD1Dull) >> 11) * (1.0 / 9007199254740992.0);
}

void BoardEmulator::apply_and_step(bool by_command) noexcept {
  // The core drives the outputs from its newest sample (the plant as it is now): the command within
  // the board's limits while armed, otherwise the safe outputs along the vent ramp.
  mfb_board_drive(&core_);
  if (mfb_board_estop(&core_)) ++stats_.estop_cycles;
  const bool live = mfb_board_outputs_live(&core_);
  if (live && !reported_armed_) {  // for a process that supervises this one (peha faults --link): the run is live
    reported_armed_ = true;
    std::printf("peha mfb-emulator: outputs armed at t=%.4f s\n", state_.time_s);
    std::fflush(stdout);
  }
  io::Command command;
  map_.decode_outputs(applied_, command);
  if (step_hook_) step_hook_(by_command ? &last_command_ : nullptr);
  plant_->write(command);
  plant_->read(state_);
  mfb_board_sample(&core_);  // the inputs after the step: the limits judge them, the state packet carries them
  note_core_counters();
  if (mfb_board_outputs_live(&core_)) {
    for (int j = 0; j < map_.joint_count(); ++j) {
      const double deg_per_count = std::abs(map_.joint(j).encoder.rad_per_count) * (180.0 / std::numbers::pi);
      double& fastest = stats_.peak_speed_degps[static_cast<std::size_t>(j)];
      fastest = std::max(fastest, std::abs(static_cast<double>(mfb_board_speed(&core_, j))) * deg_per_count);
      const std::int32_t margin = mfb_board_range_margin(&core_, j);
      if (margin == INT32_MAX) continue;
      double& closest = stats_.closest_range_deg[static_cast<std::size_t>(j)];
      closest = std::min(closest, margin * deg_per_count);
    }
  }
  ++(by_command ? stats_.steps_on_command : stats_.steps_free_running);
  if (truth_.size() < truth_.capacity()) {
    const BoardOutputs safe = map_.safe_outputs();
    bool motor_off = applied_.digital_out == safe.digital_out;
    for (int j = 0; j < map_.joint_count(); ++j) {
      const AnalogChannel& m = map_.joint(j).motor;
      if (m.mapped()) motor_off = motor_off && applied_.da[static_cast<std::size_t>(m.channel)] == safe.da[static_cast<std::size_t>(m.channel)];
    }
    truth_.push_back({state_.time_s, io::monotonic_ns(), live, motor_off});
    for (int j = 0; j < map_.joint_count(); ++j) {
      const io::JointSensors& s = state_.joints[static_cast<std::size_t>(j)];
      truth_joints_.push_back({s.angle_rad, s.agonist_loadcell_N, s.antagonist_loadcell_N});
    }
  }
}

void BoardEmulator::transmit(const std::uint8_t* bytes, std::size_t n, std::int64_t at_ns) noexcept {
  if (at_ns <= io::monotonic_ns()) {
    socket_.send_to(host_, std::span<const std::uint8_t>(bytes, n));
    ++stats_.states_sent;
    return;
  }
  if (pending_.size() >= kMaxPending) return;  // a full delay line drops (counted as sent: it was injected)
  Pending p{at_ns, n, {}};
  std::copy(bytes, bytes + n, p.bytes.begin());
  pending_.push_back(p);
}

void BoardEmulator::flush_delayed(std::int64_t now) noexcept {
  std::size_t keep = 0;
  for (std::size_t i = 0; i < pending_.size(); ++i) {
    if (pending_[i].at_ns <= now) {
      socket_.send_to(host_, std::span<const std::uint8_t>(pending_[i].bytes.data(), pending_[i].size));
      ++stats_.states_sent;
    } else {
      pending_[keep++] = pending_[i];
    }
  }
  pending_.resize(keep);
}

void BoardEmulator::send_state(std::int64_t now) noexcept {
  if (!have_host_) return;
  std::array<std::uint8_t, kMaxPacketSize> bytes;
  const std::size_t n = mfb_board_state_packet(&core_, bytes.data(), bytes.size());
  if (n == 0) return;
  const FaultInjection& f = params_.faults;
  const std::int64_t at = now + static_cast<std::int64_t>(f.delay_s * 1e9);
  if (f.delay_s > 0) ++stats_.injected_delay;
  if (f.burst_from_s >= 0 && !burst_started_ && state_.time_s >= f.burst_from_s) {
    burst_started_ = true;
    burst_left_ = f.burst_packets == 0 ? std::numeric_limits<std::uint64_t>::max() : f.burst_packets;
    stats_.burst_ns = now;
    std::printf("peha mfb-emulator: loss burst from t=%.4f s (monotonic %lld ns)\n", state_.time_s, static_cast<long long>(now));
    std::fflush(stdout);
  }
  if (burst_left_ > 0) {
    --burst_left_;
    ++stats_.injected_burst;
    return;
  }
  if (f.loss > 0 && uniform() < f.loss) {
    ++stats_.injected_loss;
    return;
  }
  if (f.corrupt > 0 && uniform() < f.corrupt) {
    ++stats_.injected_corrupt;
    const auto bit = static_cast<std::size_t>(uniform() * static_cast<double>(n * 8));
    bytes[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
  }
  if (f.reorder > 0 && !have_held_ && uniform() < f.reorder) {
    ++stats_.injected_reorder;
    held_ = Pending{at, n, bytes};
    have_held_ = true;
    return;
  }
  transmit(bytes.data(), n, at);
  if (f.duplicate > 0 && uniform() < f.duplicate) {
    ++stats_.injected_duplicate;
    transmit(bytes.data(), n, at);
  }
  if (have_held_) {  // the held packet leaves after this newer one: the host sees it out of order
    transmit(held_.bytes.data(), held_.size, std::max(at, held_.at_ns));
    have_held_ = false;
  }
}

void BoardEmulator::run(const std::atomic<bool>& stop) {
  const std::int64_t period = static_cast<std::int64_t>(params_.period_s * 1e9);
  const std::int64_t start = io::monotonic_ns();
  std::int64_t next_free = start + 2 * period;
  std::array<std::uint8_t, 512> buffer;
  int sessions_ended = 0;
  while (!stop.load(std::memory_order_relaxed)) {
    std::int64_t now = io::monotonic_ns();
    if (params_.max_runtime_s > 0 && now - start > static_cast<std::int64_t>(params_.max_runtime_s * 1e9)) break;
    if (params_.sessions > 0 && sessions_ended >= params_.sessions) break;
    std::int64_t wake = next_free;
    for (const Pending& p : pending_) wake = std::min(wake, p.at_ns);
    if (wake > now) socket_.wait_readable(std::min<std::int64_t>(wake - now, 100'000'000));
    now = io::monotonic_ns();
    for (;;) {
      io::UdpEndpoint from;
      const long n = socket_.receive(buffer, from);
      if (n < 0) break;
      if (static_cast<std::size_t>(n) > buffer.size()) {
        ++stats_.oversized;
        continue;
      }
      mfb_verdict verdict;
      const mfb_event event = mfb_board_receive(&core_, buffer.data(), static_cast<std::size_t>(n), mfb_endpoint{from.address, from.port}, &verdict);
      note_core_counters();
      if (event == MFB_EVENT_DROPPED) continue;
      if (event == MFB_EVENT_ANSWER) {  // a hello, or a session this boot never opened: answered, nothing driven
        std::array<std::uint8_t, kMaxPacketSize> answer;
        mfb_endpoint to;
        const std::size_t size = mfb_board_answer_packet(&core_, answer.data(), answer.size(), &to);
        if (size > 0) socket_.send_to(io::UdpEndpoint{to.address, to.port}, std::span<const std::uint8_t>(answer.data(), size));
        continue;
      }
      host_ = from;
      have_host_ = true;
      last_command_ = command_packet(core_.command);
      if (event == MFB_EVENT_NEW_SESSION) {
        // A new session: the exoskeleton back to its initial state, answered without a step.
        plant_ = make_plant_();
        plant_->activate();  // the plant is the world behind the board's outputs: always driven
        plant_->read(state_);
        mfb_board_sample(&core_);
        ++stats_.sessions;
      } else {
        apply_and_step(true);
      }
      send_state(io::monotonic_ns());
      next_free = io::monotonic_ns() + 2 * period;
    }
    now = io::monotonic_ns();
    if (const mfb_watchdog w = mfb_board_poll(&core_); w != MFB_WATCHDOG_QUIET) {
      if (w == MFB_WATCHDOG_HOST_LOST && stats_.host_loss_ns == 0) {  // its host fell silent while driving the outputs
        stats_.host_loss_ns = now;
        stats_.host_loss_t_s = state_.time_s;
      }
      ++stats_.watchdog_trips;
      ++sessions_ended;
    }
    if (now >= next_free) {  // no command: the plant runs on with what the DA holds
      apply_and_step(false);
      send_state(now);
      next_free += period;
      if (next_free < now) next_free = now + period;  // stalled (e.g. suspended): no burst
    }
    flush_delayed(io::monotonic_ns());
  }
}

}  // namespace peha::mfb
