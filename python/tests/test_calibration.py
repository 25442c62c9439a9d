"""Calibration from Python: the same fit as `peha calibrate`, files, prediction against C++."""
import numpy as np
import pytest

import peha
from conftest import CAL_OPTIONS

TOL = dict(rtol=1e-12, atol=1e-12)


def test_read_dataset(calibration_files):
    data = peha.read_dataset(calibration_files[0])
    assert len(data) == data.pressure_Pa.size == data.force_N.size == data.contraction.size > 1000
    assert data.pressure_Pa.max() < 1e6 and data.pressure_Pa.max() > 1e5  # MPa in the file, Pa here
    assert len(data.sha256) == 64


def test_bad_dataset_raises_value_error(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("pressure_MPa,contraction,force_N\n0.1,0.0,abc\n")
    with pytest.raises(ValueError, match="bad.csv"):
        peha.read_dataset(bad)


def test_load_and_predict_match_cpp(ref, calibration_files):
    cal = peha.Calibration.load(calibration_files[1])
    assert cal.muscle == "agonist" and cal.has_spgp and cal.num_pseudo == CAL_OPTIONS["pseudo_inputs"]
    p = cal.params
    np.testing.assert_array_equal([p.a_N_per_Pa, p.b_N_per_Pa, p.c_N_per_Pa, p.k_N, p.eps0], ref["cal_params"])
    mean, std = cal.predict(ref["cal_eps"], ref["cal_force_N"], 0.8e6)
    np.testing.assert_allclose(mean, ref["cal_mean_Pa"], **TOL)
    np.testing.assert_allclose(std, ref["cal_std_Pa"], **TOL)
    assert np.all(np.asarray(std) >= 0)


def test_calibrate_in_python_equals_peha_calibrate(calibration_files, tmp_path):
    csv, yaml = calibration_files
    result = peha.calibrate(csv, muscle="agonist", **CAL_OPTIONS)
    cli = peha.Calibration.load(yaml)
    mine = result.calibration
    a, b = mine.params, cli.params
    np.testing.assert_allclose([a.a_N_per_Pa, a.b_N_per_Pa, a.c_N_per_Pa, a.k_N, a.eps0],
                               [b.a_N_per_Pa, b.b_N_per_Pa, b.c_N_per_Pa, b.k_N, b.eps0], **TOL)
    assert mine.stats["rows_heldout"] == cli.stats["rows_heldout"] > 0
    np.testing.assert_allclose(mine.stats["heldout_rms_spgp_Pa"], cli.stats["heldout_rms_spgp_Pa"], **TOL)
    # Saved and loaded back: the same predictions.
    result.save(tmp_path / "py.yaml")
    back = peha.Calibration.load(tmp_path / "py.yaml")
    data = result.data
    m1, s1 = back.predict(data.contraction, data.force_N)
    m2, s2 = cli.predict(data.contraction, data.force_N)
    np.testing.assert_allclose(m1, m2, **TOL)
    np.testing.assert_allclose(s1, s2, **TOL)
    # The per-row outcome: SPGP std as predict() gives it; held-out rows as the split says.
    np.testing.assert_allclose(result.spgp_std_Pa, s1, **TOL)
    assert result.heldout.sum() == mine.stats["rows_heldout"]
    report = tmp_path / "report"
    result.write_report(report, plot=False)
    assert (report / "predictions.csv").exists() and (report / "summary.txt").exists()


def test_result_rows_and_muscle_model_agree_with_predict(calibration_files):
    result = peha.calibrate(calibration_files[0], muscle="agonist", **CAL_OPTIONS)
    cal, data = result.calibration, result.data
    eps, F = data.contraction, data.force_N
    mean, _ = cal.predict(eps, F)
    # The SPGP's share of each row is the same in the per-row outcome and in predict().
    inverse = peha.inverse_pressure(cal.params, F, eps)
    ok = (peha.inverse_status(cal.params, F, eps) == int(peha.InverseStatus.OK)) & (mean > 0)
    assert ok.mean() > 0.9
    np.testing.assert_allclose((mean - inverse)[ok], (result.pressure_spgp_Pa - result.pressure_parametric_Pa)[ok],
                               rtol=0, atol=1e-6)
    # The parametric rows are F / g(u), the inverse model's value (the fit's own arithmetic, in MPa).
    np.testing.assert_allclose(result.pressure_parametric_Pa[ok], inverse[ok], rtol=1e-12, atol=1e-6)
    # A MuscleModel with the calibration applied is the same pressure model.
    m = cal.muscle_model()
    assert m.has_residual and not cal.muscle_model(with_spgp=False).has_residual
    np.testing.assert_array_equal(peha.muscle_pressure(m, F, eps, 0.8e6), cal.predict(eps, F, 0.8e6)[0])
