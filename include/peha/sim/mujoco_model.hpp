#pragma once
/// \file
/// Owning handles for a MuJoCo model and its data, with load errors as exceptions (set-up only).

#include <mujoco/mujoco.h>

#include <filesystem>
#include <memory>
#include <string>

namespace peha::sim {

struct ModelDeleter {
  void operator()(mjModel* m) const noexcept { mj_deleteModel(m); }
};
struct DataDeleter {
  void operator()(mjData* d) const noexcept { mj_deleteData(d); }
};
using ModelPtr = std::unique_ptr<mjModel, ModelDeleter>;
using DataPtr = std::unique_ptr<mjData, DataDeleter>;

/// Loads an MJCF file; throws std::runtime_error with MuJoCo's message and the path on failure.
ModelPtr load_mjcf(const std::filesystem::path& path);

/// Id of a named object; throws naming the model, the kind and the name if it does not exist.
int require_id(const mjModel* m, mjtObj type, const std::string& name, const std::string& model_name);

}  // namespace peha::sim
