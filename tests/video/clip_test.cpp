// The video layer: a 2 s clip of the one-DOF rig from a log, checked with ffprobe (duration, size,
// frame count) and by the pixels of a decoded frame (not blank: the link and the overlay are there).
#include "peha/experiments/arm/arm_scenario.hpp"
#include "peha/models/units.hpp"
#include "peha/sim/arm_mjcf.hpp"
#include "peha/sim/mujoco_model.hpp"
#include "peha/video/clip.hpp"
#include "peha/video/run_videos.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <string>
#include <vector>

#include <unistd.h>

namespace peha::video {
namespace {

/// stdout of a command line (test helper; the product never uses a shell).
std::string output_of(const std::string& command) {
  std::string out;
  FILE* p = popen(command.c_str(), "r");
  if (!p) return out;
  char buf[4096];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  pclose(p);
  return out;
}

/// A 2 s E1-like log: the link swings from -10 to +20 deg, the finger pushes for the first second.
std::filesystem::path write_log(const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  const auto path = dir / "e1_payload_test.csv";
  std::ofstream f(path);
  f << "# synthetic log for the video test\n";
  f << "t_s,plant_angle_rad,finger_force_N,finger_active,plant_agonist_force_N,plant_antagonist_force_N,"
       "agonist_pressure_MPa,antagonist_pressure_MPa,tau_motor_cmd_Nm\n";
  for (int k = 0; k <= 2000; ++k) {
    const double t = k * 1e-3;
    const double angle = models::deg_to_rad(-10.0 + 30.0 * 0.5 * (1 - std::cos(M_PI * t / 2)));
    f << t << ',' << angle << ',' << (t < 1 ? 20.0 : 0.0) << ',' << (t < 1 ? 1 : 0) << ',' << 400 + 50 * t << ",100,"
      << 0.25 << ',' << 0.26 << ',' << 0.5 << '\n';
  }
  return path;
}

/// A fresh directory of this process (worktrees may run their tests at the same time).
std::filesystem::path fresh_dir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / (name + "_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

std::filesystem::path rig_model_file() { return std::filesystem::path(PEHA_SOURCE_DIR) / "models" / "one_dof_rig.xml"; }

TEST(VideoClip, TwoSecondClipHasItsDurationSizeFramesAndAPicture) {
  const auto dir = fresh_dir("peha_video_clip_test");
  const auto csv = write_log(dir);
  sim::ModelPtr model = sim::load_mjcf(rig_model_file());
  RunVideoOptions options;
  options.clip.width = 640;
  options.clip.height = 360;
  const RunVideoReport report = render_run_videos(dir, model.get(), options);
  ASSERT_EQ(report.videos.size(), 1u) << "skipped: " << (report.skipped.empty() ? "" : report.skipped.front());
  const auto mp4 = dir / "e1_payload_test.mp4";
  ASSERT_TRUE(std::filesystem::exists(mp4));
  EXPECT_EQ(report.videos[0].stats.frames, 60);  // 2 s at 30 fps, 1x
  EXPECT_GT(std::filesystem::file_size(mp4), 10'000u);
  EXPECT_LT(std::filesystem::file_size(mp4), 5'000'000u);

  // ffprobe: width,height,frames,duration of the video stream.
  const std::string probe = output_of("ffprobe -v error -count_frames -select_streams v:0 -show_entries "
                                      "stream=width,height,nb_read_frames,avg_frame_rate:format=duration -of "
                                      "default=noprint_wrappers=1 '" + mp4.string() + "'");
  EXPECT_NE(probe.find("width=640"), std::string::npos) << probe;
  EXPECT_NE(probe.find("height=360"), std::string::npos) << probe;
  EXPECT_NE(probe.find("nb_read_frames=60"), std::string::npos) << probe;
  EXPECT_NE(probe.find("avg_frame_rate=30/1"), std::string::npos) << probe;
  const auto d = probe.find("duration=");
  ASSERT_NE(d, std::string::npos) << probe;
  EXPECT_NEAR(std::stod(probe.substr(d + 9)), 2.0, 0.05) << probe;

  // A decoded frame at 0.5 s (finger pushing): not blank. The background is uniform; the link,
  // payload, arrow and overlay text make a spread of colours and a share of pixels off the mode.
  const std::string raw = output_of("ffmpeg -v error -ss 0.5 -i '" + mp4.string() +
                                    "' -frames:v 1 -f rawvideo -pix_fmt gray -");
  ASSERT_EQ(raw.size(), 640u * 360u);
  std::vector<int> histogram(256, 0);
  double sum = 0, sum_sq = 0;
  for (unsigned char c : raw) {
    ++histogram[c];
    sum += c;
    sum_sq += double(c) * c;
  }
  const double n = static_cast<double>(raw.size());
  const double stddev = std::sqrt(sum_sq / n - (sum / n) * (sum / n));
  const int mode_count = *std::max_element(histogram.begin(), histogram.end());
  const double off_mode = 1.0 - mode_count / n;
  const int levels = static_cast<int>(std::count_if(histogram.begin(), histogram.end(), [](int h) { return h > 20; }));
  RecordProperty("gray_stddev", std::to_string(stddev));
  RecordProperty("off_background_share", std::to_string(off_mode));
  EXPECT_GT(stddev, 8.0);
  EXPECT_GT(off_mode, 0.02);
  EXPECT_GT(levels, 20);
  std::printf("clip: %s, %ju bytes, render %.2f s for 2 s, gray std %.1f, %.1f %% off the background, %d levels\n",
              mp4.c_str(), static_cast<std::uintmax_t>(std::filesystem::file_size(mp4)), report.videos[0].stats.render_s,
              stddev, 100 * off_mode, levels);
  std::printf("gl: %s\n", report.gl.c_str());
  std::filesystem::remove_all(dir);
}

TEST(VideoClip, RendersInAHiddenWindowOnAnXvfbItStartsWhenThereIsNoDisplay) {
  const auto dir = fresh_dir("peha_video_xvfb_test");
  write_log(dir);
  unsetenv("DISPLAY");  // this test's own process (ctest runs each test alone)
  sim::ModelPtr model = sim::load_mjcf(rig_model_file());
  RunVideoOptions options;
  options.gl = "glfw";
  options.clip.width = 320;
  options.clip.height = 180;
  options.max_seconds = 1.0;
  const RunVideoReport report = render_run_videos(dir, model.get(), options);
  ASSERT_EQ(report.videos.size(), 1u);
  EXPECT_NE(report.gl.find("GLFW hidden window (Xvfb :"), std::string::npos) << report.gl;
  EXPECT_EQ(report.videos[0].stats.frames, 30);
  EXPECT_GT(std::filesystem::file_size(dir / "e1_payload_test.mp4"), 1000u);
  EXPECT_EQ(std::getenv("DISPLAY"), nullptr) << "the Xvfb peha started is stopped and forgotten again";
  std::filesystem::remove_all(dir);
}

TEST(VideoClip, AnUnknownLogIsSkippedWithTheReason) {
  const auto dir = fresh_dir("peha_video_skip_test");
  std::ofstream(dir / "e1_other.csv") << "t_s,x\n0,1\n0.001,2\n";
  sim::ModelPtr model = sim::load_mjcf(rig_model_file());
  const RunVideoReport report = render_run_videos(dir, model.get(), {});
  EXPECT_TRUE(report.videos.empty());
  ASSERT_EQ(report.skipped.size(), 1u);
  EXPECT_NE(report.skipped[0].find("not a log the video knows"), std::string::npos);
  std::filesystem::remove_all(dir);
}

/// Pixels of `pressurised` that are the colour scale's red (R high, G and B low) where `vented` shows
/// the vented grey-blue (B above R) at the same place: the muscle that filled.
int muscle_pixels_turned_red(const std::vector<unsigned char>& vented, const std::vector<unsigned char>& pressurised) {
  int n = 0;
  for (std::size_t i = 0; i + 2 < vented.size(); i += 3) {
    const bool was_blue = vented[i + 2] > vented[i] + 10;
    const bool is_red = pressurised[i] > 120 && pressurised[i] > 2 * pressurised[i + 1] && pressurised[i] > 2 * pressurised[i + 2];
    n += was_blue && is_red;
  }
  return n;
}

// The rig's agonist (DMSP-40, 400 mm, 40 mm across) drawn vented at t = 0 and at the supply
// (0.8 MPa, contracted 20 %) at t = 1: its pixels turn from grey-blue to red. At 640 x 360 from the
// side camera (about 210 px per m) the muscle covers some 700 px; at least 250 must turn. Rendering
// both frames vented turns none: the count sees the pressure, not the scene.
TEST(VideoClip, AMuscleTurnsFromGreyBlueToRedWhenPressurised) {
  sim::ModelPtr model = sim::load_mjcf(rig_model_file());
  const int joint = mj_name2id(model.get(), mjOBJ_JOINT, "joint");
  ClipOptions o;
  o.width = 640;
  o.height = 360;
  o.machine.kind = MachineKind::kRig;
  o.machine.supply_pressure_MPa = 0.8;
  auto setter = [joint](bool pressurise) {
    return [joint, pressurise](double t, mjData* d, Frame& f) {
      d->qpos[0] = 0.0;
      JointMuscles m{joint, JointLook{}, {}};
      if (pressurise && t > 0.5) m.muscle[0] = MuscleState{0.2, 0.8};
      f.muscles.push_back(m);
    };
  };
  {
    mjData* d = mj_makeData(model.get());
    mj_kinematics(model.get(), d);
    const CameraPose c = machine_camera(model.get(), d, MachineKind::kRig);
    mj_deleteData(d);
    o.lookat = c.lookat;
    o.distance_m = c.distance_m;
    o.azimuth_deg = c.azimuth_deg;
    o.elevation_deg = c.elevation_deg;
  }
  const OffscreenContext gl;
  const auto frames = render_frames(model.get(), {0.0, 1.0}, setter(true), o, gl);
  const int turned = muscle_pixels_turned_red(frames[0], frames[1]);
  const auto unchanged = render_frames(model.get(), {0.0, 1.0}, setter(false), o, gl);
  const int turned_without_pressure = muscle_pixels_turned_red(unchanged[0], unchanged[1]);
  std::printf("muscle pixels turned red: %d pressurised, %d vented twice\n", turned, turned_without_pressure);
  RecordProperty("muscle_pixels_turned_red", std::to_string(turned));
  EXPECT_GE(turned, 250);
  EXPECT_EQ(turned_without_pressure, 0);
}

// A two-armed E3 log (the upper body's columns, prefixed by side) makes a clip: every joint named by a
// `<joint>_plant_angle_rad` column drives its joint of the upper body's model, each side its own.
TEST(VideoClip, ATwoArmedPosturesLogDrivesBothArms) {
  const auto dir = fresh_dir("peha_video_two_arms_test");
  const experiments::ArmScenario s =
      experiments::read_arm_scenario(config::Document::load_file(PEHA_SOURCE_DIR "/configs/upper_body.yaml"));
  sim::ModelPtr model = sim::load_arm_mjcf(sim::arm_mjcf(s.plant.model, s.plant.mjcf));
  {
    std::ofstream f(dir / "e3_postures.csv");
    f << "t_s,operator_active";
    for (const std::string& joint : s.plant.actuated) {
      std::string p = joint;
      for (char& c : p) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      for (const char* what : {"plant_angle_rad", "angle_rad", "plant_agonist_force_N", "plant_antagonist_force_N",
                               "agonist_pressure_cmd_MPa", "antagonist_pressure_cmd_MPa"}) {
        f << ',' << p << '_' << what;
      }
    }
    f << '\n';
    for (int k = 0; k <= 1000; ++k) {
      const double t = k * 1e-3;
      f << t << ",0";
      for (std::size_t j = 0; j < s.plant.actuated.size(); ++j) {
        const double angle = (j == 1 ? -1.5 : j == 6 ? 0.3 * t : 0.0);  // R_SFE hangs; L_EFE flexes
        f << ',' << angle << ',' << angle << ",40,40,0.1,0.3";
      }
      f << '\n';
    }
  }
  RunVideoOptions options;
  options.clip.width = 320;
  options.clip.height = 180;
  const RunVideoReport report = render_run_videos(dir, model.get(), options);
  ASSERT_EQ(report.videos.size(), 1u) << (report.skipped.empty() ? std::string() : report.skipped[0]);
  EXPECT_EQ(report.videos[0].stats.frames, 30);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace peha::video
