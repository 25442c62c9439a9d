#pragma once
/// \file
/// Identification of an arm's gravity parameters from static joint torques (docs/identification.md).
///
/// Each sample is a posture q at rest and the joint torques that held it, measured by the rig. The
/// regressor (models/gravity_parameters.hpp) makes the torques linear in the parameters theta, so the
/// fit is linear least squares. Joint torques never see every parameter (a serial arm's gravity has
/// fewer base parameters than 4 per frame), so the fit starts from a prior (the nominal model) and
/// changes it only along the directions the data determine: delta = argmin |Y delta - (tau - Y theta0)|
/// with the least (column-scaled) norm, a rank-revealing complete orthogonal decomposition. Directions
/// the data do not see keep the prior, and so do the frames that carry no body in the prior (frames
/// sharing an origin, as the wrist's three joints do, would otherwise share one body's mass).
///
/// An identification is refused (GravityIdentificationRejected) when the fit cannot be trusted: a
/// residual above max_residual_rms_Nm and above a fraction of the measurements' own uncertainty, or an identified gravity torque that differs from the prior's
/// by more than max_change_fraction at a sample where the prior's exceeds min_torque_Nm (a wrong
/// lever, sign or channel), or a frame whose mass is not positive.

#include "peha/config/reader.hpp"
#include "peha/models/arm.hpp"

#include <Eigen/Dense>

#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

namespace peha::calibration {

/// One static posture: the joint angles (rad, every model joint) and the measured holding torque of
/// each identified joint (Nm, in the order of GravityIdentificationOptions::joints).
struct GravitySample {
  std::string name;
  Eigen::VectorXd q_rad;
  Eigen::VectorXd tau_Nm;
  /// Optional, per joint: how uncertain each torque is (Nm, > 0; e.g. half the friction band the two
  /// approaches found). Rows are weighted by its inverse; empty: every row weighs the same.
  Eigen::VectorXd uncertainty_Nm;
};

struct GravityIdentificationOptions {
  std::vector<int> joints = {0, 1};     ///< model joints whose torque is measured (R_SFE, R_EFE)
  /// Directions whose singular value is below this x the largest keep the prior: the data barely see
  /// them (e.g. how the forearm's and the hand's first moments split when the wrist hardly moves),
  /// and fitting them would fit the measurement's noise.
  double rank_tolerance = 1e-6;
  double max_residual_rms_Nm = 0.5;     ///< refuse a fit whose RMS residual is larger than this ...
  /// ... and larger than this x the RMS of the samples' uncertainty_Nm (a rig with more friction
  /// measures each torque less precisely; its residual is judged against that).
  double max_residual_uncertainty_fraction = 0.25;
  double max_change_fraction = 0.3;     ///< refuse a fit that moves a torque by more than this vs the prior
  double min_torque_Nm = 2.0;           ///< ... at samples where the prior's |torque| is at least this
};

struct GravityIdentification {
  std::vector<int> joints;        ///< the model joints whose torques were measured (the options'), in the samples' order
  Eigen::VectorXd prior;          ///< theta0: the nominal model's parameters
  Eigen::VectorXd theta;          ///< identified parameters
  Eigen::VectorXd std;            ///< per parameter, from the residual and the (pseudo-)inverse of Y^T Y; 0 where not identified
  std::vector<std::string> names; ///< per parameter
  int rank = 0;                   ///< identified directions (base parameters the data determine)
  Eigen::VectorXd singular_values;///< of the column-scaled regressor, largest first (rank: those >= rank_tolerance x the largest)
  int rows = 0;                   ///< torque equations (samples x joints)
  double residual_rms_Nm = 0;     ///< RMS of tau - Y theta over every row
  double residual_max_Nm = 0;
  double uncertainty_rms_Nm = 0;  ///< RMS of the samples' uncertainty_Nm (0: none given)
  double prior_rms_Nm = 0;        ///< RMS of tau - Y theta0: how far the nominal model was
  double max_change_fraction = 0; ///< largest |Y theta - Y theta0| / |Y theta0| over rows with |Y theta0| >= min_torque_Nm
  Eigen::MatrixXd predicted_Nm;   ///< samples x joints: Y theta
  Eigen::MatrixXd prior_Nm;       ///< samples x joints: Y theta0
};

class GravityIdentificationRejected : public std::runtime_error {
 public:
  explicit GravityIdentificationRejected(const std::string& what) : std::runtime_error(what) {}
};

/// Fits theta to `samples` from the prior `nominal` (its kinematics and bodies). Throws
/// GravityIdentificationRejected when a check above fails, std::invalid_argument on malformed samples.
GravityIdentification identify_gravity(const models::ArmModel& nominal, const std::vector<GravitySample>& samples,
                                       const GravityIdentificationOptions& options);

/// The identification file (YAML): the parameters by name with their std, the fit's figures and the
/// samples. Written through a temporary and a rename (config/atomic_file.hpp).
void write_gravity_identification(const std::filesystem::path& path, const models::ArmModel& nominal,
                                  const std::vector<GravitySample>& samples, const GravityIdentification& fit,
                                  const std::string& provenance);

/// Reads an identification file for the arm `nominal` (joint names must match) and returns `nominal`
/// with the identified parameters (models::with_gravity_parameters). Throws config::Error.
models::ArmModel read_gravity_identification(const config::Document& doc, const models::ArmModel& nominal);

}  // namespace peha::calibration
