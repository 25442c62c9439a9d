# peha front door. `make run` and `make test` work on a fresh Debian 12 machine.
PRESET ?= release
BUILD  := build/$(PRESET)
CONFIG ?= configs/e1_one_dof.yaml

.PHONY: all deps configure build run test bench clean help

all: build

help:
	@echo "make run    install missing packages, build Release, run E1 on the simulated one-DOF rig"
	@echo "make test   install missing packages, build Release, run every test"
	@echo "make bench  build and run the Google Benchmark suite"
	@echo "make clean  remove build/ and out/"

deps:
	@./scripts/install-deps.sh

$(BUILD)/build.ninja: CMakeLists.txt CMakePresets.json
	cmake --preset $(PRESET)

configure: deps $(BUILD)/build.ninja

build: configure
	cmake --build --preset $(PRESET)

run: build
	./$(BUILD)/peha run --config $(CONFIG)

test: build
	ctest --preset $(PRESET)

bench: build
	./$(BUILD)/peha_bench --benchmark_counters_tabular=true

clean:
	rm -rf build out
