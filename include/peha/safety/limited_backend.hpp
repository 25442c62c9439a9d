#pragma once
/// \file
/// The limits stage at the backend boundary: an io::Backend that wraps another and limits every
/// command in write() (safety::apply_limits against the newest sample read through it) before it
/// passes it on. Experiments hold only this wrapper (runtime::run_cycles takes nothing else), so no
/// command reaches the outputs around the limits; what was sent is `sent()`, with its `flags()`.
/// Lifecycle calls pass straight through. noexcept and allocation-free in the loop.

#include "peha/io/backend.hpp"
#include "peha/safety/limits.hpp"

namespace peha::safety {

class LimitedBackend final : public io::Backend {
 public:
  /// `limits` and `joints` (the joint set-ups the controller runs with) must outlive this.
  LimitedBackend(io::Backend& inner, const LimitsModel& limits, const JointModels& joints) noexcept
      : inner_(inner), limits_(limits), joints_(joints) {}

  const io::BackendInfo& info() const override { return inner_.info(); }
  void configure() override { inner_.configure(); }
  void activate() noexcept override { inner_.activate(); }
  void deactivate() noexcept override { inner_.deactivate(); }
  void estop() noexcept override { inner_.estop(); }
  io::BackendStatus status() const noexcept override { return inner_.status(); }
  bool read(io::SensorState& state) noexcept override {
    const bool fresh = inner_.read(state);
    if (fresh) last_state_ = state;
    return fresh;
  }
  /// Limits a copy of `command` against the newest sample, then writes it.
  bool write(const io::Command& command) noexcept override {
    sent_ = command;
    flags_ = apply_limits(limits_, joints_, data_, last_state_, sent_);
    return inner_.write(sent_);
  }

  const io::Command& sent() const noexcept { return sent_; }  ///< the last command as limited and written
  std::uint32_t flags() const noexcept { return flags_; }     ///< its LimitFlag bits
  const LimitsData& data() const noexcept { return data_; }   ///< counts per flag, previous command

 private:
  io::Backend& inner_;
  const LimitsModel& limits_;
  JointModels joints_;
  LimitsData data_;
  io::SensorState last_state_{};
  io::Command sent_{};
  std::uint32_t flags_ = 0;
};

}  // namespace peha::safety
