// `peha run --video`: the plant's MuJoCo model from the scenario, then video::render_run_videos.
#include "peha/app/video_option.hpp"

#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/experiments/arm/arm_scenario.hpp"
#include "peha/sim/arm_mjcf.hpp"
#include "peha/video/run_videos.hpp"

#include <fmt/format.h>

namespace peha::app {

bool write_run_videos(const config::Document& doc, const std::string& experiment, const std::filesystem::path& dir) {
  try {
    sim::ModelPtr model;
    if (experiment == "arm") {
      const sim::ArmPlantParams plant = experiments::read_arm_scenario(doc).plant;
      model = sim::load_arm_mjcf(sim::arm_mjcf(plant.model, plant.mjcf));
    } else {
      model = sim::load_mjcf(experiments::read_e1(doc).plant.model_file);
    }
    const video::RunVideoReport report = video::render_run_videos(dir, model.get(), {});
    for (const auto& v : report.videos) {
      fmt::print("video: {} ({} frames, {:.1f} s at {} fps, {:.1f} MB, rendered in {:.1f} s)\n", v.mp4.string(),
                 v.stats.frames, v.stats.duration_s, video::ClipOptions{}.fps, v.stats.bytes / 1e6, v.stats.render_s);
    }
    for (const auto& s : report.skipped) fmt::print("video: no clip of {}\n", s);
    if (!report.gl.empty()) fmt::print("video: rendered with {}\n", report.gl);
    if (report.videos.empty()) fmt::print("video: this run wrote no per-cycle log a video is made of\n");
    return true;
  } catch (const std::exception& e) {
    fmt::print(stderr, "video: NO VIDEO WRITTEN: {}\n       (every other output of the run is written in {})\n", e.what(),
               dir.string());
    return false;
  }
}

}  // namespace peha::app
