#include "peha/sim/mujoco_model.hpp"

#include <fmt/format.h>

#include <stdexcept>

namespace peha::sim {

ModelPtr load_mjcf(const std::filesystem::path& path) {
  if (!std::filesystem::exists(path)) {
    throw std::runtime_error(fmt::format("{}: MJCF model file not found", path.string()));
  }
  char error[1024] = "";
  ModelPtr m(mj_loadXML(path.string().c_str(), nullptr, error, sizeof(error)));
  if (!m) throw std::runtime_error(fmt::format("{}: MuJoCo could not load the model: {}", path.string(), error));
  return m;
}

int require_id(const mjModel* m, mjtObj type, const std::string& name, const std::string& model_name) {
  const int id = mj_name2id(m, type, name.c_str());
  if (id < 0) {
    throw std::runtime_error(fmt::format("{}: the model has no {} named '{}'", model_name,
                                         type == mjOBJ_BODY ? "body" : type == mjOBJ_JOINT ? "joint" : "object",
                                         name));
  }
  return id;
}

}  // namespace peha::sim
