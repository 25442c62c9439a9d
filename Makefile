# peha front door. `make run` and `make test` work on a fresh Debian 12 machine.
PRESET ?= release
BUILD  := build/$(PRESET)
CONFIG ?= configs/e1_one_dof.yaml
CAL    := out/calibration
PEHA    = ./$(BUILD)/peha

.PHONY: all deps configure build run test bench fuzz soak video clean help

all: build

help:
	@echo "make run    install missing packages, build Release, run E1 on the simulated one-DOF rig,"
	@echo "            record + calibrate both muscles, run E1 again with the calibrated models"
	@echo "make test   install missing packages, build Release, run every test"
	@echo "make bench  build and run the Google Benchmark suite (incl. 60 s of MFB round trips over UDP)"
	@echo "make fuzz   fuzz the MFB packet parser for 10 minutes (libFuzzer, ASan, UBSan)"
	@echo "make video  render MP4s of E1 (both payloads), E3 and E4 (brisk movement) into out/video_*/ (docs/video.md)"
	@echo "make soak   opt-in: build and run only the long benchmark (60 s of MFB round trips at 1 kHz over UDP)"
	@echo "make clean  remove build/ and out/"

deps:
	@./scripts/install-deps.sh

$(BUILD)/build.ninja: CMakeLists.txt CMakePresets.json
	cmake --preset $(PRESET)

configure: deps $(BUILD)/build.ninja

build: configure
	cmake --build --preset $(PRESET)

# E1 with the nominal model (and force trim), then: record the calibration excitation of both
# muscles, calibrate them (LM x 300 + SPGP), and run E1 on the paper's pure feed-forward with the
# calibrated models, parametric alone vs parametric + SPGP.
run: build
	$(PEHA) run --config $(CONFIG) --name e1_nominal
	$(PEHA) record-calibration --config $(CONFIG) --muscle agonist --out $(CAL)/agonist.csv
	$(PEHA) record-calibration --config $(CONFIG) --muscle antagonist --out $(CAL)/antagonist.csv
	$(PEHA) calibrate $(CAL)/agonist.csv --muscle agonist --out $(CAL)/agonist.yaml
	$(PEHA) calibrate $(CAL)/antagonist.csv --muscle antagonist --out $(CAL)/antagonist.yaml
	@# Exit code 3 = some variant violated a safety figure: expected for the parametric-only
	@# variant on pure feed-forward, and reported in the table; any other failure stops make.
	$(PEHA) run --config $(CONFIG) --name e1_calibrated --force-trim-rate 0 \
	  --agonist-calibration $(CAL)/agonist.yaml --antagonist-calibration $(CAL)/antagonist.yaml; \
	  code=$$?; [ $$code -eq 0 ] || [ $$code -eq 3 ]

test: build
	ctest --preset $(PRESET)

# Google Benchmark, then the same LM fit by scipy.optimize.least_squares(method="lm") on the same
# 60 s of 250 Hz data in the same run (cost and time ratio).
bench: build
	./$(BUILD)/peha_bench --benchmark_counters_tabular=true
	$(PEHA) record-calibration --config $(CONFIG) --muscle agonist --out out/bench/agonist.csv
	$(PEHA) calibrate out/bench/agonist.csv --muscle agonist --out out/bench/agonist_lm.yaml --no-spgp --no-holdout --no-plot
	/usr/bin/python3 tools/compare_lm_scipy.py out/bench/agonist.csv --peha-yaml out/bench/agonist_lm.yaml --json out/bench/scipy_vs_peha.json

# Videos (docs/video.md): E1, E3 and E4 with an MP4 per case beside each CSV (offscreen MuJoCo + ffmpeg).
video: build
	$(PEHA) run --config $(CONFIG) --name video_e1 --video
	$(PEHA) run --config configs/right_arm.yaml --experiment postures --name video_e3 --video
	$(PEHA) run --config configs/right_arm.yaml --experiment goniometer --case brisk --name video_e4 --video

# Opt-in soak: only the 60 s MFB loopback benchmark at 1 kHz (also part of `make bench`).
soak: build
	./$(BUILD)/peha_bench --benchmark_filter=BM_MfbLoopback1kHz60s --benchmark_counters_tabular=true

# The MFB packet parser under libFuzzer for 10 minutes (make test runs it for 20 s).
fuzz: deps
	./scripts/fuzz-mfb.sh 600

clean:
	rm -rf build out
