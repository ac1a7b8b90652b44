#!/usr/bin/env python3
"""Generate the Chebyshev coefficients used by `fiberlab_math::special::i0e`.

i0e(x) = exp(-x) I0(x) is approximated on two pieces:
  * x in [0, 8]:  i0e(x)         = sum_k a_k T_k(x/4 - 1)
  * x > 8:        sqrt(x) i0e(x) = sum_k b_k T_k(16/x - 1)
Coefficients come from Chebyshev interpolation of 50-digit mpmath values and are
truncated where they drop below 1e-18 of the function's magnitude.
Run: python3 tools/gen_i0e.py  (needs mpmath)
"""
import mpmath as mp

mp.mp.dps = 50
N = 60


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


small = trim(cheb_coeffs(lambda t: i0e(4 * (t + 1))), mp.mpf("1e-18"))
large = trim(cheb_coeffs(lambda t: mp.sqrt(16 / (t + 1)) * i0e(16 / (t + 1)) if t > -1 else 1 / mp.sqrt(2 * mp.pi)), mp.mpf("1e-18"))

for name, cs in (("I0E_SMALL", small), ("I0E_LARGE", large)):
    print(f"const {name}: [f64; {len(cs)}] = [")
    for c in cs:
        print(f"    {float(c)!r},")
    print("];")
