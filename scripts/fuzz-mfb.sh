#!/usr/bin/env bash
# Builds and runs the libFuzzer target of the MFB packet parser (fuzz/mfb_packet_fuzz.cpp) with
# clang-14, AddressSanitizer and UndefinedBehaviorSanitizer.
#   scripts/fuzz-mfb.sh [SECONDS]   default 20 (what `make test` runs); `make fuzz` runs 600
# New inputs go to build/fuzz/corpus (the committed seeds in fuzz/corpus/mfb_packet stay as they
# are); a crash leaves build/fuzz/crash-* and exits non-zero.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-20}"
CXX="${PEHA_FUZZ_CXX:-clang++-14}"
if ! command -v "$CXX" >/dev/null 2>&1; then
  echo "fuzz-mfb: $CXX not found: run scripts/install-deps.sh (clang-14 libclang-rt-14-dev)" >&2
  exit 1
fi
mkdir -p build/fuzz/corpus
bin=build/fuzz/mfb_packet_fuzz
if [ ! -x "$bin" ] || [ src/mfb/protocol.cpp -nt "$bin" ] || [ include/peha/mfb/protocol.hpp -nt "$bin" ] ||
   [ fuzz/mfb_packet_fuzz.cpp -nt "$bin" ] || [ fuzz/fuzz_key.hpp -nt "$bin" ]; then
  "$CXX" -std=c++20 -g -O1 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all -Wall -Wextra \
    -I include src/mfb/protocol.cpp fuzz/mfb_packet_fuzz.cpp -lsodium -o "$bin"
fi
exec "$bin" -max_total_time="$seconds" -print_final_stats=1 -artifact_prefix=build/fuzz/ \
  build/fuzz/corpus fuzz/corpus/mfb_packet
