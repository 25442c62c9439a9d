#pragma once
/// \file
/// One lock around MuJoCo's model loading (MJCF parsing and compiling), for experiments that build
/// simulated plants on several threads (the robustness matrix). Stepping separate models in
/// parallel needs no lock.

#include <mutex>

namespace peha::experiments {

/// Held while a MuJoCo model is loaded (sim::load_mjcf, a simulated backend's constructor).
std::mutex& mujoco_load_mutex();

}  // namespace peha::experiments
