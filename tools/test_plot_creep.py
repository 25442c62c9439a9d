#!/usr/bin/python3
"""Tests for tools/plot_creep.py (the wire-creep experiment's figure, docs/creep.md).

Run:  /usr/bin/python3 -m unittest tools/test_plot_creep.py
"""

import os
import subprocess
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
PLOTTER = os.path.join(HERE, "plot_creep.py")

SERIES = ("t_s,angle_deg,truth_agonist_mm,truth_antagonist_mm,estimate_agonist_mm,estimate_antagonist_mm,"
          "sigma_agonist_mm,sigma_antagonist_mm,tracking_rms_agonist_N,tracking_rms_antagonist_N,"
          "gated_agonist,gated_antagonist,alerts\n")


def write_run(directory, name, estimator_on):
    """A 10-minute run: the agonist creeps 2 mm, the antagonist 0.3 mm; the alert at 6 min when on."""
    with open(os.path.join(directory, f"creep_{name}.csv"), "w") as f:
        f.write(SERIES)
        for k in range(601):
            t = float(k)
            truth = (2.0 * t / 600.0, 0.3 * t / 600.0)
            est = (1.05 * truth[0], 1.1 * truth[1]) if estimator_on else (0.0, 0.0)
            alerts = 1 if estimator_on and t >= 360.0 else 0
            f.write(f"{t},{5.0},{truth[0]},{truth[1]},{est[0]},{est[1]},0.1,0.1,{10 + t / 60},{2.0},1,1,{alerts}\n")
    with open(os.path.join(directory, f"releases_{name}.csv"), "w") as f:
        f.write("release_time_s,angle_deg,static_torque_error_pct\n")
        for k in range(30):
            f.write(f"{9.0 + 20 * k},{23.0},{2.7 - (0 if estimator_on else 0.01 * k)}\n")


class PlotCreepTest(unittest.TestCase):
    def test_writes_the_figure_for_every_variant_and_trim(self):
        with tempfile.TemporaryDirectory() as d:
            for variant in ("nominal", "loadcell_bias_+40N"):
                for trim in ("4", "0"):
                    write_run(d, f"{variant}_trim{trim}_off", False)
                    write_run(d, f"{variant}_trim{trim}_on", True)
            r = subprocess.run(["/usr/bin/python3", PLOTTER, d], capture_output=True, text=True)
            self.assertEqual(r.returncode, 0, r.stderr)
            png = os.path.join(d, "creep.png")
            self.assertTrue(os.path.exists(png))
            self.assertGreater(os.path.getsize(png), 10000)

    def test_a_directory_without_runs_is_a_usage_error(self):
        with tempfile.TemporaryDirectory() as d:
            r = subprocess.run(["/usr/bin/python3", PLOTTER, d], capture_output=True, text=True)
            self.assertEqual(r.returncode, 2)
            self.assertIn("no creep_<run>.csv", r.stderr)


if __name__ == "__main__":
    unittest.main()
