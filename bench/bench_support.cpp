#include "bench_support.hpp"

#include "peha/config/reader.hpp"
#include "peha/control/one_dof_gravity.hpp"
#include "peha/safety/limits.hpp"
#include "peha/sim/one_dof_rig.hpp"

#include "peha/calibration/spgp.hpp"

#include <cmath>
#include <random>
#include <cstddef>
#include <stdexcept>

namespace peha::bench {

const experiments::E1Scenario& e1_scenario() {
  static const experiments::E1Scenario s =
      experiments::read_e1(config::Document::load_file(PEHA_SOURCE_DIR "/configs/e1_one_dof.yaml"));
  return s;
}

const experiments::E1Case& e1_heavy_case() {
  for (const experiments::E1Case& c : e1_scenario().cases) {
    if (std::abs(c.payload_kg - 5.0) < 1e-9) return c;
  }
  throw std::runtime_error("configs/e1_one_dof.yaml has no 5.0 kg case");
}

control::OneDofControllerModel heavy_controller_model() {
  control::OneDofControllerModel m = e1_scenario().controller;
  m.gravity.payload_mass_kg = e1_heavy_case().payload_kg;
  return m;
}

sim::OneDofRigParams heavy_plant_params() {
  sim::OneDofRigParams p = e1_scenario().plant;
  p.payload_kg = e1_heavy_case().payload_kg;
  return p;
}

namespace {

E1Recording record() {
  const experiments::E1Scenario& s = e1_scenario();
  control::OneDofGravityController controller(heavy_controller_model());
  sim::OneDofRigBackend plant(heavy_plant_params());
  plant.activate();
  safety::LimitsData limits_data;

  const auto steps = static_cast<std::size_t>(std::llround(s.duration_s / s.period_s));
  E1Recording r;
  r.states.reserve(steps + 1);
  r.commands.reserve(steps + 1);
  r.allocation.reserve(steps + 1);
  io::SensorState state;
  io::Command command;
  for (std::size_t k = 0; k <= steps; ++k) {
    plant.read(state);
    controller.update(state, command);
    safety::apply_limits(s.limits, {&s.controller.joint}, limits_data, state, command);
    r.states.push_back(state);
    r.commands.push_back(command);
    r.allocation.push_back(controller.diagnostics().allocation_input);
    if (k < steps) plant.write(command);
  }
  return r;
}

}  // namespace

const E1Recording& e1_recording() {
  static const E1Recording r = record();
  return r;
}

std::shared_ptr<const calibration::SpgpResidual> synthetic_spgp_residual() {
  static const std::shared_ptr<const calibration::SpgpResidual> residual = [] {
    constexpr int kRows = 3000;
    std::mt19937_64 rng(12);
    std::uniform_real_distribution<double> eps(0.0, 0.25), force(0.0, 1500.0);
    std::normal_distribution<double> noise_Pa(0.0, 1000.0);
    Eigen::MatrixXd X(kRows, 2);
    Eigen::VectorXd y(kRows);
    for (int n = 0; n < kRows; ++n) {
      X(n, 0) = eps(rng);
      X(n, 1) = force(rng);
      const double f = X(n, 1) / 1500.0;
      y[n] = 2e4 * std::sin(25.0 * X(n, 0)) + 1e4 * f * f - 6e4 * X(n, 0) * f + noise_Pa(rng);
    }
    calibration::SpgpOptions options;
    options.num_pseudo = 50;
    options.max_iterations = 60;
    const auto spgp = std::make_shared<const calibration::Spgp>(calibration::Spgp::fit(X, y, options));
    return std::make_shared<const calibration::SpgpResidual>(spgp, calibration::Span{0.0, 0.25}, calibration::Span{0.0, 1500.0},
                                                             calibration::Span{-0.2e6, 0.2e6});
  }();
  return residual;
}

}  // namespace peha::bench
