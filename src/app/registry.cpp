#include "peha/app/registry.hpp"

#include "peha/experiments/arm/arm_contract.hpp"
#include "peha/experiments/creep/creep_contract.hpp"
#include "peha/experiments/e1_gravity/e1_contract.hpp"
#include "peha/experiments/e5_max_force/e5_contract.hpp"

#include <stdexcept>

namespace peha::app {

const std::vector<Experiment>& experiment_registry() {
  static const std::vector<Experiment> registry = {
      experiments::e1_experiment(),
      experiments::creep_experiment(),
      experiments::e5_experiment(),
      experiments::arm_experiment(),
  };
  return registry;
}

const Experiment& find_experiment(const config::Document& doc) {
  std::vector<std::string> keys;
  for (const auto& e : experiment_registry()) keys.push_back(e.key);
  config::Map root = doc.root();
  const std::string key = root.choice("experiment", keys);  // throws, naming the known keys
  for (const auto& e : experiment_registry()) {
    if (e.key == key) return e;
  }
  throw std::logic_error("unreachable: the experiment key was checked");
}

}  // namespace peha::app
