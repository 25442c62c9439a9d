#include "peha/video/machine_scene.hpp"

#include <algorithm>
#include <cmath>
#include <string_view>

namespace peha::video {
namespace {

using V = std::array<double, 3>;
V operator+(V a, V b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
V operator-(V a, V b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
V operator*(V a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
double dot(V a, V b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
V cross(V a, V b) { return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]}; }
V unit(V a) {
  const double n = std::sqrt(dot(a, a));
  return n > 1e-12 ? a * (1 / n) : V{0, 0, 1};
}
V at(const double* p) { return {p[0], p[1], p[2]}; }
/// Column k of a row-major 3x3 rotation (a body's axis k in world coordinates).
V column(const double* mat, int k) { return {mat[k], mat[3 + k], mat[6 + k]}; }

using Rgba = std::array<float, 4>;
constexpr Rgba kAluminium{0.72f, 0.74f, 0.78f, 1}, kDarkFrame{0.30f, 0.33f, 0.38f, 1}, kSteel{0.80f, 0.80f, 0.82f, 1};
constexpr Rgba kHousing{0.10f, 0.10f, 0.12f, 1}, kWire{0.92f, 0.92f, 0.88f, 1}, kFloor{0.62f, 0.62f, 0.60f, 1};
constexpr Rgba kWall{0.86f, 0.86f, 0.84f, 1}, kSkin{0.87f, 0.74f, 0.62f, 1}, kShirt{0.30f, 0.42f, 0.58f, 1};
constexpr Rgba kTrousers{0.22f, 0.22f, 0.26f, 1}, kStrap{0.12f, 0.18f, 0.32f, 1}, kCabinet{0.40f, 0.44f, 0.40f, 1};

/// Appends decor geoms to a scene (silently stops at maxgeom).
class Painter {
 public:
  explicit Painter(mjvScene& s) : s_(s) {}

  void connector(int type, double radius_m, V a, V b, const Rgba& rgba) {
    if (std::sqrt(dot(b - a, b - a)) < 1e-6) return;
    if (mjvGeom* g = next(rgba)) {
      mjv_makeConnector(g, type, radius_m, a[0], a[1], a[2], b[0], b[1], b[2]);
      commit();
    }
  }
  void capsule(V a, V b, double radius_m, const Rgba& rgba) { connector(mjGEOM_CAPSULE, radius_m, a, b, rgba); }
  void cylinder(V a, V b, double radius_m, const Rgba& rgba) { connector(mjGEOM_CYLINDER, radius_m, a, b, rgba); }
  /// A box from a to b (its z axis), `half_x` along `side` (made orthogonal) and `half_y` across.
  void bar(V a, V b, V side, double half_x, double half_y, const Rgba& rgba) {
    const V z = unit(b - a);
    const V x = unit(side - z * dot(side, z));
    const V y = cross(z, x);
    const double half_z = 0.5 * std::sqrt(dot(b - a, b - a));
    shape(mjGEOM_BOX, {half_x, half_y, half_z}, (a + b) * 0.5, x, y, z, rgba);
  }
  /// An axis-aligned box.
  void box(V centre, V half, const Rgba& rgba) { shape(mjGEOM_BOX, half, centre, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, rgba); }
  void sphere(V centre, double radius_m, const Rgba& rgba) {
    shape(mjGEOM_SPHERE, {radius_m, radius_m, radius_m}, centre, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, rgba);
  }
  /// A plane through `centre` spanned by x and y (half sizes), facing x cross y.
  void plane(V centre, V x, V y, double half_x, double half_y, const Rgba& rgba) {
    shape(mjGEOM_PLANE, {half_x, half_y, 1}, centre, x, y, cross(x, y), rgba);
  }
  /// A tube along the cubic Bezier p0..p3 (the Bowden cable's outer housing), as a chain of capsules.
  void tube(V p0, V p1, V p2, V p3, double radius_m, const Rgba& rgba) {
    constexpr int kSegments = 14;
    V prev = p0;
    for (int i = 1; i <= kSegments; ++i) {
      const double t = static_cast<double>(i) / kSegments, u = 1 - t;
      const V p = p0 * (u * u * u) + p1 * (3 * u * u * t) + p2 * (3 * u * t * t) + p3 * (t * t * t);
      capsule(prev, p, radius_m, rgba);
      prev = p;
    }
  }

 private:
  mjvGeom* next(const Rgba& rgba) {
    if (s_.ngeom >= s_.maxgeom) return nullptr;
    mjvGeom* g = s_.geoms + s_.ngeom;
    mjv_initGeom(g, mjGEOM_NONE, nullptr, nullptr, nullptr, rgba.data());
    return g;
  }
  void commit() {
    s_.geoms[s_.ngeom].category = mjCAT_DECOR;
    ++s_.ngeom;
  }
  void shape(int type, V size, V pos, V x, V y, V z, const Rgba& rgba) {
    const mjtNum mat[9] = {x[0], y[0], z[0], x[1], y[1], z[1], x[2], y[2], z[2]};
    if (mjvGeom* g = next(rgba)) {
      mjv_initGeom(g, type, size.data(), pos.data(), mat, rgba.data());
      commit();
    }
  }
  mjvScene& s_;
};

double finite_or(double v, double fallback) { return std::isfinite(v) ? v : fallback; }

/// A muscle standing on its base at `base` (z up): end caps, and the braided body between them
/// whose length is L0 (1 - u) and whose girth grows as it shortens; returns its free (top) end.
V draw_muscle(Painter& p, V base, const MuscleLook& look, const MuscleState& state, double supply_MPa) {
  const double u = std::clamp(finite_or(state.contraction, 0.0), -0.1, 0.45);
  const double length_m = look.rest_length_m * (1 - u);
  const double radius_m = 0.5 * look.diameter_m * (1 + 1.2 * std::max(u, 0.0));
  const double cap_m = 0.03, cap_radius_m = 0.5 * look.diameter_m + 0.006;
  const V up{0, 0, 1};
  const V bottom = base + up * cap_m, top = bottom + up * length_m;
  p.cylinder(base, bottom, cap_radius_m, kSteel);
  p.capsule(bottom + up * radius_m, top - up * radius_m, radius_m, pressure_rgba(finite_or(state.pressure_MPa, 0.0), supply_MPa));
  p.cylinder(top, top + up * cap_m, cap_radius_m, kSteel);
  return top + up * cap_m;
}

/// The muscles of `joints` standing in a row along `row` from `first`, on a base, with the
/// housings' stops on a crossbar above the longest; each inner wire runs up from its muscle to
/// the stop, each housing from the stop to its joint's pulley (tangent point, leaving along
/// `away[j]`, the wire's side `side[j]`).
struct Route {
  V tangent_plus, tangent_minus;  ///< where the agonist's / antagonist's wire leaves the pulley
  V away;                         ///< direction in which the wires leave the pulley towards the housing
};
void draw_bank(Painter& p, V first, V row, double spacing_m, const std::vector<JointMuscles>& joints, const std::vector<Route>& routes,
               double supply_MPa) {
  double longest_m = 0;
  for (const JointMuscles& j : joints) {
    for (const MuscleLook& m : j.look.muscle) longest_m = std::max(longest_m, m.rest_length_m);
  }
  const double bar_z = first[2] + 0.12 + 1.1 * longest_m;
  const std::size_t n = 2 * joints.size();
  const V last = first + row * (spacing_m * static_cast<double>(n - 1));
  const V margin = row * 0.06;
  // Base plate and the rack: two posts and the crossbar that holds the housings' stops.
  p.bar(first - margin - V{0, 0, 0.04}, last + margin - V{0, 0, 0.04}, {0, 0, 1}, 0.04, 0.07, kDarkFrame);
  p.bar(first - margin, first - margin + V{0, 0, bar_z - first[2]}, {1, 0, 0}, 0.015, 0.015, kDarkFrame);
  p.bar(last + margin, last + margin + V{0, 0, bar_z - first[2]}, {1, 0, 0}, 0.015, 0.015, kDarkFrame);
  p.bar(first - margin + V{0, 0, bar_z - first[2]}, last + margin + V{0, 0, bar_z - first[2]}, {0, 0, 1}, 0.015, 0.025, kDarkFrame);
  for (std::size_t j = 0; j < joints.size(); ++j) {
    for (int m = 0; m < 2; ++m) {
      const V base = first + row * (spacing_m * static_cast<double>(2 * j + static_cast<std::size_t>(m)));
      const V top = draw_muscle(p, base, joints[j].look.muscle[static_cast<std::size_t>(m)], joints[j].muscle[static_cast<std::size_t>(m)],
                                supply_MPa);
      const V stop = V{base[0], base[1], bar_z};
      p.capsule(top, stop, 0.0015, kWire);
      p.cylinder(stop - V{0, 0, 0.01}, stop + V{0, 0, 0.02}, 0.008, kSteel);
      const V tangent = m == 0 ? routes[j].tangent_plus : routes[j].tangent_minus;
      const V near = tangent + routes[j].away * 0.08;
      p.capsule(near, tangent, 0.0015, kWire);
      p.tube(stop + V{0, 0, 0.02}, stop + V{0, 0, 0.35}, near + routes[j].away * 0.3, near, 0.005, kHousing);
    }
  }
}

/// Where a joint's wires leave its pulley (centre `centre`, on the parent body's frame): on the
/// parent's +z / -z side, leaving towards the parent's -x; the agonist on the side whose pull
/// turns the joint positive.
Route pulley_route(const mjModel* m, const mjData* d, int joint, V centre, double radius_m) {
  const int parent = m->body_parentid[m->jnt_bodyid[joint]];
  const double* R = d->xmat + 9 * parent;
  const V x = column(R, 0), y = column(R, 1), z = column(R, 2);
  // A pull along -x at +z r gives the torque r z x (-x) = -r y: positive about the axis if -y . axis > 0.
  const double side = dot(y * -1.0, at(d->xaxis + 3 * joint)) > 0 ? 1.0 : -1.0;
  return {centre + z * (side * radius_m), centre - z * (side * radius_m), x * -1.0};
}

void draw_rig(const mjModel* m, const mjData* d, const std::vector<JointMuscles>& joints, Painter& p, double supply_MPa) {
  if (joints.empty() || joints[0].joint_id < 0) return;
  const JointMuscles& j = joints[0];
  const V c = at(d->xanchor + 3 * j.joint_id);
  const V behind = unit(at(d->xaxis + 3 * j.joint_id)) * -1.0;  // away from the side camera
  const double r = j.look.pulley_radius_m;
  // Floor, backdrop, and the stand under the model's post (which ends 0.22 m below the joint).
  p.plane({c[0], c[1], 0}, {1, 0, 0}, {0, 1, 0}, 2.5, 2.5, kFloor);
  p.plane(c + behind * 0.9 - V{0, 0, c[2] - 1.5}, {1, 0, 0}, {0, 0, 1}, 2.5, 1.5, kWall);
  p.bar({c[0] - 0.06, c[1], 0}, {c[0] - 0.06, c[1], c[2] - 0.22}, {1, 0, 0}, 0.03, 0.03, kDarkFrame);
  p.box({c[0] - 0.06, c[1], 0.01}, {0.22, 0.18, 0.01}, kDarkFrame);
  // The cable drum beside the model's pulley, where both wires wrap.
  const V drum = c + behind * 0.06;
  p.cylinder(c + behind * 0.015, drum + behind * 0.015, r, kAluminium);
  Route route = pulley_route(m, d, j.joint_id, drum, r);
  p.box(drum + route.away * 0.13, {0.01, 0.02, r + 0.03}, kDarkFrame);  // housing bracket
  draw_bank(p, {c[0] - 0.62, drum[1], 0.09}, {1, 0, 0}, 0.16, joints, {route}, supply_MPa);
}

bool ends_with(std::string_view s, std::string_view tail) { return s.size() >= tail.size() && s.substr(s.size() - tail.size()) == tail; }

/// Length of a welded body along its x axis: to the next joint's body of its carrier, else twice its COM.
double segment_length(const mjModel* m, int body) {
  const int carrier = m->body_parentid[body];
  for (int b = 0; b < m->nbody; ++b) {
    if (b != body && m->body_parentid[b] == carrier && m->body_jntnum[b] > 0) return std::sqrt(dot(at(m->body_pos + 3 * b), at(m->body_pos + 3 * b)));
  }
  return std::max(0.05, 2 * m->body_ipos[3 * body]);
}

void draw_arm(const mjModel* m, const mjData* d, const std::vector<JointMuscles>& joints, Painter& p, double supply_MPa) {
  // The shoulders: joints whose body hangs on the world; the torso between them (one arm: beside it).
  std::vector<std::pair<V, bool>> shoulders;  // anchor, left side
  for (int j = 0; j < m->njnt; ++j) {
    if (m->body_parentid[m->jnt_bodyid[j]] != 0) continue;
    const char* name = mj_id2name(m, mjOBJ_JOINT, j);
    const bool left = name && name[0] == 'L' && name[1] == '_';
    shoulders.emplace_back(at(d->xanchor + 3 * j), left);
  }
  if (shoulders.empty()) return;
  constexpr double kHalfShoulders_m = 0.19, kExoOffset_m = 0.075;
  V centre{0, 0, 0};
  for (const auto& s : shoulders) centre = centre + s.first * (1.0 / static_cast<double>(shoulders.size()));
  if (shoulders.size() == 1) centre[1] += shoulders[0].second ? -kHalfShoulders_m : kHalfShoulders_m;
  const double shoulder_z = centre[2];
  auto outward = [&](V p_world) { return V{0, p_world[1] >= centre[1] ? 1.0 : -1.0, 0}; };

  // Room, person, the arm that wears no exoskeleton (one-armed models).
  p.plane({centre[0], centre[1], 0}, {1, 0, 0}, {0, 1, 0}, 3, 3, kFloor);
  p.plane({centre[0] - 1.2, centre[1], 1.5}, {0, 1, 0}, {0, 0, 1}, 3, 1.5, kWall);
  p.plane({centre[0], centre[1] + 1.3, 1.5}, {1, 0, 0}, {0, 0, 1}, 3, 1.5, kWall);
  p.box({centre[0] - 0.02, centre[1], shoulder_z - 0.27}, {0.11, kHalfShoulders_m - 0.03, 0.29}, kShirt);
  p.capsule({centre[0], centre[1], shoulder_z}, {centre[0], centre[1], shoulder_z + 0.12}, 0.045, kSkin);
  p.sphere({centre[0], centre[1], shoulder_z + 0.24}, 0.105, kSkin);
  for (double side : {-1.0, 1.0}) {
    p.capsule({centre[0], centre[1] + side * 0.09, shoulder_z - 0.6}, {centre[0], centre[1] + side * 0.09, 0.08}, 0.07, kTrousers);
  }
  if (shoulders.size() == 1) {
    const V other{shoulders[0].first[0], 2 * centre[1] - shoulders[0].first[1], shoulder_z};
    p.capsule(other, other - V{0, 0, 0.58}, 0.042, kSkin);
  }

  // The person's arm segments, the exoskeleton's links beside them, the straps between.
  for (int b = 1; b < m->nbody; ++b) {
    const std::string_view name = mj_id2name(m, mjOBJ_BODY, b) ? mj_id2name(m, mjOBJ_BODY, b) : "";
    const bool user = name.find("user_") != std::string_view::npos, exo = name.find("exo_") != std::string_view::npos;
    if (!user && !exo) continue;
    const V o = at(d->xpos + 3 * b), x = column(d->xmat + 9 * b, 0);
    const double length_m = segment_length(m, b);
    const V side = outward(o) * kExoOffset_m;
    if (exo) {
      p.bar(o + side, o + side + x * length_m, outward(o), 0.008, 0.016, kAluminium);
      continue;
    }
    const double radius_m = ends_with(name, "upper_arm") ? 0.045 : ends_with(name, "forearm") ? 0.036 : 0.028;
    p.capsule(o + x * (ends_with(name, "hand") ? 0.02 : 0.0), o + x * length_m, radius_m, kSkin);
    if (ends_with(name, "hand")) continue;
    const V mid = o + x * (0.55 * length_m);
    p.cylinder(mid - x * 0.025, mid + x * 0.025, radius_m + 0.006, kStrap);
    p.bar(mid + outward(o) * radius_m, mid + side, x, 0.02, 0.006, kStrap);
  }

  // Pulleys (and each PEHA joint's motor) beside the joints; the controller unit behind the person.
  std::vector<Route> routes;
  for (const JointMuscles& j : joints) {
    if (j.joint_id < 0) {
      routes.push_back({});
      continue;
    }
    const V c = at(d->xanchor + 3 * j.joint_id);
    const V out = outward(c);
    const V pulley = c + out * kExoOffset_m;
    p.cylinder(pulley - out * 0.012, pulley + out * 0.012, j.look.pulley_radius_m, kAluminium);
    p.cylinder(pulley + out * 0.012, pulley + out * 0.07, 0.018, kDarkFrame);
    routes.push_back(pulley_route(m, d, j.joint_id, pulley, j.look.pulley_radius_m));
  }
  std::vector<JointMuscles> drawn;
  std::vector<Route> drawn_routes;
  for (std::size_t k = 0; k < joints.size(); ++k) {
    if (joints[k].joint_id >= 0) drawn.push_back(joints[k]), drawn_routes.push_back(routes[k]);
  }
  if (drawn.empty()) return;
  constexpr double kSpacing_m = 0.085;
  const double width_m = kSpacing_m * static_cast<double>(2 * drawn.size() - 1);
  const V first{centre[0] - 0.6, centre[1] - 0.5 * width_m, 0.32};
  p.box({first[0], centre[1], 0.14}, {0.14, 0.5 * width_m + 0.1, 0.14}, kCabinet);
  draw_bank(p, first, {0, 1, 0}, kSpacing_m, drawn, drawn_routes, supply_MPa);
}

}  // namespace

std::array<float, 4> pressure_rgba(double pressure_MPa, double supply_MPa) noexcept {
  const double f = supply_MPa > 0 && std::isfinite(pressure_MPa) ? std::clamp(pressure_MPa / supply_MPa, 0.0, 1.0) : 0.0;
  // grey-blue (vented) -> amber (half) -> red (supply)
  constexpr std::array<std::array<float, 3>, 3> stops{{{0.55f, 0.62f, 0.75f}, {0.98f, 0.72f, 0.15f}, {0.90f, 0.10f, 0.08f}}};
  const std::size_t i = f < 0.5 ? 0 : 1;
  const float w = static_cast<float>(f < 0.5 ? 2 * f : 2 * f - 1);
  std::array<float, 4> rgba{0, 0, 0, 1};
  for (std::size_t k = 0; k < 3; ++k) rgba[k] = stops[i][k] + w * (stops[i + 1][k] - stops[i][k]);
  return rgba;
}

void add_machine_geoms(const mjModel* model, const mjData* data, MachineKind kind, double supply_MPa,
                       const std::vector<JointMuscles>& joints, mjvScene& scene) {
  Painter p(scene);
  if (kind == MachineKind::kRig) draw_rig(model, data, joints, p, supply_MPa);
  if (kind == MachineKind::kArm) draw_arm(model, data, joints, p, supply_MPa);
}

CameraPose machine_camera(const mjModel* m, const mjData* d, MachineKind kind) {
  CameraPose c;
  if (kind == MachineKind::kRig) {
    // From the side (Fig. 3a, 9c): the link, its payload and the muscles under it.
    const int j = m->njnt > 0 ? 0 : -1;
    const V a = j >= 0 ? at(d->xanchor) : V{0, 0, 1};
    c.lookat = {a[0] - 0.12, a[1], 0.58 * a[2]};
    c.distance_m = 2.05;
    c.azimuth_deg = 90;
    c.elevation_deg = -6;
    return c;
  }
  // From the front and the exoskeleton's side, slightly above (Fig. 10).
  V centre{0, 0, 0};
  int n = 0, left = 0;
  for (int j = 0; j < m->njnt; ++j) {
    if (m->body_parentid[m->jnt_bodyid[j]] != 0) continue;
    centre = centre + at(d->xanchor + 3 * j);
    const char* name = mj_id2name(m, mjOBJ_JOINT, j);
    left += name && name[0] == 'L' && name[1] == '_';
    ++n;
  }
  if (n > 0) centre = centre * (1.0 / n);
  c.lookat = {centre[0] - 0.15, centre[1], centre[2] - 0.45};
  c.distance_m = 2.9;
  c.azimuth_deg = n > 1 ? 160 : left ? 215 : 145;
  c.elevation_deg = -10;
  return c;
}

}  // namespace peha::video
