#!/usr/bin/python3
"""Tests for tools/plot_run.py.

Run:  /usr/bin/python3 -m unittest tools/test_plot_run.py
  or  /usr/bin/python3 tools/test_plot_run.py
"""

import importlib.util
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
PLOTTER = os.path.join(HERE, "plot_run.py")

COLUMNS = [
    "t_s", "angle_rad", "velocity_radps", "finger_force_N", "finger_active",
    "tau_desired_Nm", "tau_pam_cmd_Nm", "tau_pam_measured_Nm", "tau_motor_cmd_Nm",
    "agonist_force_cmd_N", "antagonist_force_cmd_N", "agonist_loadcell_N",
    "antagonist_loadcell_N", "agonist_pressure_cmd_MPa", "antagonist_pressure_cmd_MPa",
    "agonist_pressure_MPa", "antagonist_pressure_MPa", "plant_angle_rad",
    "plant_agonist_tension_N", "plant_antagonist_tension_N",
    "plant_agonist_force_N", "plant_antagonist_force_N", "fault",
    "extra_unknown_column",
]


def _python():
    """An interpreter that has numpy + matplotlib (Debian's, if needed)."""
    if (importlib.util.find_spec("numpy") is not None
            and importlib.util.find_spec("matplotlib") is not None):
        return sys.executable
    if os.path.exists("/usr/bin/python3"):
        return "/usr/bin/python3"
    return None


PYTHON = _python()


def synth_rows(payload_kg, duration=6.0, dt=0.005, release_at=(2.0, 4.5),
               hold_from=(0.5, 3.5)):
    """Synthetic gravity-compensation run: the finger holds the arm, releases
    it, the controller holds the payload at ~40 deg (small sag + recovery)."""
    g, lever = 9.81, 0.30
    rows = []
    n = int(round(duration / dt)) + 1
    target = math.radians(40.0)
    for k in range(n):
        t = k * dt
        active = any(a <= t < b for a, b in zip(hold_from, release_at))
        since = min([t - b for b in release_at if t >= b] or [1e9])
        sag = math.radians(4.0 * payload_kg / 2.5) * math.exp(-since / 0.25) \
            * math.sin(min(since, 10.0) * 12.0 + 0.3) if since < 5 else 0.0
        angle = target - abs(sag) + 0.002 * math.sin(7 * t)
        tau_g = payload_kg * g * lever * math.cos(angle)
        finger = (tau_g / lever) if active else 0.0
        tau_d = 0.0 if active else tau_g
        tau_pam = 0.85 * tau_d
        tau_pam_meas = tau_pam * (1 - 0.1 * math.exp(-since / 0.1)) + 0.05 * math.sin(31 * t)
        tau_motor = tau_d - tau_pam_meas
        f_ag = 150.0 + tau_pam / 0.04
        f_an = 150.0
        p_ag = min(0.8, 0.1 + f_ag / 2500.0)
        p_an = 0.1 + f_an / 2500.0
        rows.append([
            t, angle, 0.0, finger, int(active), tau_d, tau_pam, tau_pam_meas,
            tau_motor, f_ag, f_an, f_ag * 0.97 + 5 * math.sin(40 * t),
            f_an + 3 * math.sin(23 * t), p_ag, p_an, p_ag * 0.98, p_an * 1.01,
            angle + 0.01, f_ag * 0.9, f_an * 0.9, f_ag, f_an,
            1 if 5.2 <= t < 5.3 else 0, 42,
        ])
    return rows


def write_log(path, payload_kg, columns=COLUMNS, case=True, old_format=False):
    """A log as peha writes it: the header first, the notes in the sidecar PATH.meta.json; with
    old_format, as peha wrote logs before the sidecar: the notes as '#' lines before the header."""
    rows = synth_rows(payload_kg)
    keep = [COLUMNS.index(c) for c in columns]
    notes = ["peha run log (synthetic, for tests)"] + (["case: payload %.1f kg" % payload_kg] if case else [])
    if not old_format:
        with open(path + ".meta.json", "w") as fh:
            json.dump({"format": "peha-log-1", "file": os.path.basename(path), "rows": len(rows),
                       "columns": [{"name": c, "unit": None} for c in columns], "notes": notes}, fh)
    with open(path, "w") as fh:
        if old_format:
            fh.write("".join("# %s\n" % n for n in notes))
        fh.write(",".join(columns) + "\n")
        for r in rows:
            fh.write(",".join(repr(r[i]) if isinstance(r[i], float) else str(r[i])
                              for i in keep) + "\n")


@unittest.skipIf(PYTHON is None, "no interpreter with numpy + matplotlib")
class PlotRunTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="plot_run_test_")

    def tearDown(self):
        shutil.rmtree(self.tmp, ignore_errors=True)

    def run_plotter(self, *args):
        env = dict(os.environ, MPLBACKEND="Agg")
        return subprocess.run([PYTHON, PLOTTER] + list(args),
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              universal_newlines=True, env=env, timeout=120)

    def assert_png(self, path):
        self.assertTrue(os.path.isfile(path), path + " not written")
        self.assertGreater(os.path.getsize(path), 10 * 1024)
        with open(path, "rb") as fh:
            self.assertEqual(fh.read(8), b"\x89PNG\r\n\x1a\n")

    def test_two_logs_default_output(self):
        write_log(os.path.join(self.tmp, "e1_payload_2.5kg.csv"), 2.5)
        write_log(os.path.join(self.tmp, "e1_payload_5.0kg.csv"), 5.0)
        with open(os.path.join(self.tmp, "summary.csv"), "w") as fh:
            fh.write("case,rms_error_deg\npayload 2.5 kg,1.2\npayload 5.0 kg,2.3\n")
        r = self.run_plotter(self.tmp)
        self.assertEqual(r.returncode, 0, r.stderr)
        out = os.path.join(self.tmp, "plot.png")
        self.assert_png(out)
        self.assertIn(out, r.stdout)
        self.assertNotIn("warning", r.stderr)

    def test_out_and_title(self):
        write_log(os.path.join(self.tmp, "a.csv"), 2.5, case=False)
        out = os.path.join(self.tmp, "sub", "fig.png")
        r = self.run_plotter(self.tmp, "--out", out, "--title", "Fig. 9 replica")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assert_png(out)
        self.assertFalse(os.path.exists(os.path.join(self.tmp, "plot.png")))

    def test_empty_dir_exit_2(self):
        r = self.run_plotter(self.tmp)
        self.assertEqual(r.returncode, 2)
        self.assertIn("no logs", r.stderr)

    def test_only_summary_exit_2(self):
        with open(os.path.join(self.tmp, "summary.csv"), "w") as fh:
            fh.write("case\nx\n")
        r = self.run_plotter(self.tmp)
        self.assertEqual(r.returncode, 2)

    def test_missing_dir_exit_2(self):
        missing = os.path.join(self.tmp, "does_not_exist")
        r = self.run_plotter(missing)
        self.assertEqual(r.returncode, 2)
        self.assertIn("does_not_exist", r.stderr)

    def test_missing_column_only_warns(self):
        cols = [c for c in COLUMNS if c not in ("tau_motor_cmd_Nm", "plant_angle_rad")]
        write_log(os.path.join(self.tmp, "e1_payload_2.5kg.csv"), 2.5, columns=cols)
        write_log(os.path.join(self.tmp, "e1_payload_5.0kg.csv"), 5.0)
        r = self.run_plotter(self.tmp)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("warning", r.stderr)
        self.assertIn("tau_motor_cmd_Nm", r.stderr)
        self.assertIn("plant_angle_rad", r.stderr)
        self.assert_png(os.path.join(self.tmp, "plot.png"))

    def test_board_run_with_unknown_truth_columns_plots_quietly(self):
        # Over the multifunction board the simulator's truth is unknown: plant_* and the finger's
        # force are NaN in every row. They are left out without a warning.
        path = os.path.join(self.tmp, "e1_payload_2.5kg.csv")
        write_log(path, 2.5)
        with open(path) as fh:
            lines = fh.read().splitlines()
        header_at = next(i for i, l in enumerate(lines) if not l.startswith("#"))
        names = lines[header_at].split(",")
        nan_cols = [names.index(c) for c in names if c.startswith("plant_") or c == "finger_force_N"]
        out = lines[:header_at + 1]
        for line in lines[header_at + 1:]:
            cells = line.split(",")
            for i in nan_cols:
                cells[i] = "nan"
            out.append(",".join(cells))
        with open(path, "w") as fh:
            fh.write("\n".join(out) + "\n")
        r = self.run_plotter(self.tmp)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertNotIn("plant_angle_rad", r.stderr)
        self.assertNotIn("finger_force_N", r.stderr)
        self.assert_png(os.path.join(self.tmp, "plot.png"))

    def test_malformed_csv_names_file(self):
        write_log(os.path.join(self.tmp, "good.csv"), 2.5)
        bad = os.path.join(self.tmp, "bad_case.csv")
        with open(bad, "w") as fh:
            fh.write("t_s,angle_rad\n0.0,0.1\n0.1,abc\n")
        r = self.run_plotter(self.tmp)
        self.assertNotEqual(r.returncode, 0)
        self.assertIn("bad_case.csv", r.stderr)
        self.assertNotIn("Traceback", r.stderr)

    def test_ragged_row_names_file(self):
        bad = os.path.join(self.tmp, "ragged.csv")
        with open(bad, "w") as fh:
            fh.write("t_s,angle_rad\n0.0,0.1\n0.1,0.2,0.3,0.4\n")
        r = self.run_plotter(self.tmp)
        self.assertNotEqual(r.returncode, 0)
        self.assertIn("ragged.csv", r.stderr)
        self.assertNotIn("Traceback", r.stderr)

    def read_case(self, path):
        """plot_run.read_log(path)["case"], in the interpreter that has numpy."""
        code = "import sys; sys.path.insert(0, %r); import plot_run; print(plot_run.read_log(%r)['case'])" % (HERE, path)
        r = subprocess.run([PYTHON, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           universal_newlines=True, timeout=60)
        self.assertEqual(r.returncode, 0, r.stderr)
        return r.stdout.strip()

    def test_case_title_from_the_sidecar_or_an_older_logs_comment(self):
        new = os.path.join(self.tmp, "e1_payload_2.5kg.csv")
        old = os.path.join(self.tmp, "e1_payload_5.0kg.csv")
        bare = os.path.join(self.tmp, "e1_payload_7.5kg.csv")
        write_log(new, 2.5)
        write_log(old, 5.0, old_format=True)
        write_log(bare, 7.5, case=False)
        with open(new) as fh:
            self.assertEqual(fh.readline().rstrip("\n"), ",".join(COLUMNS))
        self.assertEqual(self.read_case(new), "payload 2.5 kg")
        self.assertEqual(self.read_case(old), "payload 5.0 kg")
        self.assertEqual(self.read_case(bare), "None")  # the title falls back to summary.csv or the stem
        with open(bare + ".meta.json", "w") as fh:
            fh.write("{not json")
        r = self.run_plotter(self.tmp)
        self.assertEqual(r.returncode, 0, r.stderr)  # a broken sidecar costs the title only
        self.assertIn("e1_payload_7.5kg.csv.meta.json: ignored", r.stderr)
        self.assert_png(os.path.join(self.tmp, "plot.png"))

    def test_help(self):
        r = self.run_plotter("--help")
        self.assertEqual(r.returncode, 0)
        for word in ("RUN_DIR", "--out", "--title"):
            self.assertIn(word, r.stdout)


if __name__ == "__main__":
    unittest.main()
