#include "peha/mfb/shared_plant.hpp"

#include <fmt/format.h>

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

std::shared_ptr<SharedPlant> SharedPlant::create(std::function<std::unique_ptr<io::Backend>()> make_plant, int parts, double wait_s) {
  return std::shared_ptr<SharedPlant>(new SharedPlant(std::move(make_plant), parts, wait_s));
}

SharedPlant::SharedPlant(std::function<std::unique_ptr<io::Backend>()> make_plant, int parts, double wait_s)
    : make_plant_(std::move(make_plant)), all_(parts >= 32 ? ~0u : (1u << parts) - 1u), wait_s_(wait_s) {
  if (parts < 1 || parts > 31) throw std::invalid_argument(fmt::format("SharedPlant: 1 to 31 boards, found {}", parts));
  plant_ = make_plant_();
  plant_->activate();
  plant_->read(state_);
  command_.joint_count = state_.joint_count;
}

std::unique_ptr<io::Backend> SharedPlant::view(int part, const std::vector<int>& io_index) {
  std::lock_guard lock(mutex_);
  for (const int j : io_index) {
    if (j < 0 || j >= state_.joint_count) throw std::invalid_argument(fmt::format("SharedPlant: no io joint {}", j));
  }
  plant_ = make_plant_();  // a new session: the whole body back to its initial state
  plant_->activate();
  plant_->read(state_);
  command_ = io::Command{};
  command_.joint_count = state_.joint_count;
  written_ = 0;
  ++generation_;
  stepped_.notify_all();
  return std::make_unique<PlantView>(shared_from_this(), part, io_index, plant_->info());
}

void SharedPlant::step() noexcept {
  if (written_ != all_) ++partial_steps_;
  plant_->write(command_);
  plant_->read(state_);
  written_ = 0;
  ++generation_;
  ++steps_;
  stepped_.notify_all();
}

void SharedPlant::write(int part, const std::vector<int>& io_index, const io::Command& command) noexcept {
  std::unique_lock lock(mutex_);
  for (std::size_t k = 0; k < io_index.size() && static_cast<int>(k) < command.joint_count; ++k) {
    command_.joints[static_cast<std::size_t>(io_index[k])] = command.joints[k];
  }
  written_ |= 1u << part;
  if (written_ == all_) {
    step();
    return;
  }
  // Wait for the other boards' outputs of this period; a late board does not hold the body.
  const std::uint64_t generation = generation_;
  const bool others = stepped_.wait_for(lock, std::chrono::duration<double>(wait_s_), [&] { return generation_ != generation; });
  if (!others) step();
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
