#include "peha/experiments/common/mujoco_lock.hpp"

namespace peha::experiments {

std::mutex& mujoco_load_mutex() {
  static std::mutex m;
  return m;
}

}  // namespace peha::experiments
