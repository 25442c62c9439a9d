#pragma once
/// \file
/// What a clip draws besides the MuJoCo model's own geoms (docs/video.md, "The machine"): each
/// muscle as a body whose length follows its contraction and whose colour follows its pressure, the
/// Bowden cables from the muscles to the joints' pulleys, and the scenery that makes the picture
/// recognisable - the rig's stand and the muscles' base plate (paper Fig. 3a / 9c), or the person
/// wearing the arm exoskeleton with the controller unit behind (Fig. 10). Everything is an mjvScene
/// decor geom added per frame: the model, and so the physics, is never touched.

#include <mujoco/mujoco.h>

#include <array>
#include <string>
#include <vector>

namespace peha::video {

/// One muscle's size as built (the scenario's plant).
struct MuscleLook {
  double rest_length_m = 0.40;  ///< L0
  double diameter_m = 0.040;    ///< nominal inner diameter (DMSP-40: 40 mm)
};

/// A PEHA joint's actuators as drawn; defaults: the paper's rig (DMSP-40 400 mm agonist, DMSP-10
/// 600 mm antagonist, 35.5 mm pulley).
struct JointLook {
  std::string joint;                 ///< MuJoCo joint name
  double pulley_radius_m = 0.0355;
  std::array<MuscleLook, 2> muscle{MuscleLook{0.40, 0.040}, MuscleLook{0.60, 0.010}};  ///< agonist, antagonist
};

/// Which picture: none (the model alone), the one-DOF rig, or a person wearing the arm(s).
enum class MachineKind { kNone, kRig, kArm };

/// The scenario values the drawing needs (filled by the app from the run's config; a joint missing
/// from `joints` is drawn with JointLook's defaults).
struct MachineLook {
  MachineKind kind = MachineKind::kNone;
  double supply_pressure_MPa = 0.8;  ///< top of the pressure colour scale
  std::vector<JointLook> joints;
};

/// A muscle at one frame (NaN contraction: drawn at rest length; NaN pressure: drawn vented).
struct MuscleState {
  double contraction = 0;    ///< (L0 - L) / L0
  double pressure_MPa = 0;   ///< gauge
};

/// One actuated joint at one frame: which MuJoCo joint, its two muscles (agonist, antagonist).
struct JointMuscles {
  int joint_id = -1;
  JointLook look;
  std::array<MuscleState, 2> muscle;
};

/// The colour of a muscle at `pressure_MPa` on the scale 0 .. `supply_MPa`: grey-blue when vented,
/// amber at half supply, red at supply (clamped outside).
std::array<float, 4> pressure_rgba(double pressure_MPa, double supply_MPa) noexcept;

/// Adds the machine's geoms for the pose in `data` (after mj_kinematics) to `scene`, as far as
/// `scene.maxgeom` allows. `joints`: the actuated joints of this frame; `supply_MPa`: the top of
/// the pressure colour scale.
void add_machine_geoms(const mjModel* model, const mjData* data, MachineKind kind, double supply_MPa,
                       const std::vector<JointMuscles>& joints, mjvScene& scene);

/// Free-camera target, distance, azimuth and elevation that show the machine as the paper's
/// figures do: the rig from the side (Fig. 3a, 9c), the arm from the front-right (Fig. 10).
struct CameraPose {
  std::array<double, 3> lookat{0, 0, 1};
  double distance_m = 2.0;
  double azimuth_deg = 90;
  double elevation_deg = -8;
};
CameraPose machine_camera(const mjModel* model, const mjData* data, MachineKind kind);

}  // namespace peha::video
