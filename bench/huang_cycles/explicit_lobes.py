"""The explicit rough fiber's lobes toward the camera of the front-lit single-fiber cases: reads a
`fiberlab measure` table (CSV of f per lobe class and bin) and prints, per class (r, tt, trt,
higher, all), the radiance f·E·cos θ_i averaged over the bins that the compared region sees: θ_o
within ±6.8° (±0.48 of the fiber's length seen from 4 away; bins partly inside weighted by their
overlap) and |φ| in [25°, 30°] (the front light is 26.6° from the camera about the fiber).
Run with the bench's venv python; the book's "The front-lit excess, lobe by lobe" gives the
measure command.

usage: explicit_lobes.py TABLE.csv [THETA_I_DEGREES (15.02)]
"""

import csv
import math
import sys

from cases import EYE, FRONT_LIGHT, IRRADIANCE, REGION_HALF_LENGTH


def main():
    rows = list(csv.DictReader(open(sys.argv[1])))
    theta_i = math.radians(float(sys.argv[2]) if len(sys.argv) > 2 else 15.02)
    half_span = math.degrees(math.atan(REGION_HALF_LENGTH / EYE[2]))
    light = FRONT_LIGHT[1:]
    phi = math.degrees(math.atan2(light[0], light[1]))
    thetas = sorted({float(r["theta_r"]) for r in rows})
    phis = sorted({float(r["phi_r"]) for r in rows})
    dt, dp = thetas[1] - thetas[0], phis[1] - phis[0]
    overlap = lambda c, w, lo, hi: max(0.0, min(c + w / 2, hi) - max(c - w / 2, lo)) / w  # noqa: E731
    print(f"θ_o within ±{half_span:.2f}°, |φ| = {phi:.2f}° ({dt:g}° × {dp:g}° bins), E cos θ_i:")
    for lobe in ("r", "tt", "trt", "higher", "all"):
        total, var, weight = [0.0] * 3, [0.0] * 3, 0.0
        for r in rows:
            if r["lobe"] != lobe:
                continue
            w = overlap(float(r["theta_r"]), dt, -half_span, half_span) * (
                abs(abs(float(r["phi_r"])) - phi) < dp / 2)
            if w > 0:
                weight += w
                for c, k in enumerate("rgb"):
                    total[c] += w * float(r["f_" + k])
                    var[c] += (w * float(r["std_" + k])) ** 2
        scale = [e * math.cos(theta_i) / weight for e in IRRADIANCE]
        print(f"{lobe:7s}", " ".join(f"{t * s:.5f}" for t, s in zip(total, scale)), " ± ",
              " ".join(f"{math.sqrt(v) * s:.5f}" for v, s in zip(var, scale)))


if __name__ == "__main__":
    main()
