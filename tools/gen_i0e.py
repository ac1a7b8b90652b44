#!/usr/bin/env python3
"""Generate the Chebyshev coefficients used by `fiberlab_math::special::i0e`.

i0e(x) = exp(-x) I0(x) is approximated piecewise:
  * x in [a, b] for [0,2], [2,4], [4,8], [8,16]:  i0e(x) = sum_k c_k T_k((2x - a - b)/(b - a))
  * x > 16:  sqrt(x) i0e(x) = sum_k c_k T_k(32/x - 1)
Coefficients come from Chebyshev interpolation of 40-digit mpmath values and are
truncated where they drop below 1e-17 of the function's magnitude on the piece.
Run: python3 tools/gen_i0e.py  (needs mpmath)
"""
import mpmath as mp

mp.mp.dps = 40
N = 48


def cheb_coeffs(f):
    nodes = [mp.cos(mp.pi * (j + mp.mpf(1) / 2) / N) for j in range(N)]
    vals = [f(t) for t in nodes]
    cs = []
    for k in range(N):
        s = mp.fsum(vals[j] * mp.cos(mp.pi * k * (j + mp.mpf(1) / 2) / N) for j in range(N))
        cs.append(2 * s / N)
    cs[0] /= 2
    return cs


def trim(cs, tol):
    last = max(i for i, c in enumerate(cs) if abs(c) > tol)
    return cs[: last + 1]


def i0e(x):
    return mp.besseli(0, x) * mp.exp(-x)


def emit(name, cs):
    print(f"const {name}: [f64; {len(cs)}] = [")
    for c in cs:
        print(f"    {float(c)!r},")
    print("];")


for a, b in ((0, 2), (2, 4), (4, 8), (8, 16)):
    cs = cheb_coeffs(lambda t: i0e((b - a) / 2 * t + (a + b) / 2))
    emit(f"I0E_{a}_{b}", trim(cs, mp.mpf("1e-17") * i0e(b)))

tail = cheb_coeffs(lambda t: mp.sqrt(32 / (t + 1)) * i0e(32 / (t + 1)) if t > -1 else 1 / mp.sqrt(2 * mp.pi))
emit("I0E_TAIL", trim(tail, mp.mpf("1e-17") * 0.4))
