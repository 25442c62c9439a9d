#pragma once
/// \file
/// Parametric calibration (SPEC §3.2, paper §V-A): the five Tendon-spring parameters
/// lambda = (a, b, c, k, eps0) by Levenberg-Marquardt (Ceres' algorithm and settings, on fused 5 x 5
/// normal equations) on the PRESSURE error
///     r_i = P_i - F_i / g(eps_i + eps0 + F_i / k)
/// keeping the best of many random initialisations (the paper: 300), spread over threads.

#include "peha/models/tendon_spring.hpp"

#include <cstdint>
#include <functional>
#include <vector>

namespace peha::calibration {

struct FitOptions {
  int restarts = 300;            ///< random initialisations
  int threads = 2;               ///< worker threads running restarts in parallel
  std::uint64_t seed = 1;        ///< of the random initialisations (deterministic for a seed)
  int max_iterations = 200;      ///< per LM solve
};

/// Data for the fit: equal-length arrays (eps = rigid-wire contraction).
struct FitData {
  std::vector<double> contraction;
  std::vector<double> force_N;
  std::vector<double> pressure_Pa;
};

struct FitResult {
  models::TendonSpringParams params;  ///< the best restart's parameters
  double rms_pressure_Pa = 0;         ///< RMS pressure error of `params` on the fit data
  double best_cost = 0;               ///< cost 0.5 * sum r^2 (r in MPa), as Ceres defines it
  int restarts_run = 0;
  int restarts_converged = 0;         ///< restarts that met a convergence test (Ceres' three tolerances)
  double seconds = 0;                 ///< wall time of all restarts
};

/// Called after each restart with (done, total); may be called from worker threads, serialised.
using Progress = std::function<void(int done, int total)>;

/// Fewest rows the fit takes: one per Tendon-spring parameter (a, b, c, k, eps0).
inline constexpr std::size_t kMinFitRows = 5;

/// Fits; throws std::invalid_argument for empty/mismatched data or bad options, DataError (dataset.hpp)
/// when no restart reaches a finite cost (data no Tendon-spring model fits).
FitResult fit_tendon_spring(const FitData& data, const FitOptions& options, const Progress& progress = {});

/// Pressure residuals r_i (Pa) of `params` on `data` (the same definition the fit minimises).
std::vector<double> pressure_residuals_Pa(const models::TendonSpringParams& params, const FitData& data);

}  // namespace peha::calibration
