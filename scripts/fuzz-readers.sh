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
# -gline-tables-only: a crash's stack has file and line, at a third less compile time than -g.
flags=(-std=c++20 -gline-tables-only -fsanitize=address,undefined -fno-sanitize-recover=all -Wall -Wextra -I include
       -I /usr/include/eigen3 -mavx2)
config_src=(src/config/reader.cpp src/config/atomic_file.cpp src/config/csv_sidecar.cpp src/config/input_file.cpp)
calibration_src=(src/calibration/dataset.cpp src/calibration/calibration_file.cpp src/calibration/spgp.cpp
                 src/models/tendon_spring.cpp src/models/joint.cpp src/models/bowden.cpp)
newest_header=$(ls -t include/peha/*/*.hpp | head -1)
# Each source compiled once (both targets link the config reader's objects). The SPGP's Eigen code
# at -O0: the readers only build a model from its parts, and -O1 with the sanitizers took 33 s of a
# fresh machine's test time for that file alone (-O0: 13 s).
object() {  # source -> build/fuzz/obj/<path>.o, echoed
  local src=$1 obj=build/fuzz/obj/${1//\//_}.o opt=-O1
  [ "$src" = src/calibration/spgp.cpp ] && opt=-O0
  if [ ! -f "$obj" ] || [ "$src" -nt "$obj" ] || [ "$newest_header" -nt "$obj" ]; then
    echo "fuzz-readers: compiling $src" >&2
    "$CXX" "${flags[@]}" "$opt" -fsanitize=fuzzer-no-link -c "$src" -o "$obj"
  fi
  echo "$obj"
}
build() {  # name, sources...
  local name=$1; shift
  local objects=() src
  for src in "$@" fuzz/"$name".cpp; do objects+=("$(object "$src")"); done
  local bin=build/fuzz/$name
  if [ ! -x "$bin" ] || [ -n "$(find "${objects[@]}" -newer "$bin" 2>/dev/null)" ]; then
    echo "fuzz-readers: linking $bin"
    "$CXX" "${flags[@]}" -fsanitize=fuzzer "${objects[@]}" -o "$bin" -lyaml-cpp -lfmt -lcrypto -lceres -lglog -lpthread
  fi
}
mkdir -p build/fuzz/obj
mkdir -p build/fuzz/corpus-config_reader_fuzz build/fuzz/corpus-calibration_files_fuzz
build config_reader_fuzz "${config_src[@]}"
build calibration_files_fuzz "${config_src[@]}" "${calibration_src[@]}"
for target in config_reader_fuzz calibration_files_fuzz; do
  seeds=fuzz/corpus/${target%_fuzz}
  echo "fuzz-readers: $target for ${seconds} s"
  build/fuzz/$target -max_total_time="$seconds" -print_final_stats=1 -artifact_prefix=build/fuzz/ \
    -rss_limit_mb=2048 -max_len=16384 build/fuzz/corpus-$target "$seeds"
done
