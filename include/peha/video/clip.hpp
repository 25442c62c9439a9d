#pragma once
/// \file
/// One MP4 clip of a run (docs/video.md): a MuJoCo model posed frame by frame from the run's log,
/// rendered offscreen (OffscreenContext), with a text overlay, optional force arrows and an inset
/// plot of logged signals up to the frame's time, encoded by ffmpeg. The clip replays what was
/// logged; it never steps a simulation.

#include "peha/video/machine_scene.hpp"
#include "peha/video/offscreen.hpp"

#include <mujoco/mujoco.h>

#include <array>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace peha::video {

/// An arrow drawn into the scene, world coordinates, m.
struct Arrow {
  std::array<double, 3> from{}, to{};
  std::array<float, 4> rgba{0.9f, 0.2f, 0.1f, 1.0f};
  double width_m = 0.012;
};

/// What the caller sets for one frame.
struct Frame {
  std::string overlay_names, overlay_values;  ///< two columns of the text overlay (lines separated by \n)
  std::vector<Arrow> arrows;
  std::vector<JointMuscles> muscles;  ///< the actuated joints' muscles (drawn when ClipOptions::machine is not kNone)
};

/// A logged signal for the inset plot.
struct Series {
  std::string name;                    ///< legend, with unit
  const std::vector<double>* t_s = nullptr;
  const std::vector<double>* values = nullptr;
  std::array<float, 3> rgb{1, 1, 1};
};

struct ClipOptions {
  int width = 960;                     ///< pixels (even)
  int height = 540;                    ///< pixels (even)
  int fps = 30;
  double speed = 1.0;                  ///< simulated seconds per video second
  std::array<double, 3> lookat{0, 0, 1};  ///< free camera target, m
  double distance_m = 1.5;
  double azimuth_deg = 90;
  double elevation_deg = -10;
  std::string title;                   ///< top-right overlay, e.g. "E1 payload_5.0kg"
  MachineLook machine;                 ///< muscles, cables and scenery drawn around the model (kNone: the model alone)
  std::vector<Series> inset;           ///< inset plot of these (empty: none)
  std::string inset_title;
  double inset_window_s = 10;          ///< the inset shows the last this many seconds
};

/// Poses `data` (qpos; the renderer then runs mj_kinematics) and fills `frame` for time t_s.
using FrameSetter = std::function<void(double t_s, mjData* data, Frame& frame)>;

struct ClipStats {
  int frames = 0;
  double duration_s = 0;      ///< of the video
  double render_s = 0;        ///< wall time of posing, rendering, reading back and encoding
  std::uintmax_t bytes = 0;   ///< MP4 size
};

/// Renders [0, duration_s] of simulated time at options.fps / options.speed frames per simulated
/// second into `mp4`. The context must be current on this thread. Throws std::runtime_error
/// (ffmpeg missing or failing, a model MuJoCo cannot render).
ClipStats render_clip(mjModel* model, double duration_s, const FrameSetter& set, const ClipOptions& options,
                      const std::filesystem::path& mp4, const OffscreenContext& gl);

/// The same renderer writing frames at the given times as PNG-less raw RGB (for tests and stills):
/// returns width * height * 3 bytes per time, top row first.
std::vector<std::vector<unsigned char>> render_frames(mjModel* model, const std::vector<double>& times_s,
                                                      const FrameSetter& set, const ClipOptions& options,
                                                      const OffscreenContext& gl);

}  // namespace peha::video
