#include "peha/video/run_videos.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>
#include <stdexcept>

namespace peha::video {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

/// Linear interpolation of a column at time t (clamped to the log's ends).
class Sampler {
 public:
  explicit Sampler(const std::vector<double>& t) : t_(t) {}
  void seek(double t) {
    const auto it = std::upper_bound(t_.begin(), t_.end(), t);
    if (it == t_.begin()) { i_ = 0; w_ = 0; return; }
    if (it == t_.end()) { i_ = t_.size() - 1; w_ = 0; return; }
    i_ = static_cast<std::size_t>(it - t_.begin()) - 1;
    const double span = t_[i_ + 1] - t_[i_];
    w_ = span > 0 ? (t - t_[i_]) / span : 0.0;
  }
  double operator()(const std::vector<double>& v) const { return w_ > 0 ? v[i_] + w_ * (v[i_ + 1] - v[i_]) : v[i_]; }
  double nearest(const std::vector<double>& v) const { return w_ < 0.5 ? v[i_] : v[i_ + 1]; }

 private:
  const std::vector<double>& t_;
  std::size_t i_ = 0;
  double w_ = 0;
};

int qpos_of(const mjModel* m, const std::string& joint) {
  const int id = mj_name2id(m, mjOBJ_JOINT, joint.c_str());
  if (id < 0) throw std::runtime_error(fmt::format("the model has no joint '{}' for the video", joint));
  return m->jnt_qposadr[id];
}

std::vector<double>& derived(LogTable& log, const std::string& name, const std::string& from, double scale) {
  std::vector<double>& out = log.columns[name];
  const std::vector<double>& in = log.at(from);
  out.resize(in.size());
  std::transform(in.begin(), in.end(), out.begin(), [scale](double x) { return x * scale; });
  return out;
}

/// Points the free camera at everything the clip will show: the bounding box of the geoms over
/// poses sampled through the clip (once per second), seen across its thinnest horizontal side.
void frame_model(mjModel* m, const FrameSetter& set, double duration_s, ClipOptions& o) {
  mjData* d = mj_makeData(m);
  double lo[3] = {1e9, 1e9, 1e9}, hi[3] = {-1e9, -1e9, -1e9};
  Frame scratch;
  for (double t = 0; t <= duration_s + 1e-9; t += std::max(1.0, duration_s / 200)) {
    set(t, d, scratch);
    mj_kinematics(m, d);
    for (int g = 0; g < m->ngeom; ++g) {
      const double r = m->geom_rbound[g] > 0 ? std::min(m->geom_rbound[g], 0.1) : 0.0;
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], d->geom_xpos[3 * g + k] - r);
        hi[k] = std::max(hi[k], d->geom_xpos[3 * g + k] + r);
      }
    }
  }
  mj_deleteData(d);
  double extent = 0;
  for (int k = 0; k < 3; ++k) {
    o.lookat[static_cast<std::size_t>(k)] = 0.5 * (lo[k] + hi[k]);
    extent = std::max(extent, hi[k] - lo[k]);
  }
  o.azimuth_deg = (hi[1] - lo[1]) <= (hi[0] - lo[0]) ? 90.0 : 0.0;  // look along the thinner of x and y
  o.distance_m = std::max(0.8, 1.7 * extent);
}

std::string muscle_lines(double f1, double f2, double p1, double p2) {
  return fmt::format("{:.0f} N / {:.0f} N\n{:.3f} / {:.3f} MPa", f1, f2, p1, p2);
}

}  // namespace

const std::vector<double>& LogTable::at(const std::string& name) const {
  const auto it = columns.find(name);
  if (it == columns.end()) throw std::runtime_error(fmt::format("log has no column '{}'", name));
  return it->second;
}

LogTable read_log_table(const std::filesystem::path& csv) {
  std::ifstream in(csv);
  if (!in) throw std::runtime_error(fmt::format("{}: cannot read", csv.string()));
  LogTable t;
  std::string line;
  std::size_t line_no = 0;
  std::vector<std::vector<double>*> cols;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line[0] == '#') continue;
    std::stringstream ss(line);
    std::string cell;
    if (t.names.empty()) {
      while (std::getline(ss, cell, ',')) t.names.push_back(cell);
      for (const auto& n : t.names) cols.push_back(&t.columns[n]);
      continue;
    }
    std::size_t c = 0;
    while (std::getline(ss, cell, ',')) {
      if (c >= cols.size()) throw std::runtime_error(fmt::format("{}:{}: more cells than columns", csv.string(), line_no));
      char* end = nullptr;
      const double v = std::strtod(cell.c_str(), &end);
      if (end == cell.c_str()) throw std::runtime_error(fmt::format("{}:{}: '{}' is not a number", csv.string(), line_no, cell));
      cols[c++]->push_back(v);
    }
    if (c != cols.size()) throw std::runtime_error(fmt::format("{}:{}: {} cells, {} columns", csv.string(), line_no, c, cols.size()));
  }
  if (!t.has("t_s")) throw std::runtime_error(fmt::format("{}: no t_s column", csv.string()));
  return t;
}

FrameSetter log_frame_setter(LogTable& log, const mjModel* model, ClipOptions& o, const std::string& title) {
  const auto& t = log.at("t_s");
  auto sample = std::make_shared<Sampler>(t);
  o.title = title;
  const std::array<float, 3> blue{0.3f, 0.6f, 1.0f}, orange{1.0f, 0.6f, 0.2f}, green{0.4f, 0.9f, 0.4f};
  const LogTable* L = &log;
  if (log.has("plant_angle_rad") && log.has("finger_force_N")) {  // E1, the one-DOF rig
    const int q = qpos_of(model, "joint");
    const int tip = mj_name2id(model, mjOBJ_SITE, "tip");
    const auto& angle_deg = derived(log, "video_angle_deg", "plant_angle_rad", 1 / kDeg);
    o.inset = {{"angle / deg", &t, &angle_deg, blue}, {"finger / N", &t, &log.at("finger_force_N"), orange}};
    o.inset_title = "link angle and finger force";
    return [=](double time, mjData* d, Frame& f) {
      sample->seek(time);
      const Sampler& s = *sample;
      // Over the board the plant's truth is unknown (NaN): the encoder's angle then.
      const double plant = s(L->at("plant_angle_rad"));
      const double angle = std::isfinite(plant) || !L->has("angle_rad") ? plant : s(L->at("angle_rad"));
      d->qpos[q] = angle;
      const double finger = s(L->at("finger_force_N"));
      const bool active = s.nearest(L->at("finger_active")) > 0.5;
      f.overlay_names = "time\nangle\nfinger\nF agonist / antagonist\np agonist / antagonist\nmotor";
      f.overlay_values = fmt::format("{:.2f} s\n{:.2f} deg\n{}\n{}\n{:.2f} Nm", time, angle / kDeg,
                                     active ? fmt::format("{:.1f} N", finger) : std::string("released"),
                                     muscle_lines(s(L->at("plant_agonist_force_N")), s(L->at("plant_antagonist_force_N")),
                                                  s(L->at("agonist_pressure_MPa")), s(L->at("antagonist_pressure_MPa"))),
                                     s(L->at("tau_motor_cmd_Nm")));
      if (tip >= 0 && active && std::isfinite(finger) && std::abs(finger) > 0.5) {
        // The finger pushes along the link's upward normal (the tip site's z axis) at the tip.
        mj_kinematics(model, d);
        const double* p = d->site_xpos + 3 * tip;
        const double* R = d->site_xmat + 9 * tip;
        const double n[3] = {R[2], R[5], R[8]};
        // 1 cm per N (at least 5 cm, at most 40 cm), signed: the arrow points at the tip.
        const double length = std::copysign(std::clamp(0.01 * std::abs(finger), 0.05, 0.4), finger);
        // It stops 6 cm short of the tip, outside the payload's weight (5 cm radius).
        const double gap = std::copysign(0.06, finger), from = gap + length;
        f.arrows.push_back({{p[0] - n[0] * from, p[1] - n[1] * from, p[2] - n[2] * from},
                            {p[0] - n[0] * gap, p[1] - n[1] * gap, p[2] - n[2] * gap}});
      }
    };
  }
  if (log.has("sfe_plant_angle_rad")) {  // E3, the right arm's postures
    const int q[3] = {qpos_of(model, "R_SFE"), qpos_of(model, "R_EFE"), qpos_of(model, "R_WFE")};
    o.inset = {{"SFE / deg", &t, &derived(log, "video_sfe_deg", "sfe_plant_angle_rad", 1 / kDeg), blue},
               {"EFE / deg", &t, &derived(log, "video_efe_deg", "efe_plant_angle_rad", 1 / kDeg), orange}};
    o.inset_title = "shoulder and elbow angles";
    return [=](double time, mjData* d, Frame& f) {
      sample->seek(time);
      const Sampler& s = *sample;
      std::string names = "time\noperator", values = fmt::format("{:.2f} s\n{}", time,
                                                                  s.nearest(L->at("operator_active")) > 0.5 ? "holding" : "released");
      const char* joints[3] = {"sfe", "efe", "wfe"};
      for (int j = 0; j < 3; ++j) {
        auto c = [&](const char* what) { return s(L->at(fmt::format("{}_{}", joints[j], what))); };
        const double angle = std::isfinite(c("plant_angle_rad")) ? c("plant_angle_rad") : c("angle_rad");  // board: encoder
        d->qpos[q[j]] = angle;
        names += fmt::format("\n{} angle\n  F agonist / antagonist\n  p cmd", j == 0 ? "SFE" : j == 1 ? "EFE" : "WFE");
        values += fmt::format("\n{:.1f} deg\n{:.0f} N / {:.0f} N\n{:.3f} / {:.3f} MPa", angle / kDeg,
                              c("plant_agonist_force_N"), c("plant_antagonist_force_N"), c("agonist_pressure_cmd_MPa"),
                              c("antagonist_pressure_cmd_MPa"));
      }
      f.overlay_names = names;
      f.overlay_values = values;
    };
  }
  if (log.has("plant_elbow_deg")) {  // E4, the elbow follows a person's goniometer
    const int sfe = qpos_of(model, "R_SFE"), efe = qpos_of(model, "R_EFE");
    o.inset = {{"person / deg", &t, &log.at("person_elbow_deg"), green}, {"exo / deg", &t, &log.at("plant_elbow_deg"), blue}};
    o.inset_title = "elbow: person and exoskeleton";
    return [=](double time, mjData* d, Frame& f) {
      sample->seek(time);
      const Sampler& s = *sample;
      if (const double shoulder = s(L->at("plant_sfe_deg")); std::isfinite(shoulder)) d->qpos[sfe] = shoulder * kDeg;
      const double elbow = s(L->at("plant_elbow_deg"));
      d->qpos[efe] = (std::isfinite(elbow) ? elbow : s(L->at("elbow_encoder_deg"))) * kDeg;  // board: encoder
      f.overlay_names = "time\nperson's elbow\nexo elbow\nshoulder\nF agonist / antagonist\np cmd\nmotor";
      f.overlay_values = fmt::format("{:.2f} s\n{:.1f} deg\n{:.1f} deg\n{:.1f} deg\n{}\n{:.2f} Nm", time,
                                     s(L->at("person_elbow_deg")), s(L->at("plant_elbow_deg")), s(L->at("plant_sfe_deg")),
                                     muscle_lines(s(L->at("plant_agonist_force_N")), s(L->at("plant_antagonist_force_N")),
                                                  s(L->at("agonist_pressure_cmd_MPa")), s(L->at("antagonist_pressure_cmd_MPa"))),
                                     s(L->at("tau_motor_cmd_Nm")));
    };
  }
  throw std::runtime_error("not a log the video knows (E1 e1_<case>.csv, E3 e3_postures.csv, E4 e4_<movement>_<variant>.csv)");
}

RunVideoReport render_run_videos(const std::filesystem::path& dir, mjModel* model, const RunVideoOptions& options) {
  std::vector<std::filesystem::path> logs;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (e.path().extension() != ".csv" || name == "summary.csv") continue;
    if (name.rfind("e1_", 0) == 0 || name == "e3_postures.csv" || name.rfind("e4_", 0) == 0) {
      logs.push_back(e.path());
    }
  }
  std::sort(logs.begin(), logs.end());
  RunVideoReport report;
  if (logs.empty()) return report;
  const OffscreenContext gl(options.gl);
  report.gl = gl.description();
  for (const auto& csv : logs) {
    LogTable log = read_log_table(csv);
    ClipOptions clip = options.clip;
    FrameSetter set;
    try {
      set = log_frame_setter(log, model, clip, csv.stem().string());
    } catch (const std::runtime_error& e) {
      report.skipped.push_back(fmt::format("{}: {}", csv.filename().string(), e.what()));
      continue;
    }
    const auto& t = log.at("t_s");
    double duration = t.empty() ? 0.0 : t.back();
    if (options.max_seconds > 0) duration = std::min(duration, options.max_seconds);
    if (options.auto_frame) frame_model(model, set, duration, clip);
    RunVideo v{csv, std::filesystem::path(csv).replace_extension(".mp4"), {}};
    v.stats = render_clip(model, duration, set, clip, v.mp4, gl);
    report.videos.push_back(v);
  }
  return report;
}

}  // namespace peha::video
