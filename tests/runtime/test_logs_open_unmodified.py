"""The CSVs peha writes open unmodified in numpy and pandas (issue 32): the header is the first
line, so numpy.genfromtxt(path, delimiter=",", names=True) and pandas.read_csv(path) give the
header's column names, every row, and the numbers peha wrote. Run through ctest
(runtime.logs_open_unmodified), which sets PYTHONPATH to the built module and PEHA_BINARY.

"What peha wrote" is checked three ways: against values known before the file existed (the
torques a Python controller returned, the times peha handed it), against the file's own text
parsed cell by cell, and against the sidecar <csv>.meta.json (columns, rows, the load-cell zero).
"""
import csv
import json
import math
import os
import pathlib
import subprocess

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
E1 = ROOT / "configs" / "e1_one_dof.yaml"
ARM = ROOT / "configs" / "right_arm.yaml"

try:
    import pandas
except ImportError:  # a failure, not a skip: scripts/install-deps.sh installs python3-pandas
    pandas = None


def peha_binary():
    path = os.environ.get("PEHA_BINARY")
    if not path:
        pytest.skip("PEHA_BINARY not set: run through ctest (test runtime.logs_open_unmodified)")
    return path


def sidecar(path):
    with open(str(path) + ".meta.json", encoding="utf-8") as f:
        meta = json.load(f)
    assert meta["format"] == "peha-log-1" and meta["file"] == path.name
    return meta


def opened_unmodified(path, meta):
    """The file as numpy and pandas read it with no option beyond the delimiter, checked to have
    the sidecar's column names (which are the header line's) and row count."""
    assert pandas is not None, "pandas is missing: run scripts/install-deps.sh (python3-pandas)"
    names = [c["name"] for c in meta["columns"]]
    assert path.read_text().split("\n", 1)[0] == ",".join(names)  # the first line is the header
    a = np.genfromtxt(path, delimiter=",", names=True)
    df = pandas.read_csv(path)
    assert list(a.dtype.names) == names
    assert list(df.columns) == names
    assert a.shape == (meta["rows"],) and len(df) == meta["rows"]
    return a, df


def text_values(path):
    """Every cell of the file's text as float, column by column (Python's correctly rounded parse)."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return {name: np.array([float(r[i]) for r in rows[1:]]) for i, name in enumerate(rows[0])}


def assert_same_numbers(got, want, what, rtol=0.0):
    """Equal (NaN where NaN), or within `rtol` of the wanted value."""
    both_nan = np.isnan(got) & np.isnan(want)
    same = (np.abs(got - want) <= rtol * np.abs(want)) | both_nan
    assert same.all(), f"{what}: row {int(np.argmin(same))}: {got[~same][:3]!r} vs {want[~same][:3]!r}"


# pandas' default float parser (its fast "high" precision one) is not correctly rounded: on E1's
# time column, written with up to 17 digits (0.005000000000000001), it lands up to 7 units in the
# last place off (1.2e-15 relative). 4e-15 allows that and still sees any formatting error (9
# significant digits are 1e-9); float_precision="round_trip" gives the exact doubles, which a
# replay of the time column needs.
PANDAS_DEFAULT_RTOL = 4e-15


def assert_pandas_numbers(path, df, name, want):
    assert_same_numbers(df[name].to_numpy(dtype=float), want, f"pandas {name}", rtol=PANDAS_DEFAULT_RTOL)
    exact = pandas.read_csv(path, usecols=[name], float_precision="round_trip")[name].to_numpy(dtype=float)
    assert_same_numbers(exact, want, f"pandas round_trip {name}")


def test_a_python_controllers_log_holds_the_times_and_torques_it_saw(tmp_path):
    import peha

    calls = {}

    def controller(s):
        # Torques with all 17 digits (a third, pi, a ramp of 1e-7 steps): the log keeps 9 of them.
        k = len(calls)
        tau = s["gravity_torque_Nm"] + np.array([math.sin(k) / 3.0e3, -2.5e-7 * k, math.pi * 1e-2])
        calls[s["time_s"]] = tau
        return tau

    log = tmp_path / "user.csv"
    result = peha.Exoskeleton(str(ARM)).control(controller, 0.3, log=str(log))
    meta = sidecar(log)
    a, df = opened_unmodified(log, meta)
    assert meta["rows"] == result.cycles == 301
    torque_columns = [c for c in a.dtype.names if c.endswith("_tau_user_Nm")]
    assert torque_columns == ["sfe_tau_user_Nm", "efe_tau_user_Nm", "wfe_tau_user_Nm"]
    # The time column: exactly the controller's time_s (peha writes it in its shortest exact form).
    times = np.array(list(calls))
    assert_same_numbers(a["t_s"], times, "numpy t_s")
    assert_pandas_numbers(log, df, "t_s", times)
    # Every other column: the value rounded to 9 significant digits, as peha formats it.
    for j, name in enumerate(torque_columns):
        want = np.array([float(f"{tau[j]:.9g}") for tau in calls.values()])
        assert_same_numbers(a[name], want, f"numpy {name}")
        assert_pandas_numbers(log, df, name, want)


@pytest.fixture(scope="module")
def e1_log(tmp_path_factory):
    """E1's log of one case, as `peha run` writes it."""
    out = tmp_path_factory.mktemp("e1")
    subprocess.run([peha_binary(), "run", "--config", str(E1), "--case", "payload_2.5kg", "--no-plot", "--out", str(out),
                    "--name", "r"], check=True, capture_output=True)
    return out / "r" / "e1_payload_2.5kg.csv"


def test_an_e1_log_opens_with_every_column_row_and_number(e1_log):
    log = e1_log
    meta = sidecar(log)
    assert meta["rows"] == 34001  # 34 s at 1 kHz, both ends
    assert "case: payload_2.5kg (2.5 kg payload)" in meta["notes"]
    assert {c["name"]: c["unit"] for c in meta["columns"]}["agonist_pressure_MPa"] == "MPa"
    a, df = opened_unmodified(log, meta)
    for name, want in text_values(log).items():
        assert_same_numbers(a[name], want, f"numpy {name}")
        assert_pandas_numbers(log, df, name, want)


def test_a_calibration_recording_opens_and_its_zero_reaches_the_reader(tmp_path):
    import peha

    data = tmp_path / "agonist.csv"
    subprocess.run([peha_binary(), "record-calibration", "--config", str(E1), "--muscle", "agonist", "--out", str(data)],
                   check=True, capture_output=True)
    meta = sidecar(data)
    a, df = opened_unmodified(data, meta)
    assert list(df.columns[:3]) == ["pressure_MPa", "contraction", "force_N"]
    for name, want in text_values(data).items():
        assert_same_numbers(a[name], want, f"numpy {name}")
        assert_pandas_numbers(data, df, name, want)
    # The start-up tare measured a zero (E1's plant has a load-cell offset) and the reader takes it.
    assert meta["loadcell_zero_N"] != 0.0
    assert peha.read_dataset(data).loadcell_zero_N == meta["loadcell_zero_N"]


def test_the_old_format_is_what_numpy_could_not_open(e1_log, tmp_path):
    # The same log with the comment lines peha wrote before the sidecar: genfromtxt takes the first
    # comment for the column names, pandas fails or misreads it. This is what the checks above catch.
    log = e1_log
    meta = sidecar(log)
    old = tmp_path / "old.csv"
    old.write_text("".join(f"# {n}\n" for n in meta["notes"]) + log.read_text())
    try:
        names = list(np.genfromtxt(old, delimiter=",", names=True).dtype.names)
    except ValueError:  # "got 26 columns instead of 1": the first comment was taken for the header
        names = None
    assert names != [c["name"] for c in meta["columns"]]
    if pandas is not None:
        try:
            names = list(pandas.read_csv(old).columns)
        except Exception:  # a tokenizing error: the comment lines have fewer fields
            names = None
        assert names != [c["name"] for c in meta["columns"]]
