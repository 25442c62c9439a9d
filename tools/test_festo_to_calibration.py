#!/usr/bin/python3
"""Tests for tools/festo_to_calibration.py (on the real Festo maps in the reference data directory:
PEHA_PAM_DATA_DIR, by default ../shared/data/pam beside the checkout).

Run:  /usr/bin/python3 -m unittest tools/test_festo_to_calibration.py
  or  /usr/bin/python3 tools/test_festo_to_calibration.py
"""

import csv
import glob
import json
import os
import shutil
import subprocess
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
TOOL = os.path.join(HERE, "festo_to_calibration.py")
PYTHON = "/usr/bin/python3" if os.path.exists("/usr/bin/python3") else "python3"
DATA_DIR = os.environ.get("PEHA_PAM_DATA_DIR",
                          os.path.normpath(os.path.join(HERE, "..", "..", "shared", "data", "pam")))
DMSP40 = os.path.join(DATA_DIR, "festo_datasheet_DMSP-40_digitized.csv")


def run_tool(*args):
    return subprocess.run([PYTHON, TOOL, *args], capture_output=True, text=True, timeout=60)


def read_csv(path):
    """(comment lines, header, rows as float lists) of a CSV: its '#' lines (a Festo map), or the
    notes of its sidecar PATH.meta.json (a converted file, whose first line must be the header)."""
    comments, header, rows = [], None, []
    if os.path.exists(path + ".meta.json"):
        with open(path + ".meta.json", encoding="utf-8") as fh:
            meta = json.load(fh)
        assert meta["format"] == "peha-log-1", meta
        comments = list(meta["notes"])
        with open(path) as fh:
            assert not fh.readline().startswith("#"), f"{path}: the first line is not the header"
    with open(path) as fh:
        for line in fh:
            line = line.rstrip("\n")
            if line.startswith("#"):
                comments.append(line)
            elif line.strip():
                fields = line.split(",")
                if header is None:
                    header = fields
                else:
                    rows.append([float(x) for x in fields])
    return comments, header, rows


@unittest.skipUnless(os.path.isfile(DMSP40), f"reference data not found: {DMSP40}")
class FestoToCalibrationTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="peha_festo_test_")

    def tearDown(self):
        shutil.rmtree(self.tmp, ignore_errors=True)

    def test_dmsp40_datasheet_keeps_positive_force_nonzero_pressure_rows_in_MPa(self):
        out = os.path.join(self.tmp, "dmsp40.csv")
        r = run_tool(DMSP40, out)
        self.assertEqual(r.returncode, 0, r.stderr)

        _, src_header, src_rows = read_csv(DMSP40)
        self.assertEqual(src_header, ["pressure_kPa", "contraction", "force_N"])
        expected = [(p / 1000.0, e, f) for p, e, f in src_rows if f > 0 and p > 0]

        comments, header, rows = read_csv(out)
        self.assertEqual(header, ["pressure_MPa", "contraction", "force_N"])  # no t_s/angle/velocity
        self.assertEqual(len(rows), len(expected))
        self.assertEqual(len(rows), 62)
        for got, want in zip(rows, expected):
            for g, w in zip(got, want):
                self.assertAlmostEqual(g, w, places=9)
        self.assertTrue(all(0 < row[0] <= 1.0 for row in rows))
        self.assertTrue(all(row[2] > 0 for row in rows))

        text = "\n".join(comments)
        self.assertIn(os.path.basename(DMSP40), text)
        n_force = sum(1 for _, _, f in src_rows if f <= 0)
        n_zero_p = sum(1 for p, _, f in src_rows if f > 0 and p == 0)
        self.assertIn(f"excluded {n_force} rows with force_N <= 0", text)
        self.assertIn(f"{n_zero_p} further rows with pressure = 0", text)
        self.assertIn("muscle's own contraction", text)
        with open(out + ".meta.json", encoding="utf-8") as fh:
            meta = json.load(fh)
        self.assertEqual(meta["file"], "dmsp40.csv")
        self.assertEqual(meta["rows"], 62)
        self.assertEqual([c["unit"] for c in meta["columns"]], ["MPa", None, "N"])
        self.assertFalse(os.path.exists(out + ".meta.json.tmp"))

    def test_min_force_excludes_more_rows(self):
        out = os.path.join(self.tmp, "dmsp40_min.csv")
        r = run_tool(DMSP40, out, "--min-force", "500")
        self.assertEqual(r.returncode, 0, r.stderr)
        _, _, src_rows = read_csv(DMSP40)
        _, _, rows = read_csv(out)
        self.assertEqual(len(rows), sum(1 for p, _, f in src_rows if f > 500 and p > 0))

    def test_martens_map_drops_length_and_converts_Pa(self):
        sources = glob.glob(os.path.join(DATA_DIR, "martens2017_*.csv"))
        if not sources:
            self.skipTest("no martens2017 map")
        out = os.path.join(self.tmp, "martens.csv")
        r = run_tool(sources[0], out)
        self.assertEqual(r.returncode, 0, r.stderr)
        comments, header, rows = read_csv(out)
        self.assertEqual(header, ["pressure_MPa", "contraction", "force_N"])
        self.assertTrue(all(0 < row[0] <= 1.0 and row[2] > 0 for row in rows))
        self.assertIn("length_m", "\n".join(comments))

    def test_all_converts_every_map(self):
        out_dir = os.path.join(self.tmp, "all")
        r = run_tool("--all", "--data-dir", DATA_DIR, "--out-dir", out_dir)
        self.assertEqual(r.returncode, 0, r.stderr)
        maps = sorted(glob.glob(os.path.join(DATA_DIR, "festo_datasheet_*.csv")) +
                      glob.glob(os.path.join(DATA_DIR, "martens2017_*.csv")))
        for m in maps:
            stem = os.path.splitext(os.path.basename(m))[0]
            self.assertTrue(os.path.isfile(os.path.join(out_dir, stem + "_calibration.csv")), stem)

    def test_unknown_format_exits_2(self):
        bad = os.path.join(self.tmp, "unknown.csv")
        with open(bad, "w") as fh:
            fh.write("# something else\npressure_bar,force_N\n1,2\n")
        r = run_tool(bad, os.path.join(self.tmp, "out.csv"))
        self.assertEqual(r.returncode, 2)
        self.assertIn("unknown format", r.stderr)
        self.assertFalse(os.path.exists(os.path.join(self.tmp, "out.csv")))

    def test_missing_file_exits_2(self):
        r = run_tool(os.path.join(self.tmp, "nope.csv"), os.path.join(self.tmp, "out.csv"))
        self.assertEqual(r.returncode, 2)
        self.assertIn("no such file", r.stderr)

    def test_malformed_row_exits_1_naming_line(self):
        bad = os.path.join(self.tmp, "bad.csv")
        with open(bad, "w") as fh:
            fh.write("pressure_kPa,contraction,force_N\n100,0.01,50\n200,abc,60\n")
        r = run_tool(bad, os.path.join(self.tmp, "out.csv"))
        self.assertEqual(r.returncode, 1)
        self.assertIn("bad.csv:3: column 'contraction': not a number 'abc'", r.stderr)


if __name__ == "__main__":
    unittest.main()
