"""What `eval_fs`, `eval`, `pdf` and `sample` allocate on 10⁶ × 3 arrays: only their outputs.

The outputs are NumPy arrays allocated by NumPy, which reports its allocations to
`tracemalloc`; the Rust loops write into them in place and allocate nothing per element
(`crates/py/src/lib.rs`, `eval_loop` and `sample_loop`). The traced peak of a call must
therefore be its output's bytes, within 5 % plus a small constant, and at least the output
(which shows the measurement sees the allocation at all).
"""

import tracemalloc

import numpy as np
import pytest

import fiberlab as fl

N = 1_000_000
SLACK = 64 * 1024  # bytes: Python objects of the call (tuples, the result wrappers)


@pytest.fixture(scope="module")
def arrays():
    rng = np.random.default_rng(7)
    wi = fl.directions_from_angles(rng.uniform(-1.5, 1.5, N), rng.uniform(-np.pi, np.pi, N))
    wo = fl.directions_from_angles(rng.uniform(-1.5, 1.5, N), rng.uniform(-np.pi, np.pi, N))
    return wi, wo, rng.uniform(-1, 1, N), rng.uniform(0, 1, (N, 4))


def traced_peak(call):
    """(result, peak bytes traced during `call()` above what was allocated before it)."""
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        tracemalloc.reset_peak()
        out = call()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    return out, peak - before


@pytest.mark.parametrize("method", ["eval_fs", "eval", "pdf"])
def test_evaluation_allocates_only_its_output(arrays, method):
    wi, wo, h, _ = arrays
    m = fl.Chiang(eumelanin=0.8)
    f = getattr(m, method)
    f(wi[:10], wo[:10], h[:10])  # warm up (thread pool, lazily built state)
    out, peak = traced_peak(lambda: f(wi, wo, h))
    assert out.shape == ((N,) if method == "pdf" else (N, 3))
    assert out.nbytes <= peak <= 1.05 * out.nbytes + SLACK, (method, peak, out.nbytes)


def test_sampling_allocates_only_its_outputs(arrays):
    _, wo, h, u = arrays
    m = fl.Chiang(eumelanin=0.8)
    m.sample(wo[:10], u[:10], h[:10])
    s, peak = traced_peak(lambda: m.sample(wo, u, h))
    total = sum(a.nbytes for a in s)
    assert total == N * (3 * 8 + 3 * 8 + 8 + 4)
    assert total <= peak <= 1.05 * total + SLACK, (peak, total)


def test_broadcast_inputs_are_copied_once_and_counted(arrays):
    """The measurement can fail: a broadcast argument must be made contiguous, a copy the
    traced peak then shows beside the output."""
    wi, wo, h, _ = arrays
    m = fl.Chiang(eumelanin=0.8)
    out, peak = traced_peak(lambda: m.eval_fs(wi, wo[0], h))
    copy = wi.nbytes  # wo[0] broadcast to (N, 3)
    assert peak >= out.nbytes + copy, (peak, out.nbytes, copy)
