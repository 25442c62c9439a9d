#include "peha/video/run_videos.hpp"

#include "peha/config/input_file.hpp"

#include "peha/models/units.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace peha::video {
namespace {

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

/// The id of the joint a log names `joint`: that joint, or ("sfe" on one arm) R_SFE, then L_SFE;
/// "r_saa": R_SAA. -1 when the model has none.
int joint_id(const mjModel* model, const std::string& joint) {
  std::string upper = joint;
  for (char& ch : upper) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
  for (const std::string& name : {joint, upper, "R_" + upper, "L_" + upper}) {
    const int id = mj_name2id(model, mjOBJ_JOINT, name.c_str());
    if (id >= 0) return id;
  }
  return -1;
}

/// Its qpos address, -1 when the model has none.
int joint_qpos(const mjModel* model, const std::string& joint) {
  const int id = joint_id(model, joint);
  return id >= 0 ? model->jnt_qposadr[id] : -1;
}

/// A joint's muscle columns: contraction (plant truth) and the chamber's pressure (plant truth, else
/// the sensor, else the command); nullptr where the log has none.
struct MuscleColumns {
  std::array<const std::vector<double>*, 2> contraction{}, pressure_MPa{};
};

MuscleColumns muscle_columns(const LogTable& log, const std::string& prefix) {
  MuscleColumns c;
  const std::array<std::string, 2> muscles{"agonist", "antagonist"};
  for (std::size_t m = 0; m < 2; ++m) {
    auto column = [&](const std::string& name) { return log.has(prefix + name) ? &log.at(prefix + name) : nullptr; };
    c.contraction[m] = column("plant_" + muscles[m] + "_contraction");
    for (const std::string& p : {"plant_" + muscles[m] + "_pressure_MPa", muscles[m] + "_pressure_MPa", muscles[m] + "_pressure_cmd_MPa"}) {
      if (!c.pressure_MPa[m]) c.pressure_MPa[m] = column(p);
    }
  }
  return c;
}

/// The scenario's look of a MuJoCo joint, or the defaults (JointLook) under its name.
JointLook look_of(const MachineLook& machine, const mjModel* model, int joint) {
  const char* name = joint >= 0 ? mj_id2name(model, mjOBJ_JOINT, joint) : nullptr;
  for (const JointLook& j : machine.joints) {
    if (name && j.joint == name) return j;
  }
  JointLook look;
  look.joint = name ? name : "";
  return look;
}

/// A joint's muscles at the sampler's time (NaN where the log has no column).
JointMuscles muscles_at(const Sampler& s, const MuscleColumns& c, int joint, const JointLook& look) {
  JointMuscles j{joint, look, {}};
  for (std::size_t m = 0; m < 2; ++m) {
    j.muscle[m].contraction = c.contraction[m] ? s(*c.contraction[m]) : std::nan("");
    j.muscle[m].pressure_MPa = c.pressure_MPa[m] ? s(*c.pressure_MPa[m]) : std::nan("");
  }
  return j;
}

int qpos_of(const mjModel* m, const std::string& joint) {
  const int q = joint_qpos(m, joint);
  if (q < 0) throw std::runtime_error(fmt::format("the model has no joint '{}' for the video", joint));
  return q;
}

std::vector<double>& derived(LogTable& log, const std::string& name, const std::string& from, double scale) {
  std::vector<double>& out = log.columns[name];
  const std::vector<double>& in = log.at(from);
  out.resize(in.size());
  std::transform(in.begin(), in.end(), out.begin(), [scale](double x) { return x * scale; });
  return out;
}

/// Points the free camera at everything the clip will show. With the machine drawn: as the paper's
/// figures show it (machine_camera, from the pose at t = 0). The model alone: the bounding box of
/// the geoms over poses sampled through the clip (once per second), seen across its thinnest
/// horizontal side.
void frame_model(mjModel* m, const FrameSetter& set, double duration_s, ClipOptions& o) {
  mjData* d = mj_makeData(m);
  Frame scratch;
  if (o.machine.kind != MachineKind::kNone) {
    set(0.0, d, scratch);
    mj_kinematics(m, d);
    const CameraPose c = machine_camera(m, d, o.machine.kind);
    mj_deleteData(d);
    o.lookat = c.lookat;
    o.distance_m = c.distance_m;
    o.azimuth_deg = c.azimuth_deg;
    o.elevation_deg = c.elevation_deg;
    return;
  }
  double lo[3] = {1e9, 1e9, 1e9}, hi[3] = {-1e9, -1e9, -1e9};
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
  std::istringstream in(config::read_input_file(csv, config::InputKind::kLog));
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

/// A model joint a log has columns for: the columns' prefix ("sfe_", "r_saa_", "" ...), its qpos
/// address and its name for the overlay.
struct LogJoint {
  std::string prefix;
  int qpos = -1;
  std::string label;
  int id = -1;  ///< MuJoCo joint id
};

/// Every joint with a column `<prefix><suffix>` whose prefix names a joint of `model` (an empty
/// prefix is kept with qpos -1 for the caller to resolve), in the log's column order.
std::vector<LogJoint> log_joints(const LogTable& log, const mjModel* model, const std::string& suffix) {
  std::vector<LogJoint> out;
  for (const std::string& name : log.names) {
    if (!name.ends_with(suffix) || name.starts_with("video_")) continue;
    const std::string prefix = name.substr(0, name.size() - suffix.size());
    if (prefix.empty()) {
      out.push_back({prefix, -1, ""});
      continue;
    }
    if (prefix.back() != '_') continue;
    const std::string joint = prefix.substr(0, prefix.size() - 1);
    const int id = joint_id(model, joint);
    if (id < 0) continue;
    std::string label = joint;
    for (char& ch : label) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
    out.push_back({prefix, model->jnt_qposadr[id], label, id});
  }
  return out;
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
    o.machine.kind = MachineKind::kRig;
    const int id = mj_name2id(model, mjOBJ_JOINT, "joint");
    const JointLook look = look_of(o.machine, model, id);
    const MuscleColumns muscles = muscle_columns(log, "");
    const auto& angle_deg = derived(log, "video_angle_deg", "plant_angle_rad", models::kDegPerRad);
    o.inset = {{"angle / deg", &t, &angle_deg, blue}, {"finger / N", &t, &log.at("finger_force_N"), orange}};
    o.inset_title = "link angle and finger force";
    return [=](double time, mjData* d, Frame& f) {
      sample->seek(time);
      const Sampler& s = *sample;
      // Over the board the plant's truth is unknown (NaN): the encoder's angle then.
      const double plant = s(L->at("plant_angle_rad"));
      const double angle = std::isfinite(plant) || !L->has("angle_rad") ? plant : s(L->at("angle_rad"));
      d->qpos[q] = angle;
      f.muscles.push_back(muscles_at(s, muscles, id, look));
      const double finger = s(L->at("finger_force_N"));
      const bool active = s.nearest(L->at("finger_active")) > 0.5;
      f.overlay_names = "time\nangle\nfinger\nF agonist / antagonist\np agonist / antagonist\nmotor";
      f.overlay_values = fmt::format("{:.2f} s\n{:.2f} deg\n{}\n{}\n{:.2f} Nm", time, models::rad_to_deg(angle),
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
  // E3 (postures): every joint with a `<prefix>plant_angle_rad` column ("sfe_" on one arm, "r_saa_"
  // on two), in the log's order.
  std::vector<LogJoint> e3 = log_joints(log, model, "plant_angle_rad");
  std::erase_if(e3, [](const LogJoint& j) { return j.qpos < 0; });
  if (!e3.empty()) {
    o.inset.clear();
    for (std::size_t k = 0; k < e3.size() && k < 2; ++k) {
      o.inset.push_back({fmt::format("{} / deg", e3[k].label), &t,
                         &derived(log, "video_" + e3[k].prefix + "deg", e3[k].prefix + "plant_angle_rad", models::kDegPerRad), k == 0 ? blue : orange});
    }
    o.inset_title = e3.size() > 1 ? fmt::format("{} and {} angles", e3[0].label, e3[1].label) : e3[0].label + " angle";
    const bool compact = e3.size() > 3;  // two arms: one line per joint
    o.machine.kind = MachineKind::kArm;
    std::vector<std::pair<MuscleColumns, JointLook>> muscles;
    for (const LogJoint& j : e3) muscles.emplace_back(muscle_columns(log, j.prefix), look_of(o.machine, model, j.id));
    return [=](double time, mjData* d, Frame& f) {
      sample->seek(time);
      const Sampler& s = *sample;
      std::string names = "time\noperator", values = fmt::format("{:.2f} s\n{}", time,
                                                                  s.nearest(L->at("operator_active")) > 0.5 ? "holding" : "released");
      for (const LogJoint& j : e3) {
        auto c = [&](const char* what) { return s(L->at(j.prefix + what)); };
        const double angle = std::isfinite(c("plant_angle_rad")) ? c("plant_angle_rad") : c("angle_rad");  // board: encoder
        d->qpos[j.qpos] = angle;
        const auto& [columns, look] = muscles[static_cast<std::size_t>(&j - e3.data())];
        f.muscles.push_back(muscles_at(s, columns, j.id, look));
        if (compact) {
          names += fmt::format("\n{}", j.label);
          values += fmt::format("\n{:.1f} deg  {:.0f} / {:.0f} N", models::rad_to_deg(angle), c("plant_agonist_force_N"), c("plant_antagonist_force_N"));
        } else {
          names += fmt::format("\n{} angle\n  F agonist / antagonist\n  p cmd", j.label);
          values += fmt::format("\n{:.1f} deg\n{:.0f} N / {:.0f} N\n{:.3f} / {:.3f} MPa", models::rad_to_deg(angle), c("plant_agonist_force_N"),
                                c("plant_antagonist_force_N"), c("agonist_pressure_cmd_MPa"), c("antagonist_pressure_cmd_MPa"));
        }
      }
      f.overlay_names = names;
      f.overlay_values = values;
    };
  }
  // E4: each driven joint's `<prefix>plant_elbow_deg` ("" for one elbow: R_EFE; "r_efe_" ...), each held
  // joint's `plant_<joint>_deg`.
  std::vector<LogJoint> driven = log_joints(log, model, "plant_elbow_deg");
  if (driven.size() == 1 && driven[0].prefix.empty()) {
    driven[0].id = joint_id(model, "efe");
    driven[0].qpos = joint_qpos(model, "efe");
    driven[0].label = "EFE";
  }
  std::erase_if(driven, [](const LogJoint& j) { return j.qpos < 0; });
  if (!driven.empty()) {
    std::vector<std::pair<int, std::string>> held;  // qpos, column
    for (const std::string& name : log.names) {
      if (!name.starts_with("plant_") || !name.ends_with("_deg") || name == "plant_elbow_deg") continue;
      const std::string joint = name.substr(6, name.size() - 10);
      const int q = joint_qpos(model, joint);
      if (q >= 0) held.emplace_back(q, name);
    }
    const LogJoint& first = driven.front();
    o.inset = {{"person / deg", &t, &log.at(first.prefix + "person_elbow_deg"), green},
               {"exo / deg", &t, &log.at(first.prefix + "plant_elbow_deg"), blue}};
    o.inset_title = driven.size() > 1 ? first.label + ": person and exoskeleton" : "elbow: person and exoskeleton";
    o.machine.kind = MachineKind::kArm;
    std::vector<std::pair<MuscleColumns, JointLook>> muscles;
    for (const LogJoint& j : driven) muscles.emplace_back(muscle_columns(log, j.prefix), look_of(o.machine, model, j.id));
    return [=](double time, mjData* d, Frame& f) {
      sample->seek(time);
      const Sampler& s = *sample;
      std::string names = "time", values = fmt::format("{:.2f} s", time);
      for (const auto& [q, column] : held) {
        if (const double deg = s(L->at(column)); std::isfinite(deg)) d->qpos[q] = models::deg_to_rad(deg);
      }
      for (const LogJoint& j : driven) {
        auto c = [&](const char* what) { return s(L->at(j.prefix + what)); };
        const double elbow = c("plant_elbow_deg");
        d->qpos[j.qpos] = models::deg_to_rad(std::isfinite(elbow) ? elbow : c("elbow_encoder_deg"));  // board: encoder
        const auto& [columns, look] = muscles[static_cast<std::size_t>(&j - driven.data())];
        f.muscles.push_back(muscles_at(s, columns, j.id, look));
        const std::string who = driven.size() > 1 ? j.label + " " : std::string();
        names += fmt::format("\n{}person\n{}exo\n  F agonist / antagonist\n  p cmd\n  motor", who, who);
        values += fmt::format("\n{:.1f} deg\n{:.1f} deg\n{}\n{:.2f} Nm", c("person_elbow_deg"), elbow,
                              muscle_lines(c("plant_agonist_force_N"), c("plant_antagonist_force_N"), c("agonist_pressure_cmd_MPa"),
                                           c("antagonist_pressure_cmd_MPa")),
                              c("tau_motor_cmd_Nm"));
      }
      f.overlay_names = names;
      f.overlay_values = values;
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
