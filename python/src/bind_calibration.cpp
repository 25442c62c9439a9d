// peha calibration for Python: calibration CSVs, the fit (LM restarts + SPGP, as `peha calibrate`),
// calibration files and the calibrated pressure model's prediction.
#include "bindings.hpp"

#include "peha/app/calibration_report.hpp"
#include "peha/calibration/calibrate.hpp"
#include "peha/calibration/calibration_file.hpp"
#include "peha/calibration/dataset.hpp"
#include "peha/models/joint.hpp"

#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cmath>
#include <limits>
#include <memory>

namespace peha::python {
namespace {

using calibration::CalibrationOutcome;
using calibration::Dataset;
using calibration::MuscleCalibration;

/// A fit's result: the calibration, the data it came from and the per-row predictions.
struct FitOutcome {
  Dataset data;
  CalibrationOutcome outcome;
};

py::dict stats_dict(const calibration::CalibrationStats& s) {
  py::dict d;
  d["rows_train"] = s.rows_train;
  d["rows_heldout"] = s.rows_heldout;
  d["restarts"] = s.restarts;
  d["restarts_converged"] = s.restarts_converged;
  d["lm_seconds"] = s.lm_seconds;
  d["spgp_seconds"] = s.spgp_seconds;
  d["train_rms_parametric_Pa"] = s.train_rms_parametric_Pa;
  d["train_rms_spgp_Pa"] = s.train_rms_spgp_Pa;
  d["heldout_rms_parametric_Pa"] = s.heldout_rms_parametric_Pa;
  d["heldout_rms_spgp_Pa"] = s.heldout_rms_spgp_Pa;
  return d;
}

/// Mean and std (Pa) of the calibrated pressure model at (eps, F): the parametric inverse (clamped
/// to [0, supply]) plus the SPGP's mean where the inverse is defined, exactly models::muscle_pressure;
/// std from the SPGP's predictive variance (0 without an SPGP).
py::tuple predict(const MuscleCalibration& c, const Array& eps, const Array& force, double supply) {
  const models::MuscleModel muscle = calibration::calibrated_muscle(c, true, models::MuscleModel{});
  py::object mean = py::vectorize([&muscle, supply](double e, double f) {
    return models::muscle_pressure(muscle, f, e, supply).pressure_Pa;
  })(eps, force);
  py::object std = py::vectorize([&c](double e, double f) {
    if (!c.spgp) return 0.0;
    const double x[2] = {e, f};
    return std::sqrt(std::max(c.spgp->predict_variance(x), 0.0));
  })(eps, force);
  return py::make_tuple(mean, std);
}

}  // namespace

void bind_calibration(py::module_& m) {
  py::class_<Dataset>(m, "Dataset", "A muscle's calibration data (SI inside): one row per sample.")
      .def_property_readonly("pressure_Pa", [](const Dataset& d) { return to_numpy(d.pressure_Pa); }, "gauge pressure, Pa")
      .def_property_readonly("contraction", [](const Dataset& d) { return to_numpy(d.contraction); }, "rigid-wire eps, -")
      .def_property_readonly("force_N", [](const Dataset& d) { return to_numpy(d.force_N); }, "load-cell force, N")
      .def_property_readonly("t_s", [](const Dataset& d) { return to_numpy(d.t_s); }, "time, s (empty if absent)")
      .def_property_readonly("angle_rad", [](const Dataset& d) { return to_numpy(d.angle_rad); }, "rad (empty if absent)")
      .def_property_readonly("wire_velocity_mps", [](const Dataset& d) { return to_numpy(d.wire_velocity_mps); },
                             "m/s (empty if absent)")
      .def_readonly("loadcell_zero_N", &Dataset::loadcell_zero_N,
                    "the load cell's reading with the muscle vented, N, already subtracted from force_N (the CSV's sidecar)")
      .def_readonly("source", &Dataset::source)
      .def_readonly("sha256", &Dataset::sha256)
      .def("__len__", &Dataset::size);
  m.def("read_dataset", [](const std::filesystem::path& path, std::size_t min_rows) {
    calibration::DatasetRules rules;
    rules.min_rows = min_rows;
    return calibration::read_dataset(path, rules);
  }, py::arg("path"), py::arg("min_rows") = 50,
        "Reads and validates a calibration CSV (pressure_MPa, contraction, force_N, ...); raises ValueError "
        "naming file, line and column.");
  py::register_exception<calibration::DataError>(m, "DataError", PyExc_ValueError);

  py::class_<MuscleCalibration>(m, "Calibration", "One muscle's calibration: Tendon-spring parameters and SPGP residual.")
      .def_static("load", &calibration::read_calibration, py::arg("path"), "Reads a calibration YAML (strict).")
      .def("save", [](const MuscleCalibration& c, const std::filesystem::path& p) { calibration::write_calibration(p, c); },
           py::arg("path"), "Writes the calibration YAML at full precision.")
      .def_readonly("muscle", &MuscleCalibration::muscle)
      .def_readonly("data_file", &MuscleCalibration::data_file)
      .def_readonly("data_sha256", &MuscleCalibration::data_sha256)
      .def_readonly("params", &MuscleCalibration::params, "the fitted TendonSpringParams (N/Pa)")
      .def_property_readonly("has_spgp", [](const MuscleCalibration& c) { return c.spgp != nullptr; })
      .def_property_readonly("num_pseudo", [](const MuscleCalibration& c) { return c.spgp ? c.spgp->num_pseudo() : 0; })
      .def_property_readonly("stats", [](const MuscleCalibration& c) { return stats_dict(c.stats); },
                             "fit statistics: rows, restarts, seconds, train/held-out pressure RMS (Pa)")
      .def("predict", &predict, py::arg("contraction"), py::arg("force_N"),
           py::arg("supply_pressure_Pa") = std::numeric_limits<double>::infinity(),
           "(mean_Pa, std_Pa) of the calibrated pressure model at rigid-wire contraction (-) and force (N): "
           "the inverse Tendon-spring pressure within [0, supply] plus the SPGP mean (as models::muscle_pressure), "
           "and the SPGP's predictive std (0 without SPGP). Arrays broadcast.")
      .def("muscle_model", [](const MuscleCalibration& c, bool with_spgp) {
        models::MuscleModel mm;
        mm.name = c.muscle;
        return calibration::calibrated_muscle(c, with_spgp, mm);
      }, py::arg("with_spgp") = true, "A MuscleModel with this calibration applied (other fields default).");

  py::class_<FitOutcome>(m, "CalibrationResult", "What calibrate() found, row by row over the dataset.")
      .def_property_readonly("calibration", [](const FitOutcome& f) { return f.outcome.calibration; })
      .def_readonly("data", &FitOutcome::data)
      .def_property_readonly("heldout", [](const FitOutcome& f) {
        py::array_t<bool> a(static_cast<py::ssize_t>(f.outcome.heldout.size()));
        for (std::size_t i = 0; i < f.outcome.heldout.size(); ++i) a.mutable_data()[i] = f.outcome.heldout[i] != 0;
        return a;
      }, "True where the row was held out")
      .def_property_readonly("split", [](const FitOutcome& f) { return f.outcome.split; })
      .def_property_readonly("pressure_parametric_Pa", [](const FitOutcome& f) { return to_numpy(f.outcome.pressure_parametric_Pa); })
      .def_property_readonly("pressure_spgp_Pa", [](const FitOutcome& f) { return to_numpy(f.outcome.pressure_spgp_Pa); })
      .def_property_readonly("spgp_std_Pa", [](const FitOutcome& f) { return to_numpy(f.outcome.spgp_std_Pa); })
      .def("save", [](const FitOutcome& f, const std::filesystem::path& p) {
        if (p.has_parent_path()) std::filesystem::create_directories(p.parent_path());
        calibration::write_calibration(p, f.outcome.calibration);
      }, py::arg("path"), "Writes the calibration YAML.")
      .def("write_report", [](const FitOutcome& f, const std::filesystem::path& dir, bool plot) {
        app::write_calibration_report(dir, f.data, f.outcome, plot);
      }, py::arg("dir"), py::arg("plot") = true,
           "The report folder of `peha calibrate`: predictions.csv, summary.txt and (plot) report.png.");

  m.def("calibrate", [](const std::filesystem::path& data_path, std::string muscle, int restarts, int threads,
                        int pseudo_inputs, int spgp_iterations, bool use_spgp, bool holdout, std::uint64_t seed,
                        std::size_t min_rows) {
    FitOutcome f;
    calibration::DatasetRules rules;
    rules.min_rows = min_rows;
    f.data = calibration::read_dataset(data_path, rules);
    // The same mapping of options as `peha calibrate` (src/app/calibrate_command.cpp).
    calibration::CalibrateOptions o;
    o.muscle = muscle.empty() ? data_path.stem().string() : muscle;
    o.fit.restarts = restarts;
    o.fit.threads = threads;
    o.fit.seed = seed;
    o.spgp.num_pseudo = pseudo_inputs;
    o.spgp.max_iterations = spgp_iterations;
    o.spgp.seed = seed;
    o.use_spgp = use_spgp;
    o.holdout = holdout;
    {
      py::gil_scoped_release release;
      f.outcome = calibration::calibrate(f.data, o);
    }
    return f;
  }, py::arg("data"), py::arg("muscle") = "", py::arg("restarts") = 300, py::arg("threads") = 2,
        py::arg("pseudo_inputs") = 50, py::arg("spgp_iterations") = 300, py::arg("use_spgp") = true,
        py::arg("holdout") = true, py::arg("seed") = 1, py::arg("min_rows") = 50,
        "Fits a muscle to a calibration CSV exactly as `peha calibrate` does (same options, same defaults): "
        "Tendon-spring parameters by LM (best of `restarts` on `threads`), SPGP with `pseudo_inputs` on the "
        "residual, time blocks 2 and 7 of 10 held out unless holdout=False. Returns a CalibrationResult.");
}

}  // namespace peha::python
