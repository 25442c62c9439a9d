#!/usr/bin/env bash
# The board core as a firmware links it: prints its size (arm-none-eabi-size) and fails if it
# needs a heap, C++ run-time or an OS: every symbol it leaves undefined must be one a bare-metal C
# library provides without them (memory and string helpers, the maths of the set-up, snprintf for
# the set-up's messages, the compiler's helpers).
# Usage: check-firmware-symbols.sh NM SIZE OBJECT...
set -euo pipefail
nm="$1" size="$2"
shift 2
"$size" -t "$@"
defined="$("$nm" --defined-only "$@" | awk 'NF == 3 {print $3}' | sort -u)"
undefined="$("$nm" -u "$@" | awk 'NF == 2 {print $2}' | sort -u | comm -23 - <(echo "$defined"))"
echo "undefined: $(echo $undefined)"
allowed='^(memcpy|memset|memmove|memcmp|snprintf|floor|ceil|fabs|__aeabi_[a-z0-9]+)$'
bad="$(echo "$undefined" | grep -Ev "$allowed" || true)"
if [ -n "$bad" ]; then
  echo "check-firmware-symbols: the core needs symbols outside a bare-metal C library: $(echo $bad)" >&2
  exit 1
fi
