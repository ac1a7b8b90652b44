#!/usr/bin/env python3
"""Reads the woven-patch tables (bench/cloth_proof/{plain,twill}.csv) and prints, per
incidence, the features the closing note of issue 20 asks about: where the highlight is
(peak bin of the `all` class), the backscatter/forward ratio, the anisotropy between the
weft (x) and warp (y) planes, and the grazing sheen. Pure Python, no packages."""
import csv, math, sys, os

def read(path):
    rows = {}
    with open(path) as f:
        lines = [l for l in f if not l.startswith('#')]
    for r in csv.DictReader(lines):
        if r['lobe'] != 'all':
            continue
        ti = float(r['theta_i'])
        lum = 0.2126 * float(r['f_r']) + 0.7152 * float(r['f_g']) + 0.0722 * float(r['f_b'])
        rows.setdefault(ti, {})[(float(r['theta_r']), float(r['phi_r']))] = lum
    return rows

def near(table, t, p):
    return min(table, key=lambda k: (k[0] - t) ** 2 + (((k[1] - p + 180) % 360) - 180) ** 2)

def main():
    here = os.path.dirname(os.path.abspath(__file__))
    for name in sys.argv[1:] or ['plain', 'twill']:
        data = read(os.path.join(here, name + '.csv'))
        print(f'{name}: θ_i | peak (θ_o, φ_o) f_r | back f(θ_i, 0°) | mirror f(θ_i, 180°) | back/mirror | '
              f'f(45°, ±90°: y plane)/f(45°, 0°/180° mean: x plane) | grazing f(87.5°, 180°)/f(42.5°, 180°)')
        for ti in sorted(data):
            t = data[ti]
            peak = max(t, key=t.get)
            back = t[near(t, ti, 0.0)]
            mirror = t[near(t, ti, 180.0)]
            yplane = 0.5 * (t[near(t, 45, 90)] + t[near(t, 45, -90)])
            xplane = 0.5 * (t[near(t, 45, 0)] + t[near(t, 45, 180)])
            graze = t[near(t, 87.5, 180)] / max(t[near(t, 42.5, 180)], 1e-30)
            print(f'  {ti:4.0f}° | ({peak[0]:.1f}°, {peak[1]:.0f}°) {t[peak]:.4f} | {back:.4f} | {mirror:.4f} | '
                  f'{back / mirror:.2f} | {yplane / xplane:.2f} | {graze:.2f}')

main()
