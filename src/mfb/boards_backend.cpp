#include "peha/mfb/boards_backend.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <stdexcept>

namespace peha::mfb {

BoardsBackend::BoardsBackend(std::vector<BoardPart> boards, const std::vector<std::string>& joint_names, double period_s,
                             double receive_timeout_s)
    : boards_(std::move(boards)), receive_timeout_s_(receive_timeout_s) {
  if (boards_.empty()) throw std::invalid_argument("BoardsBackend: no board");
  std::vector<int> seen(joint_names.size(), 0);
  for (const BoardPart& b : boards_) {
    if (!b.backend || static_cast<int>(b.io_index.size()) != b.backend->channel_map().joint_count()) {
      throw std::invalid_argument(fmt::format("BoardsBackend: board '{}' has no backend or its joints do not match its channel map", b.name));
    }
    for (const int j : b.io_index) {
      if (j < 0 || j >= static_cast<int>(joint_names.size())) throw std::invalid_argument(fmt::format("BoardsBackend: io joint {} out of range", j));
      ++seen[static_cast<std::size_t>(j)];
    }
    labels_.push_back(b.name.empty() ? std::string("the board") : fmt::format("board '{}'", b.name));
  }
  for (std::size_t j = 0; j < seen.size(); ++j) {
    if (seen[j] != 1) throw std::invalid_argument(fmt::format("BoardsBackend: io joint '{}' is on {} boards", joint_names[j], seen[j]));
  }
  if (boards_.size() == 1) {
    info_.name = boards_[0].backend->info().name;
  } else {
    info_.name = "mfb:";
    for (std::size_t b = 0; b < boards_.size(); ++b) {
      info_.name += fmt::format("{}{}=udp://{}", b ? "," : "", boards_[b].name, boards_[b].backend->info().name.substr(10));
    }
  }
  info_.joint_names = joint_names;
  info_.period_s = period_s;
  samples_.resize(boards_.size());
  rtt_seen_.resize(boards_.size(), 0);
  commands_.resize(boards_.size());
  for (std::size_t b = 0; b < boards_.size(); ++b) commands_[b].joint_count = static_cast<int>(boards_[b].io_index.size());
}

void BoardsBackend::configure() {
  for (std::size_t b = 0; b < boards_.size(); ++b) {
    try {
      boards_[b].backend->configure();
    } catch (const std::exception& e) {
      if (boards_.size() == 1) throw;
      throw std::runtime_error(fmt::format("{}: {}", labels_[b], e.what()));
    }
  }
}

void BoardsBackend::activate() noexcept {
  for (BoardPart& b : boards_) b.backend->activate();
}

void BoardsBackend::deactivate() noexcept {
  for (BoardPart& b : boards_) b.backend->deactivate();
}

void BoardsBackend::estop() noexcept {
  for (BoardPart& b : boards_) b.backend->estop();
}

io::BackendStatus BoardsBackend::status() const noexcept {
  io::BackendStatus s = boards_[0].backend->status();
  if (boards_.size() > 1) s.part = labels_[0].c_str();
  bool faulted = s.estop || s.watchdog_tripped || s.rebooted;
  std::int64_t oldest = s.last_sample_ns;
  for (std::size_t b = 1; b < boards_.size(); ++b) {
    const io::BackendStatus o = boards_[b].backend->status();
    const bool fault = o.estop || o.watchdog_tripped || o.rebooted;
    if (fault && !faulted) s.part = labels_[b].c_str();
    faulted = faulted || fault;
    s.active = s.active && o.active;
    s.estop = s.estop || o.estop;
    s.watchdog_tripped = s.watchdog_tripped || o.watchdog_tripped;
    s.ready_to_arm = s.ready_to_arm && o.ready_to_arm;
    s.rebooted = s.rebooted || o.rebooted;
    if (o.last_sample_ns < oldest) {
      oldest = o.last_sample_ns;
      if (!faulted) s.part = labels_[b].c_str();  // a silent board: the host watchdog's fault is this one's
    }
    s.last_rtt_s = std::max(s.last_rtt_s, o.last_rtt_s);
    s.rtt_samples = std::min(s.rtt_samples, o.rtt_samples);  // a new figure once every board has a new one
  }
  s.last_sample_ns = oldest;
  return s;
}

void BoardsBackend::record_rtt() noexcept {
  for (std::size_t b = 0; b < boards_.size(); ++b) {
    const UdpBackend& board = *boards_[b].backend;
    if (board.stats().rtt_count == rtt_seen_[b]) continue;
    rtt_seen_[b] = board.stats().rtt_count;
    if (rtt_sink_) rtt_sink_->add(b, board.last_rtt_s());
  }
}

bool BoardsBackend::read(io::SensorState& state) noexcept {
  if (boards_.size() == 1) {
    const bool fresh = boards_[0].backend->read(state);
    record_rtt();
    return fresh;
  }
  bool all = true;
  for (std::size_t b = 0; b < boards_.size(); ++b) all = boards_[b].backend->read(samples_[b]) && all;  // each drains its socket
  record_rtt();
  if (!all) return false;
  state.time_s = samples_[0].time_s;
  state.sequence = samples_[0].sequence;
  state.joint_count = static_cast<int>(info_.joint_names.size());
  for (std::size_t b = 0; b < boards_.size(); ++b) {
    const std::vector<int>& index = boards_[b].io_index;
    for (std::size_t k = 0; k < index.size(); ++k) state.joints[static_cast<std::size_t>(index[k])] = samples_[b].joints[k];
  }
  return true;
}

bool BoardsBackend::write(const io::Command& command) noexcept {
  if (boards_.size() == 1) return boards_[0].backend->write(command);
  if (command.joint_count != static_cast<int>(info_.joint_names.size())) {
    // Each board's channel map refuses it the same way (safe outputs, enable inactive).
    for (std::size_t b = 0; b < boards_.size(); ++b) commands_[b].joint_count = 0;
  } else {
    for (std::size_t b = 0; b < boards_.size(); ++b) {
      const std::vector<int>& index = boards_[b].io_index;
      commands_[b].joint_count = static_cast<int>(index.size());
      for (std::size_t k = 0; k < index.size(); ++k) commands_[b].joints[k] = command.joints[static_cast<std::size_t>(index[k])];
    }
  }
  bool sent = true;
  const std::int64_t deadline = io::monotonic_ns() + static_cast<std::int64_t>(receive_timeout_s_ * 1e9);
  for (std::size_t b = 0; b < boards_.size(); ++b) sent = boards_[b].backend->send(commands_[b]) && sent;
  for (std::size_t b = 0; b < boards_.size(); ++b) boards_[b].backend->await_reply(deadline);
  return sent;
}

UdpLinkStats BoardsBackend::stats() const noexcept {
  UdpLinkStats sum = boards_[0].backend->stats();
  for (std::size_t b = 1; b < boards_.size(); ++b) {
    const UdpLinkStats& o = boards_[b].backend->stats();
    sum.received.accepted += o.received.accepted;
    sum.received.foreign_source += o.received.foreign_source;
    sum.received.foreign_session += o.received.foreign_session;
    sum.received.duplicate += o.received.duplicate;
    sum.received.stale += o.received.stale;
    sum.received.malformed += o.received.malformed;
    sum.received.unauthenticated += o.received.unauthenticated;
    sum.received.gaps += o.received.gaps;
    sum.received.reboots += o.received.reboots;
    sum.commands_sent += o.commands_sent;
    sum.send_failures += o.send_failures;
    sum.replies_missing += o.replies_missing;
    sum.late_replies += o.late_replies;
    sum.implausible_samples += o.implausible_samples;
    sum.clamped_outputs += o.clamped_outputs;
    sum.oversized += o.oversized;
    sum.rtt_count += o.rtt_count;
    sum.rtt_sum_s += o.rtt_sum_s;
    sum.rtt_max_s = std::max(sum.rtt_max_s, o.rtt_max_s);
  }
  return sum;
}

}  // namespace peha::mfb
