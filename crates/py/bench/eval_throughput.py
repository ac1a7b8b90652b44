"""Throughput of `Model.eval_fs`, `eval`, `pdf` and `sample` from Python against the same parallel loops timed inside Rust.

Issue target: evaluating 10⁶ directions of `chiang` from Python costs at most 1.2× the Rust
loop. Both are timed in this process on the same arrays: `fiberlab._native._bench_rust`
times the loop behind each method (output allocation included, input checks excluded); the
Python figure is the whole call — `m.eval_fs(wi, wo, h)`, `m.eval(...)`, `m.pdf(...)`,
`m.sample(wo, u, h)` — with broadcasting, checks and the GIL release. Prints the median of
`--repeats` runs of each and their ratio.

    python crates/py/bench/eval_throughput.py [--n 1000000] [--repeats 5]
"""

import argparse
import statistics
import time

import numpy as np

import fiberlab as fl
from fiberlab import _native


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1_000_000, help="direction pairs per call")
    ap.add_argument("--repeats", type=int, default=5, help="timed runs of each (median)")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()

    rng = np.random.default_rng(args.seed)
    theta = rng.uniform(-1.5, 1.5, size=(2, args.n))
    phi = rng.uniform(-np.pi, np.pi, size=(2, args.n))
    wi = fl.directions_from_angles(theta[0], phi[0])
    wo = fl.directions_from_angles(theta[1], phi[1])
    h = rng.uniform(-1, 1, size=args.n)
    u = rng.uniform(0, 1, size=(args.n, 4))
    m = fl.Chiang(eumelanin=0.8, beta_m=0.3, beta_n=0.3)

    methods = [
        ("eval_fs", "fs", lambda: m.eval_fs(wi, wo, h)),
        ("eval", "fs_cos", lambda: m.eval(wi, wo, h)),
        ("pdf", "pdf", lambda: m.pdf(wi, wo, h)),
        ("sample", "sample", lambda: m.sample(wo, u, h)),
    ]
    m.eval_fs(wi[:1000], wo[:1000], h[:1000])  # warm up the thread pool
    print(f"chiang, {args.n} pairs, median of {args.repeats} (target: ratio ≤ 1.2):")
    for name, loop, call in methods:
        rust, python = [], []
        for _ in range(args.repeats):
            rust.append(_native._bench_rust(m._native, loop, wi, wo, h, u))
            start = time.perf_counter()
            call()
            python.append(time.perf_counter() - start)
        r, p = statistics.median(rust), statistics.median(python)
        print(f"  {name:8} Rust loop {r * 1e3:8.2f} ms ({args.n / r / 1e6:6.2f} M/s)   "
              f"Python call {p * 1e3:8.2f} ms ({args.n / p / 1e6:6.2f} M/s)   ratio {p / r:.3f}")


if __name__ == "__main__":
    main()
