"""tools/bench_report.py: collects Google Benchmark's JSON and the peers' JSON into one file and
replaces only the table between the markers of the performance page."""

import json
import sys
import tempfile
import unittest
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_report  # noqa: E402


def gb_entry(name, real_time, cpu_time, unit="ns", **counters):
    return dict(name=name, real_time=real_time, cpu_time=cpu_time, time_unit=unit, **counters)


class BenchReportTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = Path(self.tmp.name)
        report = {
            "context": {"num_cpus": 2, "mhz_per_cpu": 2600, "load_avg": [0.5, 0.4, 0.3]},
            "benchmarks": [
                gb_entry("BM_SpgpPredictMean", 150.0, 90.0),
                gb_entry("BM_SpgpPredictMeanAndVariance", 600.0, 450.0),
                gb_entry("BM_FitTendonSpring300Restarts/iterations:1/real_time", 0.4, 0.0, "s", best_cost=0.0075),
                gb_entry("BM_ArmControlStepWithSpgp/0/iterations:1", 300.0, 300.0, "ms", median_ns=1500.0,
                         p99_ns=2500.0, p999_ns=4000.0, max_ns=9000.0, allocs_per_step=0.0, band_reuse=0.84),
                gb_entry("BM_ArmControlStepWithSpgp/1/iterations:1", 400.0, 400.0, "ms", median_ns=2100.0,
                         p99_ns=2500.0, p999_ns=4000.0, max_ns=9000.0, allocs_per_step=0.0, band_reuse=0.0),
            ],
        }
        (self.dir / "peha_bench.json").write_text(json.dumps(report))
        self.doc = self.dir / "performance.md"
        self.doc.write_text("# Performance\n\nbefore\n\n<!-- bench:begin -->\nold table\n<!-- bench:end -->\n\nafter\n")

    def tearDown(self):
        self.tmp.cleanup()

    def test_writes_the_json_and_replaces_only_the_table(self):
        self.assertEqual(bench_report.main(["--dir", str(self.dir), "--doc", str(self.doc)]), 0)
        doc = self.doc.read_text()
        self.assertIn("before", doc)
        self.assertIn("after", doc)
        self.assertNotIn("old table", doc)
        self.assertIn("| SPGP mean / mean + variance (M = 50, D = 2) | 90 ns / 450 ns CPU time", doc)
        out = json.loads((self.dir / "bench.json").read_text())
        verdicts = {t["figure"]: t["met"] for t in out["targets"]}
        self.assertTrue(verdicts["SPGP mean / mean + variance (M = 50, D = 2)"])
        self.assertTrue(verdicts["300 LM restarts, 15 000 synthetic rows (BM_FitTendonSpring300Restarts)"])
        arm = "Arm step: J^T G + 3 allocations + SPGP on 6 muscles + limits, "
        self.assertTrue(verdicts[arm + "holding a posture (pressure bands reused)"])  # median 1.5 us
        self.assertFalse(verdicts[arm + "every pressure band computed (moving)"])  # median 2.1 us

    def _udp_row(self, floor_miss_pct, loop_miss_pct, **loop_counters):
        """Adds a 60 s floor and loop to the report, runs it; returns the UDP row and the page."""
        report = json.loads((self.dir / "peha_bench.json").read_text())
        misses = dict(overruns=2.0, max_burst=20.0, burst_miss_pct=95.0, late_wake_overruns=2.0)
        report["benchmarks"] += [
            gb_entry("BM_TimerFloor1kHz60s/iterations:1/real_time", 60.0, 1.0, "s", cycles=59980.0, wake_median_us=25.0,
                     wake_p999_us=250.0, wake_max_us=20000.0, miss_rate_pct=floor_miss_pct, fifo=1.0, **misses),
            gb_entry("BM_MfbLoopback1kHz60s/iterations:1/real_time", 60.0, 3.0, "s", cycles=59979.0, rtt_median_us=40.0,
                     rtt_p999_us=90.0, rtt_max_us=400.0, miss_rate_pct=loop_miss_pct, faults=0.0, fifo=1.0,
                     **misses, **loop_counters),
        ]
        (self.dir / "peha_bench.json").write_text(json.dumps(report))
        self.assertEqual(bench_report.main(["--dir", str(self.dir), "--doc", str(self.doc)]), 0)
        targets = {t["figure"]: t for t in json.loads((self.dir / "bench.json").read_text())["targets"]}
        return targets["UDP loop 60 s at 1 kHz (make bench)"], self.doc.read_text()

    def test_the_udp_row_carries_the_machine_floor_beside_the_loop(self):
        row, doc = self._udp_row(0.035, 0.036)
        self.assertIn("RTT median 40 us, p99.9 90 us, max 400 us; deadline misses 0.036 %, 2 overrun(s), largest 20 deadlines", doc)
        self.assertIn("Machine floor (bare timer loop, same set-up, run just before): wake-up latency median 25 us, "
                      "p99.9 250 us, max 2e+04 us; deadline misses 0.035 %", doc)
        self.assertFalse(row["met"])  # misses 0.036 % > 0.01 %
        # The floor alone misses 0.035 %: the row says the target is out of reach on this machine.
        self.assertIn("the bare timer loop alone misses 0.035 %", row["out_of_reach"])
        self.assertIn("| **no**: out of reach on this machine: the bare timer loop alone misses 0.035 % |", doc)

    def test_a_loop_that_misses_more_than_a_quiet_floor_is_not_excused(self):
        row, _ = self._udp_row(0.005, 0.036)
        self.assertFalse(row["met"])
        self.assertNotIn("out_of_reach", row)

    def test_a_loop_whose_own_misses_exceed_the_target_is_not_excused_by_a_bad_floor(self):
        row, _ = self._udp_row(0.035, 0.05, on_time_miss_pct=0.02)
        self.assertFalse(row["met"])
        self.assertNotIn("out_of_reach", row)  # 0.02 % of its own misses: peha's, whatever the floor
        self.assertIn("misses by cycles that woke on time (the loop's own at most) 0.02 %", row["measured"])

    def _plant_row(self, friction_cpu_ns):
        report = json.loads((self.dir / "peha_bench.json").read_text())
        report["benchmarks"] += [
            gb_entry("BM_SimulatedRigStep", 3300.0, 3200.0),
            gb_entry("BM_BareMujocoRigStep", 1150.0, 1130.0),
            gb_entry("BM_BareMujocoRigStepWithFriction", friction_cpu_ns + 20.0, friction_cpu_ns),
        ]
        (self.dir / "peha_bench.json").write_text(json.dumps(report))
        self.assertEqual(bench_report.main(["--dir", str(self.dir), "--doc", str(self.doc)]), 0)
        targets = {t["figure"]: t for t in json.loads((self.dir / "bench.json").read_text())["targets"]}
        return targets["Simulated rig: plant over bare mj_step, real-time factor"]

    def test_a_plant_whose_mujoco_step_alone_takes_the_budget_is_out_of_reach(self):
        row = self._plant_row(1800.0)  # 1.8 us > 1.5 x 1.13 us
        self.assertFalse(row["met"])
        self.assertIn("MuJoCo's own step for the model takes the budget", row["out_of_reach"])
        self.assertIn("1.8 us: 1.8 us before any plant code, against 1.69 us for the whole at 50 % overhead and 2 us at 500x", row["measured"])

    def test_a_slow_plant_with_room_in_the_budget_is_only_not_met(self):
        row = self._plant_row(1200.0)  # MuJoCo with friction leaves 0.5 us: the plant's own code is to blame
        self.assertFalse(row["met"])
        self.assertNotIn("out_of_reach", row)

    def test_missing_benchmark_json_is_an_error(self):
        (self.dir / "peha_bench.json").unlink()
        with self.assertRaises(SystemExit):
            bench_report.main(["--dir", str(self.dir), "--doc", str(self.doc)])


if __name__ == "__main__":
    unittest.main()
