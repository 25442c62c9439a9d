"""Fixtures of the Python binding tests: the C++ reference results and a small calibration.

Run through ctest (test python.bindings), which sets PYTHONPATH to the built package, PEHA_BINARY
and PEHA_PY_REFERENCE (python/tests/reference.cpp) to the built executables.
"""
import json
import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
E1 = ROOT / "configs" / "e1_one_dof.yaml"
ARM = ROOT / "configs" / "right_arm.yaml"
# Small fits (seconds, not minutes): the same code path as the defaults.
CAL_OPTIONS = dict(restarts=8, threads=2, pseudo_inputs=12, spgp_iterations=40, seed=3)


def _exe(var):
    path = os.environ.get(var)
    if not path or not pathlib.Path(path).exists():
        pytest.skip(f"{var} not set: run through ctest (test python.bindings)")
    return path


@pytest.fixture(scope="session")
def calibration_files(tmp_path_factory):
    """A recorded calibration CSV and `peha calibrate`'s YAML of it (small options)."""
    peha = _exe("PEHA_BINARY")
    d = tmp_path_factory.mktemp("cal")
    csv = d / "agonist.csv"
    subprocess.run([peha, "record-calibration", "--config", str(E1), "--muscle", "agonist", "--out", str(csv)],
                   check=True, capture_output=True)
    yaml = d / "agonist.yaml"
    o = CAL_OPTIONS
    subprocess.run([peha, "calibrate", str(csv), "--muscle", "agonist", "--out", str(yaml), "--no-plot",
                    "--restarts", str(o["restarts"]), "--threads", str(o["threads"]),
                    "--pseudo-inputs", str(o["pseudo_inputs"]), "--spgp-iterations", str(o["spgp_iterations"]),
                    "--seed", str(o["seed"])], check=True, capture_output=True)
    return csv, yaml


@pytest.fixture(scope="session")
def ref(calibration_files):
    """Every reference value computed by the C++ API (peha_py_reference)."""
    exe = _exe("PEHA_PY_REFERENCE")
    out = subprocess.run([exe, str(E1), str(ARM), str(calibration_files[1])], check=True, capture_output=True, text=True)
    return json.loads(out.stdout)
