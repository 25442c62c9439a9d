"""The examples run and say what they should (ctest python.examples)."""
import csv
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import peha

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import analyse_runs  # noqa: E402
import e1_python_gravity  # noqa: E402

E1 = HERE.parent / "configs" / "e1_one_dof.yaml"


def without_tare(tmp: pathlib.Path) -> pathlib.Path:
    """E1's scenario with the start-up tare off (tare_s: 0), beside links to the files it names.

    The Python controller of the example has no start-up tare and no limits stage (the shipped
    controller vents, tares and refills through the limits in its first 1.7 s), so the C++ run it is
    compared with is the same controller without the tare."""
    configs = tmp / "configs"
    configs.mkdir()
    for entry in E1.parent.iterdir():
        if entry.is_dir():
            (configs / entry.name).symlink_to(entry)
    (tmp / "models").symlink_to(E1.parent.parent / "models")
    text = E1.read_text()
    assert "tare_s: 0.5," in text
    copy = configs / E1.name
    copy.write_text(text.replace("tare_s: 0.5,", "tare_s: 0.0,"))
    return copy


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    peha_bin = os.environ.get("PEHA_BINARY")
    if not peha_bin:
        pytest.skip("PEHA_BINARY not set: run through ctest (test python.examples)")
    out = tmp_path_factory.mktemp("runs")
    config = without_tare(tmp_path_factory.mktemp("scenario"))
    for name, extra in (("a", []), ("b", ["--seed", "7"])):
        subprocess.run([peha_bin, "run", "--config", str(config), "--no-plot", "--out", str(out), "--name", name, *extra],
                       check=True, capture_output=True)
    return out / "a", out / "b"


def test_python_controller_reproduces_e1_hold(runs):
    """The hold of E1 under the Python controller: the same figures as the C++ run's summary and log."""
    with open(runs[0] / "summary.csv", newline="") as f:
        summary = {(r["case"], r["release"]): r for r in csv.DictReader(f)}
    for case in peha.Rig(str(E1)).cases:
        r = e1_python_gravity.run_hold(E1, case)
        c = e1_python_gravity.cpp_hold_figures(runs[0], r)
        for k in ("angle_at_release_deg", "drift_deg", "max_excursion_deg"):
            assert abs(r[k] - c[k]) < 1e-6, k  # the log's 9 digits
        ref = summary[(case, "hold")]  # rounded to 0.001 deg (angle) and 0.0001 deg (drift, excursion)
        assert abs(r["angle_at_release_deg"] - float(ref["angle_at_release_deg"])) <= 0.5e-3 + 1e-12
        assert abs(r["drift_deg"] - float(ref["drift_deg"])) <= 0.5e-4 + 1e-12
        assert abs(r["max_excursion_deg"] - float(ref["max_excursion_deg"])) <= 0.5e-4 + 1e-12
        assert abs(r["drift_deg"]) < 0.5  # E1's own bound (E1.LinkStaysWhereReleasedForBothPayloads)


def test_python_controller_log_matches_the_cpp_log(runs):
    log = peha.read_log(runs[0] / "e1_payload_5.0kg.csv")
    r = e1_python_gravity.run_hold(E1, "payload_5.0kg")
    n = r["t_s"].size
    np.testing.assert_allclose(r["t_s"], log["t_s"][:n], atol=1e-9)
    np.testing.assert_allclose(r["angle_deg"], np.degrees(log["plant_angle_rad"][:n]), rtol=1e-7, atol=1e-7)
    np.testing.assert_allclose(r["tau_motor_Nm"], log["tau_motor_cmd_Nm"][:n], rtol=1e-7, atol=1e-7)


def test_e1_example_prints_and_plots(runs, tmp_path, capsys):
    png = tmp_path / "e1.png"
    assert e1_python_gravity.main(["--case", "payload_2.5kg", "--compare", str(runs[0]),
                                   "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "payload_2.5kg" in out and "largest difference to the C++ run" in out
    assert png.stat().st_size > 10_000


def test_analyse_runs_fig9_fig8_and_comparison(runs, tmp_path):
    peha_bin = os.environ["PEHA_BINARY"]
    csv = tmp_path / "agonist.csv"
    subprocess.run([peha_bin, "record-calibration", "--config", str(E1), "--muscle", "agonist", "--out", str(csv)],
                   check=True, capture_output=True)
    peha.calibrate(csv, muscle="agonist", restarts=4, pseudo_inputs=10, spgp_iterations=30).save(tmp_path / "agonist.yaml")
    out = tmp_path / "analysis"
    assert analyse_runs.main([str(runs[0]), "--compare", str(runs[1]), "--calibration", str(csv),
                              str(tmp_path / "agonist.yaml"), "--out", str(out)]) == 0
    for png in ("fig9_a.png", "fig8_agonist.png", "compare.png"):
        assert (out / png).stat().st_size > 10_000, png
    rms = analyse_runs.fig8(csv, tmp_path / "agonist.yaml", out / "again.png")
    assert rms["rms_spgp_Pa"] <= rms["rms_parametric_Pa"]
    rows = analyse_runs.compare(runs[0], runs[1], out / "compare2.png")
    assert {r[0] for r in rows} == {"payload_2.5kg", "payload_5.0kg"}
    assert {r[1] for r in rows} == {"payload_2.5kg", "payload_5.0kg"}
    assert len(rows) == 2 * 3 * 4  # cases x releases x figures


def calibrated_like(run: pathlib.Path, tmp: pathlib.Path) -> pathlib.Path:
    """`run` as `make run`'s calibrated run names it: every case as <case>_parametric and <case>_spgp."""
    out = tmp / "e1_calibrated"
    out.mkdir()
    for log in run.glob("e1_*.csv"):
        for variant in ("_parametric", "_spgp"):
            (out / f"{log.stem}{variant}.csv").symlink_to(log)
    with open(run / "summary.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    with open(out / "summary.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        for variant in ("_parametric", "_spgp"):
            w.writerows({**r, "case": r["case"] + variant} for r in rows)
    (tmp / "latest").symlink_to(out.name)
    return out


def test_analyse_runs_compares_a_nominal_run_with_a_calibrated_one(runs, tmp_path, capsys):
    """The two runs `make run` writes: each case against its two variants, in the table and the figure;
    `out/latest` (a link to the calibrated run) as well; a folder that is no E1 run is refused."""
    calibrated = calibrated_like(runs[1], tmp_path)
    rows = analyse_runs.compare(runs[0], calibrated, tmp_path / "c.png")
    assert {(r[0], r[1]) for r in rows} == {(c, c + v) for c in ("payload_2.5kg", "payload_5.0kg") for v in ("_parametric", "_spgp")}
    assert len(rows) == 2 * 2 * 3 * 4  # cases x variants x releases x figures
    assert (tmp_path / "c.png").stat().st_size > 10_000
    # The same run seen through the link: same figures as in run B's own summary.
    out = tmp_path / "analysis"
    assert analyse_runs.main([str(runs[0]), "--compare", str(tmp_path / "latest"), "--out", str(out)]) == 0
    table = capsys.readouterr().out
    with open(runs[1] / "summary.csv", newline="") as f:
        hold = next(r for r in csv.DictReader(f) if r["case"] == "payload_2.5kg" and r["release"] == "hold")
    line = next(ln for ln in table.splitlines() if "payload_2.5kg_spgp" in ln and "hold" in ln and "drift_deg" in ln)
    assert abs(float(line.split()[-1]) - float(hold["drift_deg"])) <= 0.5e-3 + 1e-12  # the table prints 3 decimals
    assert (out / "compare.png").stat().st_size > 10_000
    for bad, says in ((tmp_path / "missing", "no such run directory"), (tmp_path, "no E1 logs")):
        assert analyse_runs.main([str(runs[0]), "--compare", str(bad), "--out", str(tmp_path / "refused")]) == 2
        assert says in capsys.readouterr().err
    assert not (tmp_path / "refused").exists()  # refused before anything is written
