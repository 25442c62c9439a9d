"""peha for Python: the exoskeleton's models, calibration, simulator and logs (docs/python.md).

SI units inside (Pa, N, m, rad, s); the names say the unit (``pressure_Pa``, ``force_N``). The
compiled part (``peha._core``) is built with the project (``make`` puts the package in
``build/release/python``); run with ``PYTHONPATH=build/release/python /usr/bin/python3``.

    import peha
    cal = peha.calibrate("out/calibration/agonist.csv", muscle="agonist")   # LM x 300 + SPGP
    cal.write_report("out/calibration/agonist_py_report")                 # report.png
"""

from __future__ import annotations

import csv as _csv
import pathlib as _pathlib

import numpy as _np

from ._core import *  # noqa: F401,F403  (the bound C++ API)
from ._core import __doc__ as _core_doc  # noqa: F401

__all__ = [name for name in dir() if not name.startswith("_")]


def read_log(path, as_pandas: bool = False):
    """A run's per-cycle CSV (``out/<run>/<experiment>_<case>.csv``) as a dict of numpy arrays.

    One float64 array per column, named as in the file (units in the names: ``t_s``,
    ``angle_rad``, ``agonist_pressure_MPa``, ...). The header is the first line; lines starting
    with ``#`` (older logs) are skipped. The case, config, seed and the columns' units are in the
    sidecar ``<log>.meta.json`` (JSON). With ``as_pandas=True`` (and pandas installed) a
    ``pandas.DataFrame`` instead.
    """
    path = _pathlib.Path(path)
    with path.open(newline="") as f:
        rows = (line for line in f if not line.startswith("#"))
        reader = _csv.reader(rows)
        header = next(reader)
        data = _np.array([[float(x) if x != "" else _np.nan for x in row] for row in reader if row], dtype=float)
    if data.size == 0:
        data = _np.zeros((0, len(header)))
    columns = {name: _np.ascontiguousarray(data[:, i]) for i, name in enumerate(header)}
    if as_pandas:
        import pandas  # optional dependency

        return pandas.DataFrame(columns)
    return columns


def read_run(run_dir):
    """Every per-cycle log of a run directory: {case file stem: read_log(...)}, plus 'summary' when present."""
    run_dir = _pathlib.Path(run_dir)
    logs = {}
    for p in sorted(run_dir.glob("*.csv")):
        if p.name == "summary.csv":
            with p.open(newline="") as f:
                logs["summary"] = list(_csv.DictReader(f))
        else:
            logs[p.stem] = read_log(p)
    return logs
