#!/usr/bin/python3
"""Print SciPy's digital Butterworth low-pass coefficients, the reference for peha's design.

peha designs the filter itself (src/control/butterworth.cpp: analog prototype poles, pre-warping,
bilinear transform, zeros at z = -1, unity DC gain). tests/control/butterworth_test.cpp compares its
direct-form polynomials b, a with the output of

    scipy.signal.butter(order, cutoff_Hz, btype="low", fs=sample_rate_Hz)   # (b, a)

pasted there as constants. This script regenerates them: every order given with --order is combined
with every (cut-off, sample-rate) pair given with --cutoff-hz and --fs-hz (a single --fs-hz applies to
every cut-off).

    /usr/bin/python3 tools/check_butterworth_scipy.py --order 2 --cutoff-hz 6 --fs-hz 200
    /usr/bin/python3 tools/check_butterworth_scipy.py --order 1 2 4 5 8 \\
        --cutoff-hz 6 20 50 --fs-hz 200 200 1000 --format cpp     # the test's table

--format text (default) prints b, a, the second-order sections (scipy's own pairing and ordering,
which need not equal peha's: only the products b, a are compared), the gains at DC and at the
cut-off and, with --group-delay-hz, scipy.signal.group_delay in seconds; --format cpp prints rows of the test's reference table; --format json prints everything
machine-readably.

Run with /usr/bin/python3 (scipy lives there, not in the python3 on PATH).
"""

from __future__ import annotations

import argparse
import json
import math
import sys

import numpy as np
from scipy import signal


def design(order: int, cutoff_hz: float, fs_hz: float, delay_freqs_hz: list[float]) -> dict:
    """SciPy's design for one case, with the checks peha's tests make on its own design."""
    if not 1 <= order <= 8:
        raise ValueError(f"order must be in 1..8 (peha's range), got {order}")
    if not 0.0 < cutoff_hz < fs_hz / 2.0:
        raise ValueError(f"need 0 < cutoff < fs/2, got cutoff {cutoff_hz} Hz at fs {fs_hz} Hz")
    b, a = signal.butter(order, cutoff_hz, btype="low", fs=fs_hz)
    sos = signal.butter(order, cutoff_hz, btype="low", fs=fs_hz, output="sos")
    _, h = signal.freqz(b, a, worN=[0.0, cutoff_hz], fs=fs_hz)
    delays_s = []
    if delay_freqs_hz:
        _, gd_samples = signal.group_delay((b, a), w=delay_freqs_hz, fs=fs_hz)
        delays_s = [float(v) / fs_hz for v in gd_samples]
    return {
        "order": order,
        "cutoff_Hz": cutoff_hz,
        "sample_rate_Hz": fs_hz,
        "b": [float(v) for v in b],
        "a": [float(v) for v in a],
        "sos": [[float(v) for v in row] for row in sos],
        "gain_dc": float(abs(h[0])),
        "gain_cutoff": float(abs(h[1])),
        "gain_cutoff_dB": float(20.0 * math.log10(abs(h[1]))),
        "group_delay_s": dict(zip((repr(f) for f in delay_freqs_hz), delays_s)),
    }


def cpp_list(values: list[float]) -> str:
    return "{" + ", ".join(repr(v) for v in values) + "}"


def print_text(d: dict) -> None:
    print(f"order {d['order']}, cutoff {d['cutoff_Hz']:g} Hz, fs {d['sample_rate_Hz']:g} Hz")
    print("  b   = " + " ".join(repr(v) for v in d["b"]))
    print("  a   = " + " ".join(repr(v) for v in d["a"]))
    for i, row in enumerate(d["sos"]):
        print(f"  sos[{i}] (b0 b1 b2 a0 a1 a2) = " + " ".join(repr(v) for v in row))
    print(f"  |H(0)| = {d['gain_dc']!r}, |H(fc)| = {d['gain_cutoff']!r} ({d['gain_cutoff_dB']:.6f} dB;"
          f" 1/sqrt(2) = {1.0 / math.sqrt(2.0)!r})")
    for f, tau in d["group_delay_s"].items():
        print(f"  group delay at {f} Hz = {tau!r} s")


def print_cpp(d: dict) -> None:
    print(f"    {{{d['order']}, {d['cutoff_Hz']!r}, {d['sample_rate_Hz']!r},")
    print(f"     {cpp_list(d['b'])},")
    print(f"     {cpp_list(d['a'])}}},")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description="Print scipy.signal.butter's low-pass coefficients (the reference of peha's "
                    "Butterworth design tests).",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="Example: /usr/bin/python3 tools/check_butterworth_scipy.py --order 1 2 4 5 8 "
               "--cutoff-hz 6 20 50 --fs-hz 200 200 1000 --format cpp")
    parser.add_argument("--order", type=int, nargs="+", default=[2], metavar="N",
                        help="filter order(s), 1..8 (default: 2)")
    parser.add_argument("--cutoff-hz", type=float, nargs="+", default=[6.0], metavar="FC",
                        help="-3 dB cut-off frequency(ies), Hz (default: 6)")
    parser.add_argument("--fs-hz", type=float, nargs="+", default=[200.0], metavar="FS",
                        help="sample rate(s), Hz: one per cut-off, or one for all (default: 200)")
    parser.add_argument("--group-delay-hz", type=float, nargs="*", default=[], metavar="F",
                        help="also print scipy.signal.group_delay at these frequencies, in s")
    parser.add_argument("--format", choices=["text", "cpp", "json"], default="text",
                        help="output format (default: text)")
    args = parser.parse_args(argv)

    if len(args.fs_hz) == 1:
        fs_list = args.fs_hz * len(args.cutoff_hz)
    elif len(args.fs_hz) == len(args.cutoff_hz):
        fs_list = args.fs_hz
    else:
        parser.error("give one --fs-hz, or one per --cutoff-hz")

    try:
        cases = [design(n, fc, fs, args.group_delay_hz) for fc, fs in zip(args.cutoff_hz, fs_list) for n in args.order]
    except ValueError as e:
        parser.error(str(e))

    if args.format == "json":
        json.dump({"scipy": __import__("scipy").__version__, "numpy": np.__version__, "cases": cases},
                  sys.stdout, indent=2)
        print()
    elif args.format == "cpp":
        print(f"    // {{order, cutoff_Hz, sample_rate_Hz, b, a}}: scipy {__import__('scipy').__version__}"
              " signal.butter(order, cutoff_Hz, fs=sample_rate_Hz)")
        for d in cases:
            print_cpp(d)
    else:
        for d in cases:
            print_text(d)
    return 0


if __name__ == "__main__":
    sys.exit(main())
