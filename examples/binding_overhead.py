#!/usr/bin/env python3
"""Call overhead of the Python bindings (docs/python.md): one inverse-model call from Python, and one
call on 10^5-element arrays, in CPU time (the machine may be shared). Compare with the C++ figure of
`peha_bench --benchmark_filter=BM_TendonSpringInverse` (CPU column).

    PYTHONPATH=build/release/python /usr/bin/python3 examples/binding_overhead.py
"""
import pathlib
import time

import numpy as np

import peha

ROOT = pathlib.Path(__file__).resolve().parents[1]


def cpu_per_call(f, n):
    best = float("inf")
    for _ in range(5):
        t0 = time.process_time()
        for _ in range(n):
            f()
        best = min(best, (time.process_time() - t0) / n)
    return best


def main():
    pam = peha.Rig(str(ROOT / "configs" / "e1_one_dof.yaml")).joint.agonist.pam
    rng = np.random.default_rng(1)
    F, eps = rng.uniform(20, 1500, 100_000), rng.uniform(0.03, 0.17, 100_000)
    f0, e0 = float(F[0]), float(eps[0])
    one = cpu_per_call(lambda: peha.inverse_pressure(pam, f0, e0, 0.8e6), 200_000)
    empty = cpu_per_call(lambda: None, 200_000)
    arr = cpu_per_call(lambda: peha.inverse_pressure(pam, F, eps, 0.8e6), 20)
    one_arr = cpu_per_call(lambda: peha.inverse_pressure(pam, F[:1], eps[:1], 0.8e6), 50_000)
    print(f"scalar call:          {one * 1e9:8.0f} ns per call (an empty Python lambda call: {empty * 1e9:.0f} ns)")
    print(f"1-element array call: {one_arr * 1e9:8.0f} ns per call")
    print(f"10^5-element call:    {arr * 1e3:8.2f} ms per call = {arr / F.size * 1e9:.1f} ns per element")


if __name__ == "__main__":
    main()
