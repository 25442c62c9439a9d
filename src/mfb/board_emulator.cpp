#include "peha/mfb/board_emulator.hpp"

#include <fmt/format.h>
#include <sodium.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <time.h>

namespace peha::mfb {
namespace {

constexpr std::size_t kMaxPending = 4096;

}  // namespace

std::string EmulatorStats::table() const {
  return fmt::format(
      "commands: accepted {}, foreign source {}, foreign session {}, duplicate {}, stale {}, malformed {}, unauthenticated {}, gaps {}, "
      "oversized {}\n"
      "simulation: {} periods on command, {} free-running; {} session(s), {} watchdog trip(s), {} e-stop cycles\n"
      "state packets: {} sent; injected loss {}, duplicate {}, reorder {}, corrupt {}, delay {}, burst {}",
      received.accepted, received.foreign_source, received.foreign_session, received.duplicate, received.stale, received.malformed,
      received.unauthenticated, received.gaps, oversized,
      steps_on_command, steps_free_running, sessions, watchdog_trips, estop_cycles, states_sent, injected_loss, injected_duplicate,
      injected_reorder, injected_corrupt, injected_delay, injected_burst);
}

BoardEmulator::BoardEmulator(const EmulatorParams& params, ChannelMap map, std::function<std::unique_ptr<io::Backend>()> make_plant)
    : params_(params), map_(std::move(map)), make_plant_(std::move(make_plant)), socket_(params.bind), filter_(params.key), rng_state_(params.faults.seed * 0x9E3779B97F4A7C15ull + 1) {
  if (!(params.period_s > 0) || !(params.watchdog_s > params.period_s) || !(params.vent_s >= 0)) {
    throw std::invalid_argument(fmt::format("mfb-emulator: need period > 0, watchdog > period, vent >= 0 (got {}, {}, {} s)",
                                            params.period_s, params.watchdog_s, params.vent_s));
  }
  if (sodium_init() < 0) throw std::runtime_error("mfb-emulator: libsodium failed to initialise (no entropy source?)");
  while (boot_id_ == 0) boot_id_ = randombytes_random();  // this power-on's id: a restart draws another
  pending_.reserve(kMaxPending);
  truth_.reserve(params.truth_steps);
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
  applied_ = map_.safe_outputs();
}

double BoardEmulator::uniform() noexcept {
  // xorshift64*: the same faults for the same seed, independent of the standard library.
  rng_state_ ^= rng_state_ >> 12;
  rng_state_ ^= rng_state_ << 25;
  rng_state_ ^= rng_state_ >> 27;
  return static_cast<double>((rng_state_ * 0x2545F4914F6CDD1Dull) >> 11) * (1.0 / 9007199254740992.0);
}

void BoardEmulator::apply_and_step(bool by_command) noexcept {
  // What the DA drives: the command while armed. Once disarmed (watchdog, e-stop, the host's
  // disable), the safe outputs - the motor cut at once, the valves vented along a ramp from where
  // they were, so the arm descends slowly instead of dropping.
  const bool estop = estop_at(state_.time_s);
  arming_.set_estop(estop);
  if (estop) ++stats_.estop_cycles;
  const std::int64_t now = io::monotonic_ns();
  if (arming_.outputs_enabled()) {
    applied_.da = last_command_.da;
    applied_.digital_out = last_command_.digital_out;
    armed_ = true;
    if (!reported_armed_) {  // for a process that supervises this one (peha faults --link): the run is live
      reported_armed_ = true;
      std::printf("peha mfb-emulator: outputs armed at t=%.4f s\n", state_.time_s);
      std::fflush(stdout);
    }
  } else {
    const BoardOutputs safe = map_.safe_outputs();
    if (armed_) {  // the moment of disarming: the vent ramp starts from what the DA held
      armed_ = false;
      trip_outputs_ = applied_;
      trip_ns_ = now;
      venting_ = params_.vent_s > 0;
    }
    if (venting_) {
      const double s = std::clamp(static_cast<double>(now - trip_ns_) * 1e-9 / params_.vent_s, 0.0, 1.0);
      for (std::size_t i = 0; i < static_cast<std::size_t>(kDaChannels); ++i) {
        applied_.da[i] = static_cast<std::uint16_t>(std::lround(trip_outputs_.da[i] + s * (safe.da[i] - trip_outputs_.da[i])));
      }
      for (int j = 0; j < map_.joint_count(); ++j) {  // every motor straight to its zero-torque code
        const AnalogChannel& m = map_.joint(j).motor;
        if (m.mapped()) applied_.da[static_cast<std::size_t>(m.channel)] = safe.da[static_cast<std::size_t>(m.channel)];
      }
      applied_.digital_out = safe.digital_out;
      if (s >= 1.0) venting_ = false;
    } else {
      applied_ = safe;
    }
  }
  io::Command command;
  map_.decode_outputs(applied_, command);
  if (step_hook_) step_hook_(by_command ? &last_command_ : nullptr);
  plant_->write(command);
  plant_->read(state_);
  ++(by_command ? stats_.steps_on_command : stats_.steps_free_running);
  if (truth_.size() < truth_.capacity()) {
    const BoardOutputs safe = map_.safe_outputs();
    bool motor_off = applied_.digital_out == safe.digital_out;
    for (int j = 0; j < map_.joint_count(); ++j) {
      const AnalogChannel& m = map_.joint(j).motor;
      if (m.mapped()) motor_off = motor_off && applied_.da[static_cast<std::size_t>(m.channel)] == safe.da[static_cast<std::size_t>(m.channel)];
    }
    truth_.push_back({state_.time_s, io::monotonic_ns(), state_.joints[0].angle_rad, state_.joints[0].agonist_loadcell_N,
                      state_.joints[0].antagonist_loadcell_N, armed_, motor_off});
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
  StatePacket s;
  s.session_id = filter_.session_id();
  s.sequence = ++state_sequence_;
  s.ack_sequence = last_command_.sequence;
  s.echo_host_time_ns = last_command_.host_time_ns;
  s.board_time_ns = static_cast<std::uint64_t>(std::llround(state_.time_s * 1e9));
  BoardInputs in;
  map_.encode_inputs(state_, estop_at(state_.time_s), in);
  if (input_hook_) input_hook_(state_.time_s, in);
  s.ad = in.ad;
  s.encoder = in.encoder;
  s.digital_in = in.digital_in;
  s.status = static_cast<std::uint8_t>(arming_.status() | (filter_.has_session() ? 0 : kStatusNoSession));
  s.arm_token = arming_.token();
  s.boot_id = boot_id_;
  std::array<std::uint8_t, kMaxPacketSize> bytes;
  const std::size_t n = encode(s, params_.key, bytes);
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
  const std::int64_t watchdog = static_cast<std::int64_t>(params_.watchdog_s * 1e9);
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
      CommandPacket c;
      const bool had_session = filter_.has_session();
      const std::uint32_t previous = filter_.session_id();
      const Verdict v =
          filter_.accept(std::span<const std::uint8_t>(buffer.data(), static_cast<std::size_t>(n)), Source{from.address, from.port}, c);
      stats_.received = filter_.counters();
      if (v != Verdict::kAccept) continue;
      if (!had_session) {  // adopted (or re-adopted): a fresh token, so no recorded edge can arm this session
        std::uint32_t token = 0;
        while (token == 0) token = randombytes_random();
        arming_.set_token(token);
      }
      host_ = from;
      have_host_ = true;
      last_command_ns_ = io::monotonic_ns();
      arming_.on_command(c);
      last_command_ = c;
      if (!had_session && (c.session_id != previous || !have_session_)) {
        // A new session: the exoskeleton back to its initial state, answered without a step.
        plant_ = make_plant_();
        plant_->activate();  // the plant is the world behind the board's outputs: always driven
        plant_->read(state_);
        armed_ = venting_ = false;
        applied_ = map_.safe_outputs();
        have_session_ = true;
        ++stats_.sessions;
      } else {
        apply_and_step(true);
      }
      send_state(io::monotonic_ns());
      next_free = io::monotonic_ns() + 2 * period;
    }
    now = io::monotonic_ns();
    if (filter_.has_session() && now - last_command_ns_ > watchdog) {
      if (arming_.outputs_enabled() && stats_.host_loss_ns == 0) {  // its host fell silent while driving the outputs
        stats_.host_loss_ns = now;
        stats_.host_loss_t_s = state_.time_s;
      }
      arming_.on_watchdog();
      filter_.release();
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
