// `peha run --video`: the plant's MuJoCo model from the scenario, then video::render_run_videos.
#include "peha/app/video_option.hpp"

#include "peha/experiments/e1_gravity/e1_gravity.hpp"
#include "peha/experiments/arm/arm_scenario.hpp"
#include "peha/sim/arm_mjcf.hpp"
#include "peha/video/run_videos.hpp"

#include <fmt/format.h>

#include <cstdlib>
#include <stdexcept>

namespace peha::app {
namespace {

/// A Festo DMSP's nominal inner diameter from its type, "DMSP-40" -> 0.040 m (the number is mm).
double muscle_diameter_m(const std::string& type) {
  const auto dash = type.rfind('-');
  const double mm = dash == std::string::npos ? 0.0 : std::atof(type.c_str() + dash + 1);
  if (!(mm > 0 && mm < 200)) throw std::runtime_error(fmt::format("muscle type '{}': no diameter in mm after a '-' (DMSP-40)", type));
  return mm * 1e-3;
}

video::JointLook joint_look(const std::string& joint, const sim::PehaJointPlantParams& p) {
  video::JointLook look;
  look.joint = joint;
  look.pulley_radius_m = p.pulley_radius_m;
  look.muscle = {video::MuscleLook{p.agonist.rest_length_m, muscle_diameter_m(p.agonist.law.name)},
                 video::MuscleLook{p.antagonist.rest_length_m, muscle_diameter_m(p.antagonist.law.name)}};
  return look;
}

}  // namespace

bool write_run_videos(const config::Document& doc, const std::string& experiment, const std::filesystem::path& dir) {
  try {
    sim::ModelPtr model;
    video::RunVideoOptions options;
    video::MachineLook& look = options.clip.machine;  // its kind is the log's (video::log_frame_setter)
    if (experiment == "arm") {
      const sim::ArmPlantParams plant = experiments::read_arm_scenario(doc).plant;
      model = sim::load_arm_mjcf(sim::arm_mjcf(plant.model, plant.mjcf));
      for (std::size_t j = 0; j < plant.actuated.size(); ++j) look.joints.push_back(joint_look(plant.actuated[j], plant.actuators[j]));
      if (!plant.actuators.empty()) look.supply_pressure_MPa = plant.actuators[0].agonist.valve.supply_pressure_Pa * 1e-6;
    } else {
      const sim::OneDofRigParams plant = experiments::read_e1(doc).plant;
      model = sim::load_mjcf(plant.model_file);
      look.joints.push_back(joint_look("joint", plant.joint));
      look.supply_pressure_MPa = plant.supply_pressure_Pa * 1e-6;
    }
    const video::RunVideoReport report = video::render_run_videos(dir, model.get(), options);
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
