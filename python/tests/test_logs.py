"""read_log / read_run on a real `peha run` directory."""
import subprocess

import numpy as np

import peha
from conftest import E1, _exe


def test_read_run_of_e1(tmp_path):
    peha_bin = _exe("PEHA_BINARY")
    subprocess.run([peha_bin, "run", "--config", str(E1), "--case", "payload_2.5kg", "--no-plot", "--out", str(tmp_path),
                    "--name", "r"], check=True, capture_output=True)
    run = peha.read_run(tmp_path / "r")
    log = run["e1_payload_2.5kg"]
    assert log["t_s"][0] == 0.0 and np.all(np.diff(log["t_s"]) > 0)
    assert log["t_s"].size == 34001  # E1: 34 s at 1 kHz (with the breakaway probes)
    header = (tmp_path / "r" / "e1_payload_2.5kg.csv").read_text().splitlines()
    header = [h for h in header if not h.startswith("#")][0].split(",")
    assert list(log) == header
    assert np.isfinite(log["plant_angle_rad"]).all()
    assert run["summary"][0]["case"] == "payload_2.5kg"
