#pragma once
/// \file
/// `peha run --video`: one MP4 per per-cycle log of a run directory, beside the CSV (docs/video.md).
/// The clip poses the plant's MuJoCo model from the logged plant angles and overlays time, joint
/// angles, muscle forces and pressures (and the finger's force as an arrow on the one-DOF rig).
/// Known logs: E1 `e1_<case>.csv` (joint "joint"), E3 `e3_postures.csv` and E4
/// `e4_<movement>_<variant>.csv` (joints R_SFE, R_EFE, R_WFE of the right arm).

#include "peha/sim/mujoco_model.hpp"
#include "peha/video/clip.hpp"

#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace peha::video {

/// A run's per-cycle CSV: column name -> values (the header first; '#' lines, as older logs have,
/// skipped). Throws std::runtime_error naming the file and line on a malformed row.
struct LogTable {
  std::vector<std::string> names;
  std::map<std::string, std::vector<double>> columns;
  bool has(const std::string& name) const { return columns.count(name) != 0; }
  const std::vector<double>& at(const std::string& name) const;
  std::size_t rows() const { return columns.empty() ? 0 : columns.begin()->second.size(); }
};
LogTable read_log_table(const std::filesystem::path& csv);

struct RunVideoOptions {
  ClipOptions clip;            ///< size, fps, speed (camera framed from the model when auto_frame)
  bool auto_frame = true;      ///< point the camera at the geoms over the poses the clip shows
  std::string gl = "auto";     ///< OffscreenContext backend: auto, egl or glfw
  double max_seconds = 0;      ///< > 0: only the first this many simulated seconds of each log
};

struct RunVideo {
  std::filesystem::path csv, mp4;
  ClipStats stats;
};

struct RunVideoReport {
  std::string gl;                    ///< which OpenGL context rendered (description)
  std::vector<RunVideo> videos;
  std::vector<std::string> skipped;  ///< logs of the directory no clip is made for, with why
};

/// Renders every known log in `dir` with `model` (the plant's MuJoCo model; its render buffer size
/// is raised to the clip's). Throws std::runtime_error when no OpenGL context can be made or ffmpeg
/// fails; the caller decides what that means for the run.
RunVideoReport render_run_videos(const std::filesystem::path& dir, mjModel* model, const RunVideoOptions& options);

/// The per-frame setter and clip options of one log (exposed for tests and stills): poses the
/// model's joints from the log at time t (linear interpolation) and writes the overlay. Adds the
/// inset's derived columns (video_*) to `log`, which must outlive the setter.
FrameSetter log_frame_setter(LogTable& log, const mjModel* model, ClipOptions& options, const std::string& title);

}  // namespace peha::video
