#pragma once
// The shipped scenarios as the tests read them, one definition each (the test sources are compiled
// in batches: a file-local helper of the same name in two files would collide).
#include "peha/config/reader.hpp"
#include "peha/experiments/arm/arm_scenario.hpp"
#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/experiments/e5_max_force/max_force.hpp"

namespace peha::test_support {

inline experiments::E1Scenario shipped_e1() {
  return experiments::read_e1(config::Document::load_file(PEHA_SOURCE_DIR "/configs/e1_one_dof.yaml"));
}

inline experiments::ArmScenario shipped_right_arm() {
  return experiments::read_arm_scenario(config::Document::load_file(PEHA_SOURCE_DIR "/configs/right_arm.yaml"));
}

inline experiments::E5Scenario shipped_e5() {
  return experiments::read_e5(config::Document::load_file(PEHA_SOURCE_DIR "/configs/e5_max_force.yaml"));
}

}  // namespace peha::test_support
