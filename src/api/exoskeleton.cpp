#include "peha/api/exoskeleton.hpp"

#include "peha/control/arm_controller.hpp"
#include "peha/experiments/common/board_run.hpp"
#include "peha/experiments/e3_postures/postures.hpp"
#include "peha/hardware/door.hpp"
#include "peha/runtime/csv_log.hpp"
#include "peha/safety/limited_backend.hpp"

#include <fmt/format.h>

#include <array>
#include <chrono>
#include <optional>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <unistd.h>

namespace peha::api {
namespace {

/// One run of the user's controller on `backend`: the arm controller in commanded-torque mode on
/// every torque-controlled joint, the callback's torques into it, the limits stage around it.
struct UserLoop {
  UserLoop(const experiments::ArmScenario& s, const TorqueController& u) : scenario(s), user(u) {}
  const experiments::ArmScenario& scenario;
  const TorqueController& user;
  control::ArmController controller{scenario.controller};
  safety::JointModels joints = experiments::arm_joint_models(controller.model());
  safety::Envelope envelope;
  ArmState view;
  JointTorques torques;
  std::vector<double> row;
  bool finished = false;

  std::size_t run(io::Backend& backend, double duration_s, runtime::RowSink* log, runtime::CycleHooks hooks, ControlResult& result) {
    const std::size_t n = scenario.controller.joints.size();
    for (std::size_t j = 0; j < n; ++j) {
      if (scenario.controller.joints[j].mode != control::ArmJointMode::kHoldPressure) controller.set_mode(static_cast<int>(j), control::ArmJointMode::kCommanded);
    }
    safety::LimitedBackend limited(backend, scenario.limits, joints);
    row.assign(log ? user_log_columns(scenario).size() : 0, 0.0);
    view.joint_count = static_cast<int>(n);
    io::SensorState state;
    io::Command command;
    const double period_s = scenario.period_s;
    auto step = [&](std::size_t) {
      const std::vector<control::ArmJointDiagnostics>& diag = controller.diagnostics();
      view.time_s = state.time_s;
      view.starting = controller.wires_slack_on_purpose(state.time_s);
      for (std::size_t j = 0; j < n; ++j) {
        const io::JointSensors& s = state.joints[j];
        view.joints[j] = {s.angle_rad,
                          diag[j].velocity_radps,
                          diag[j].torque_gravity_Nm,
                          s.agonist_loadcell_N - controller.loadcell_offset_N(j, 0),
                          s.antagonist_loadcell_N - controller.loadcell_offset_N(j, 1),
                          s.agonist_pressure_Pa,
                          s.antagonist_pressure_Pa};
      }
      torques = user(view, period_s);
      finished = finished || torques.finished;
      for (std::size_t j = 0; j < n; ++j) controller.set_desired_torque(static_cast<int>(j), torques.tau_Nm[j]);
      controller.update(state, command);
    };
    auto hold = [](std::size_t) {};
    auto observe = [&](std::size_t, const io::Command& sent, std::uint32_t limit_flags) {
      for (std::size_t a = 0; a < n; ++a) {
        safety::JointSample j = experiments::arm_joint_sample(state, sent, nullptr, a);
        if (controller.wires_slack_on_purpose(state.time_s)) j.min_tension_N = std::numeric_limits<double>::infinity();
        envelope.observe(a, j);
      }
      if (!log) return;
      std::size_t c = 0;
      row[c++] = state.time_s;
      for (std::size_t a = 0; a < n; ++a) {
        const io::JointSensors& s = state.joints[a];
        for (const double v : {s.angle_rad, controller.diagnostics()[a].velocity_radps, s.agonist_loadcell_N, s.antagonist_loadcell_N,
                               s.agonist_pressure_Pa * 1e-6, s.antagonist_pressure_Pa * 1e-6, torques.tau_Nm[a],
                               controller.diagnostics()[a].torque_gravity_Nm, sent.joints[a].agonist_pressure_Pa * 1e-6,
                               sent.joints[a].antagonist_pressure_Pa * 1e-6, sent.joints[a].motor_torque_Nm}) {
          row[c++] = v;
        }
        const std::array<double, hardware::kSensorColumns.size()> sensors = hardware::sensor_columns(s);
        for (std::size_t i = hardware::kRequiredSensorColumns; i < sensors.size(); ++i) row[c++] = sensors[i];
      }
      row[c++] = static_cast<double>(limit_flags);
      row[c] = static_cast<double>(limited.monitor().flags());
      log->push_row(row);
    };
    hooks.after = [then = hooks.after, this](const io::SensorState& s, const io::Command& sent) {
      const bool go = then ? then(s, sent) : true;
      return go && !finished;
    };
    const auto steps = static_cast<std::size_t>(std::llround(duration_s / period_s));
    const std::size_t done = runtime::run_cycles(limited, runtime::resuming(runtime::with_lifecycle(hooks, scenario.lifecycle), [this] { controller.resume(); }),
                                                 steps, state, command, step, hold, observe);
    experiments::add_arm_envelope_checks(scenario, joints, envelope, result.verdict);
    safety::add_supervisor_check(limited.monitor(), result.verdict);
    result.cycles = done + 1;
    result.faults = limited.monitor().count();
    result.fault_reason = limited.monitor().run_reason();
    return done;
  }
};

}  // namespace

std::vector<std::string> user_log_columns(const experiments::ArmScenario& scenario) {
  std::vector<std::string> c = {"t_s"};
  for (std::size_t j = 0; j < scenario.controller.joints.size(); ++j) {
    for (const char* f : {"angle_rad", "velocity_radps", "agonist_loadcell_N", "antagonist_loadcell_N", "agonist_pressure_MPa",
                          "antagonist_pressure_MPa", "tau_user_Nm", "tau_gravity_Nm", "agonist_pressure_cmd_MPa", "antagonist_pressure_cmd_MPa",
                          "tau_motor_cmd_Nm"}) {
      c.push_back(fmt::format("{}_{}", experiments::arm_log_prefix(scenario, j), f));
    }
    // The sensors a rig may lack (supply, redundant encoder, motor monitor) close the block.
    for (std::size_t i = hardware::kRequiredSensorColumns; i < hardware::kSensorColumns.size(); ++i) {
      c.push_back(fmt::format("{}_{}", experiments::arm_log_prefix(scenario, j), hardware::kSensorColumns[i]));
    }
  }
  c.push_back("limit_flags");
  c.push_back("fault_flags");
  return c;
}

Exoskeleton::Exoskeleton(const std::filesystem::path& scenario, const std::string& backend)
    : scenario_(experiments::read_arm_scenario(config::Document::load_file(scenario))), backend_(backend) {
  const hardware::BackendUri uri = hardware::BackendUri::parse(backend);  // throws on a malformed one
  if (uri.kind == hardware::BackendKind::kReplay) {
    throw std::invalid_argument("peha::api::Exoskeleton: a replay has no arm to move: give sim: or udp://...");
  }
  if (uri.kind == hardware::BackendKind::kBoards && !scenario_.link) {
    throw std::invalid_argument(fmt::format("{}: --backend {} needs the scenario's mfb: section", scenario.string(), backend));
  }
  if (!scenario_.faults.empty()) throw std::invalid_argument(fmt::format("{}: its faults: list is E3's; remove it to run your controller", scenario.string()));
  joint_names_ = experiments::arm_joint_names(scenario_);
}

bool Exoskeleton::torque_controlled(std::size_t joint) const {
  return scenario_.controller.joints.at(joint).mode != control::ArmJointMode::kHoldPressure;
}

void Exoskeleton::set_realtime(int fifo_priority, int cpu, bool lock_memory) {
  fifo_priority_ = fifo_priority;
  cpu_ = cpu;
  lock_memory_ = lock_memory;
}

ControlResult Exoskeleton::control(const TorqueController& controller, double duration_s, const std::filesystem::path& log) {
  if (!controller) throw std::invalid_argument("peha::api::Exoskeleton::control: no controller given");
  if (!(duration_s > 0)) throw std::invalid_argument(fmt::format("peha::api::Exoskeleton::control: duration {} s is not > 0", duration_s));
  const hardware::BackendUri uri = hardware::BackendUri::parse(backend_);
  const hardware::HardwareRequest request = experiments::arm_hardware(scenario_, scenario_.plant);
  ControlResult result;
  result.log = log;
  UserLoop loop{scenario_, controller};
  if (uri.kind == hardware::BackendKind::kBoards) {
    experiments::HardwareRunOptions o;
    o.backend = uri;
    o.realtime.fifo_priority = fifo_priority_;
    o.realtime.cpu = cpu_;
    o.realtime.lock_memory = lock_memory_;
    o.quiet = true;
    o.dir = log.empty() ? std::filesystem::temp_directory_path() : (log.parent_path().empty() ? std::filesystem::path(".") : log.parent_path());
    const std::filesystem::path file = log.empty() ? o.dir / fmt::format("peha_user_control_{}.csv", ::getpid()) : log;
    const experiments::BoardRunResult run = experiments::run_on_hardware(
        request, scenario_.lifecycle, o, {"control", duration_s, file, user_log_columns(scenario_), {"peha::api::Exoskeleton::control"}},
        [&](hardware::Hardware& hw, runtime::RowSink& sink, runtime::CycleHooks hooks) -> safety::Verdict& {
          loop.run(*hw.backend, duration_s, &sink, hooks, result);
          return result.verdict;
        });
    if (log.empty()) std::filesystem::remove(file);
    result.faults += run.faults;
    if (result.fault_reason.empty() && run.faults) result.fault_reason = experiments::first_lifecycle_fault(run.lifecycle).second;
    result.realtime_factor = 1.0;
  } else {
    const hardware::Hardware arm = hardware::open_backend(uri, request);
    std::optional<runtime::CsvLog> csv;
    if (!log.empty()) csv.emplace(user_log_columns(scenario_), static_cast<std::size_t>(std::llround(duration_s / scenario_.period_s)) + 2);
    const auto wall_start = std::chrono::steady_clock::now();
    loop.run(*arm.backend, duration_s, csv ? &*csv : nullptr, {}, result);
    const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    result.realtime_factor = static_cast<double>(result.cycles) * scenario_.period_s / std::max(wall_s, 1e-9);
    if (csv) {
      if (log.has_parent_path()) std::filesystem::create_directories(log.parent_path());
      csv->write(log, {"peha::api::Exoskeleton::control on " + arm.where(), "pressures gauge; tau_user_Nm: the callback's torque"});
    }
  }
  result.passed = result.verdict.passed();
  return result;
}

}  // namespace peha::api
