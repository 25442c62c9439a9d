#!/usr/bin/env bash
# Builds and runs the libFuzzer targets of peha's file readers with clang-14, AddressSanitizer and
# UndefinedBehaviorSanitizer: the strict config reader (fuzz/config_reader_fuzz.cpp) and the
# calibration CSV + YAML readers (fuzz/calibration_files_fuzz.cpp).
#   scripts/fuzz-readers.sh [SECONDS]   per target; default 10 (what `make test` runs); `make fuzz` runs 600
# New inputs go to build/fuzz/corpus-<target>/; a crash leaves build/fuzz/crash-* and exits non-zero.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-10}"
CXX="${PEHA_FUZZ_CXX:-clang++-14}"
if ! command -v "$CXX" >/dev/null 2>&1; then
  echo "fuzz-readers: $CXX not found: run scripts/install-deps.sh (clang-14 libclang-rt-14-dev)" >&2
  exit 1
fi
# -mavx2: the SPGP's blocked passes (src/calibration/spgp.cpp) pass 32-byte vectors between
# always-inlined helpers and are cloned for AVX2 and generic x86-64 (target_clones). GCC, which
# builds peha, compiles the generic clone with SSE2; clang refuses a 32-byte vector argument in a
# function without AVX ("changes the ABI") even when inlined. The fuzz binary is built whole with
# the same flags on this machine, so AVX2 for all of it is consistent (it needs an AVX2 CPU).
flags=(-std=c++20 -g -O1 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all -Wall -Wextra -I include
       -I /usr/include/eigen3 -mavx2)
config_src=(src/config/reader.cpp src/config/atomic_file.cpp src/config/csv_sidecar.cpp src/config/input_file.cpp)
calibration_src=(src/calibration/dataset.cpp src/calibration/calibration_file.cpp src/calibration/spgp.cpp
                 src/models/tendon_spring.cpp src/models/joint.cpp src/models/bowden.cpp)
build() {  # name, sources..., libraries after --
  local name=$1; shift
  local bin=build/fuzz/$name
  local newest
  newest=$(ls -t "$@" fuzz/"$name".cpp include/peha/*/*.hpp 2>/dev/null | grep -v '^-' | head -1)
  if [ ! -x "$bin" ] || [ "$newest" -nt "$bin" ]; then
    echo "fuzz-readers: building $bin"
    "$CXX" "${flags[@]}" "$@" fuzz/"$name".cpp -o "$bin" -lyaml-cpp -lfmt -lcrypto -lceres -lglog -lpthread
  fi
}
mkdir -p build/fuzz/corpus-config_reader_fuzz build/fuzz/corpus-calibration_files_fuzz
build config_reader_fuzz "${config_src[@]}"
build calibration_files_fuzz "${config_src[@]}" "${calibration_src[@]}"
for target in config_reader_fuzz calibration_files_fuzz; do
  seeds=fuzz/corpus/${target%_fuzz}
  echo "fuzz-readers: $target for ${seconds} s"
  build/fuzz/$target -max_total_time="$seconds" -print_final_stats=1 -artifact_prefix=build/fuzz/ \
    -rss_limit_mb=2048 -max_len=16384 build/fuzz/corpus-$target "$seeds"
done
