#include "peha/mfb/shared_plant.hpp"

#include "peha/io/udp_socket.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <string>

namespace peha::mfb {
namespace {

/// Board `part`'s view of the body: its joints' commands in, its joints' sensors out.
class PlantView final : public io::Backend {
 public:
  PlantView(std::shared_ptr<SharedPlant> body, int part, std::vector<int> io_index, const io::BackendInfo& whole)
      : body_(std::move(body)), part_(part), io_index_(std::move(io_index)) {
    info_.name = fmt::format("{} (board {})", whole.name, part);
    for (const int j : io_index_) info_.joint_names.push_back(whole.joint_names[static_cast<std::size_t>(j)]);
    info_.period_s = whole.period_s;
  }
  const io::BackendInfo& info() const override { return info_; }
  void activate() noexcept override {}  // the body is always driven (it is the world behind the outputs)
  void deactivate() noexcept override {}
  void estop() noexcept override {}
  io::BackendStatus status() const noexcept override {
    io::BackendStatus s;
    s.active = true;
    return s;
  }
  bool read(io::SensorState& state) noexcept override {
    body_->read(io_index_, state);
    return true;
  }
  bool write(const io::Command& command) noexcept override {
    body_->write(part_, io_index_, command);
    return true;
  }

 private:
  std::shared_ptr<SharedPlant> body_;
  int part_;
  std::vector<int> io_index_;
  io::BackendInfo info_;
};

}  // namespace

std::shared_ptr<SharedPlant> SharedPlant::create(std::function<std::unique_ptr<io::Backend>()> make_plant, int parts, double period_s,
                                                 double wait_s) {
  return std::shared_ptr<SharedPlant>(new SharedPlant(std::move(make_plant), parts, period_s, wait_s));
}

SharedPlant::SharedPlant(std::function<std::unique_ptr<io::Backend>()> make_plant, int parts, double period_s, double wait_s)
    : make_plant_(std::move(make_plant)),
      parts_(parts),
      half_period_ns_(static_cast<std::int64_t>(period_s * 0.5e9)),
      wait_ns_(static_cast<std::int64_t>(wait_s * 1e9)),
      next_host_ns_(static_cast<std::size_t>(std::max(parts, 0)), 0),
      live_ns_(static_cast<std::size_t>(std::max(parts, 0)), 0) {
  if (parts < 1 || parts > 31) throw std::invalid_argument(fmt::format("SharedPlant: 1 to 31 boards, found {}", parts));
  if (!(period_s > 0) || !(wait_s > 0)) throw std::invalid_argument("SharedPlant: period and wait must be > 0");
  plant_ = make_plant_();
  plant_->activate();
  plant_->read(state_);
  command_.joint_count = state_.joint_count;
}

std::unique_ptr<io::Backend> SharedPlant::view(int part, const std::vector<int>& io_index) {
  std::lock_guard lock(mutex_);
  if (part < 0 || part >= parts_) throw std::invalid_argument(fmt::format("SharedPlant: no board {}", part));
  for (const int j : io_index) {
    if (j < 0 || j >= state_.joint_count) throw std::invalid_argument(fmt::format("SharedPlant: no io joint {}", j));
  }
  plant_ = make_plant_();  // a new session: the whole body back to its initial state
  plant_->activate();
  plant_->read(state_);
  command_ = io::Command{};
  command_.joint_count = state_.joint_count;
  written_ = 0;
  cycle_open_ = false;
  stepped_host_ns_ = 0;
  ++generation_;
  stepped_.notify_all();
  return std::make_unique<PlantView>(shared_from_this(), part, io_index, plant_->info());
}

void SharedPlant::note_command(int part, const CommandPacket* command) noexcept {
  std::lock_guard lock(mutex_);
  next_host_ns_[static_cast<std::size_t>(part)] = command ? std::max<std::uint64_t>(command->host_time_ns, 1) : 0;
}

void SharedPlant::step() noexcept {
  if (cycle_open_) stepped_host_ns_ = cycle_host_ns_;
  plant_->write(command_);
  plant_->read(state_);
  written_ = 0;
  cycle_open_ = false;
  ++generation_;
  ++steps_;
  stepped_.notify_all();
}

void SharedPlant::write(int part, const std::vector<int>& io_index, const io::Command& command) noexcept {
  std::unique_lock lock(mutex_);
  const auto p = static_cast<std::size_t>(part);
  const std::uint64_t host_ns = next_host_ns_[p];
  next_host_ns_[p] = 0;
  const std::int64_t now = io::monotonic_ns();
  auto apply = [&] {
    for (std::size_t k = 0; k < io_index.size() && static_cast<int>(k) < command.joint_count; ++k) {
      command_.joints[static_cast<std::size_t>(io_index[k])] = command.joints[k];
    }
  };
  std::uint32_t live = 0;
  for (int b = 0; b < parts_; ++b) {
    // Live: commanded within 4 waits, so one lost command (a wait) does not drop a board from the next cycle.
    if (live_ns_[static_cast<std::size_t>(b)] != 0 && now - live_ns_[static_cast<std::size_t>(b)] <= 4 * wait_ns_) live |= 1u << b;
  }
  if (host_ns == 0) {  // free-running: the body runs on by itself only while no host drives any board
    apply();
    if (live == 0 && part == 0) step();
    return;
  }
  live_ns_[p] = now;
  live |= 1u << part;
  const auto h = static_cast<std::int64_t>(host_ns);
  const auto c = static_cast<std::int64_t>(cycle_host_ns_);
  if (cycle_open_ && h + half_period_ns_ < c) return;  // a command of a cycle already stepped (delayed): too late
  if (!cycle_open_ && stepped_host_ns_ != 0 && h <= static_cast<std::int64_t>(stepped_host_ns_) + half_period_ns_) {
    apply();  // of the cycle just stepped without it (it came after the wait): its outputs hold from now
    return;
  }
  if (cycle_open_ && h > c + half_period_ns_) {        // the next cycle began: the open one missed a board
    ++partial_steps_;
    step();
  }
  apply();
  if (!cycle_open_) {
    cycle_open_ = true;
    cycle_host_ns_ = host_ns;
  }
  written_ |= 1u << part;
  if ((written_ & live) == live) {
    step();
    return;
  }
  // Wait for the other live boards' commands of this cycle; a missing one does not hold the body.
  const std::uint64_t generation = generation_;
  if (!stepped_.wait_for(lock, std::chrono::nanoseconds(wait_ns_), [&] { return generation_ != generation; })) {
    ++partial_steps_;
    step();
  }
}

void SharedPlant::read(const std::vector<int>& io_index, io::SensorState& state) noexcept {
  std::lock_guard lock(mutex_);
  state.time_s = state_.time_s;
  state.sequence = state_.sequence;
  state.joint_count = static_cast<int>(io_index.size());
  for (std::size_t k = 0; k < io_index.size(); ++k) state.joints[k] = state_.joints[static_cast<std::size_t>(io_index[k])];
}

std::uint64_t SharedPlant::steps() const {
  std::lock_guard lock(mutex_);
  return steps_;
}

std::uint64_t SharedPlant::partial_steps() const {
  std::lock_guard lock(mutex_);
  return partial_steps_;
}

}  // namespace peha::mfb
