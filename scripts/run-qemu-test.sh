#!/usr/bin/env bash
# Runs a semihosting test program on QEMU's Cortex-M7 board (mps2-an500) and judges it.
# The program ends QEMU with the semihosting exit call; `timeout` ends a program that hangs (the
# test then fails, naming the timeout). -icount shift=0: one instruction = 1 ns of virtual time, so
# the program's cost figures are instruction counts. Passes only if QEMU exited 0 and the program's
# last line reports 0 failed.
# Usage: run-qemu-test.sh QEMU ELF TIMEOUT_S
set -uo pipefail
qemu="$1" elf="$2" limit="$3"
log="$(mktemp)"
trap 'rm -f "$log"' EXIT
timeout --kill-after=5 "$limit" "$qemu" -M mps2-an500 -cpu cortex-m7 -nographic -monitor none -serial none \
  -semihosting-config enable=on,target=native -icount shift=0 -kernel "$elf" >"$log" 2>&1
rc=$?
cat "$log"
if [ "$rc" -eq 124 ] || [ "$rc" -eq 137 ]; then
  echo "run-qemu-test: $elf did not end within $limit s (QEMU stopped by timeout)" >&2
  exit 1
fi
if [ "$rc" -ne 0 ]; then
  echo "run-qemu-test: QEMU exited $rc" >&2
  exit 1
fi
if ! tail -n 1 "$log" | grep -q " 0 failed"; then
  echo "run-qemu-test: the program's last line does not report 0 failed" >&2
  exit 1
fi
