#include "peha/app/calibration_report.hpp"

#include "peha/config/csv_sidecar.hpp"
#include "peha/experiments/run_request.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>

namespace peha::app {

void write_calibration_report(const std::filesystem::path& dir, const calibration::Dataset& data,
                              const calibration::CalibrationOutcome& outcome, bool plot, const ReportOperatingPoints& points) {
  std::filesystem::create_directories(dir);
  const calibration::MuscleCalibration& c = outcome.calibration;
  const calibration::CalibrationStats& s = c.stats;
  {
    const std::filesystem::path path = dir / "predictions.csv";
    const std::vector<std::string> columns = {"row", "t_s", "heldout", "contraction", "force_N", "pressure_MPa",
                                              "pressure_parametric_MPa", "pressure_spgp_MPa", "spgp_std_MPa"};
    config::remove_csv_sidecar(path);
    std::ofstream csv(path);
    csv << fmt::format("{}\n", fmt::join(columns, ","));
    for (std::size_t i = 0; i < data.size(); ++i) {
      csv << fmt::format("{},{:.6g},{},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}\n", i,
                         data.t_s.empty() ? static_cast<double>(i) : data.t_s[i], int(outcome.heldout[i]),
                         data.contraction[i], data.force_N[i], data.pressure_Pa[i] * 1e-6,
                         outcome.pressure_parametric_Pa[i] * 1e-6, outcome.pressure_spgp_Pa[i] * 1e-6,
                         outcome.spgp_std_Pa[i] * 1e-6);
    }
    csv.close();
    config::write_csv_sidecar(path, {columns, data.size(), {"peha calibrate: per-row predictions of " + data.source}, {}});
  }
  if (c.spgp) {
    // The SPGP's predictive band over (contraction, force): a grid 10 % beyond the data's ranges.
    std::ofstream grid(dir / "spgp_grid.csv");
    grid << "contraction,force_N,mean_MPa,std_MPa\n";
    const int n = 60;
    const double e_pad = 0.1 * (c.contraction.max - c.contraction.min), f_pad = 0.1 * (c.force_N.max - c.force_N.min);
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) {
        const double x[2] = {c.contraction.min - e_pad + (c.contraction.max - c.contraction.min + 2 * e_pad) * i / (n - 1),
                             c.force_N.min - f_pad + (c.force_N.max - c.force_N.min + 2 * f_pad) * j / (n - 1)};
        grid << fmt::format("{:.9g},{:.9g},{:.9g},{:.9g}\n", x[0], x[1], c.spgp->predict_mean(x) * 1e-6,
                            std::sqrt(std::max(c.spgp->predict_variance(x), 0.0)) * 1e-6);
      }
    }
    std::ofstream pseudo(dir / "pseudo_inputs.csv");
    pseudo << "contraction,force_N\n";
    const Eigen::MatrixXd& z = c.spgp->pseudo_inputs();
    for (Eigen::Index m = 0; m < z.rows(); ++m) {
      pseudo << fmt::format("{:.9g},{:.9g}\n", c.spgp->input_mean()[0] + c.spgp->input_scale()[0] * z(m, 0),
                            c.spgp->input_mean()[1] + c.spgp->input_scale()[1] * z(m, 1));
    }
  }
  if (points.check) {
    const int m = points.index;
    const std::filesystem::path path = dir / "operating_points.csv";
    const std::vector<std::string> columns = {"case", "angle_deg", "contraction", "force_cmd_N", "loadcell_N",
                                              "min_loadcell_N", "pressure_cmd_MPa", "spgp_mean_MPa", "spgp_std_MPa"};
    config::remove_csv_sidecar(path);
    std::ofstream csv(path);
    csv << fmt::format("{}\n", fmt::join(columns, ","));
    for (const experiments::AcceptancePoint& p : points.check->points) {
      const double x[2] = {p.contraction[m], p.force_cmd_N[m]};
      const double mean = c.spgp ? c.spgp->predict_mean(x) : 0.0;
      const double sd = c.spgp ? std::sqrt(std::max(c.spgp->predict_variance(x), 0.0)) : 0.0;
      csv << fmt::format("{},{:.3f},{:.6g},{:.4g},{:.4g},{:.4g},{:.6g},{:.6g},{:.6g}\n", p.case_name, p.angle_deg, p.contraction[m],
                         p.force_cmd_N[m], p.loadcell_N[m], p.min_loadcell_N[m], p.pressure_cmd_Pa[m] * 1e-6, mean * 1e-6, sd * 1e-6);
    }
    csv.close();
    config::write_csv_sidecar(path, {columns,
                                     points.check->points.size(),
                                     {"the closed-loop check's holds (calibration.acceptance of the scenario): where the controller worked"},
                                     {}});
  }
  std::ofstream txt(dir / "summary.txt");
  const std::string summary = fmt::format(
      "muscle {} from {} (sha256 {})\n"
      "rows: {} train, {} held out ({})\n"
      "Tendon-spring (LM on the pressure error, best of {} restarts, {} converged, {:.1f} s):\n"
      "  a = {:.6g} N/MPa, b = {:.6g} N/MPa, c = {:.6g} N/MPa, k = {:.6g} N, eps0 = {:.6g}\n"
      "SPGP residual: {}\n"
      "pressure RMS error      train      held out\n"
      "  parametric          {:7.2f} kPa  {:7.2f} kPa\n"
      "  parametric + SPGP   {:7.2f} kPa  {:7.2f} kPa\n"
      "input ranges seen: contraction {:.4f}..{:.4f}, force {:.1f}..{:.1f} N, pressure {:.3f}..{:.3f} MPa\n",
      c.muscle, c.data_file, c.data_sha256, s.rows_train, s.rows_heldout, outcome.split,
      s.restarts, s.restarts_converged, s.lm_seconds, c.params.a_N_per_Pa * 1e6, c.params.b_N_per_Pa * 1e6,
      c.params.c_N_per_Pa * 1e6, c.params.k_N, c.params.eps0,
      c.spgp ? fmt::format("M = {} pseudo-inputs, {} iterations, {:.1f} s, NLML {:.2f}", c.spgp->num_pseudo(),
                           c.spgp->iterations(), s.spgp_seconds, c.spgp->final_nlml())
             : std::string("off"),
      s.train_rms_parametric_Pa * 1e-3, s.heldout_rms_parametric_Pa * 1e-3, s.train_rms_spgp_Pa * 1e-3,
      s.heldout_rms_spgp_Pa * 1e-3, c.contraction.min, c.contraction.max, c.force_N.min, c.force_N.max,
      c.pressure_Pa.min * 1e-6, c.pressure_Pa.max * 1e-6);
  txt << summary;
  fmt::print("\n{}", summary);
  if (plot) experiments::plot_with("plot_calibration.py", dir);
}

}  // namespace peha::app
