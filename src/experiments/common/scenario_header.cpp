#include "peha/experiments/common/scenario_header.hpp"

namespace peha::experiments {

ScenarioHeader read_scenario_header(config::Map& root, const char* experiment) {
  ScenarioHeader h;
  root.choice("experiment", {experiment});
  h.description = root.string("description");
  h.seed = static_cast<std::uint64_t>(root.integer("seed", 0, 1L << 40));
  return h;
}

}  // namespace peha::experiments
