#!/usr/bin/env python3
"""PROSPECT-D reference values from the independent `prosail` package (J. Gómez-Dans; test-only,
never a fiberlab dependency), for fiberlab's own implementation (`crates/scatter/src/feret_2017.rs`)
to be compared against: the leaf's hemispherical reflectance and transmittance (acceptance angle
40°) of several leaves at every 10 nm from 400 to 800 nm.

Usage (in a throw-away environment): pip install prosail==2.0.5; python3 bench/leaf_proof/prosail_table.py
Writes crates/scatter/tests/data/prosail_prospect_d.csv.
"""
import prosail

# name, N, Cab, Car, Anth, Cbrown, Cw, Cm
LEAVES = [
    ("healthy", 1.5, 40.0, 8.0, 0.0, 0.0, 0.01, 0.009),
    ("pale", 1.2, 10.0, 3.0, 0.0, 0.0, 0.005, 0.004),
    ("dark", 2.2, 80.0, 15.0, 0.0, 0.0, 0.02, 0.012),
    ("red", 1.8, 30.0, 10.0, 15.0, 0.0, 0.012, 0.008),
    ("senescent", 2.0, 5.0, 6.0, 2.0, 1.0, 0.004, 0.015),
    ("one_plate", 1.0, 25.0, 5.0, 1.0, 0.0, 0.008, 0.005),
]
rows = ["leaf,n,cab,car,anth,cbrown,cw,cm,wavelength_nm,reflectance,transmittance"]
for name, n, cab, car, anth, cbrown, cw, cm in LEAVES:
    wv, r, t = prosail.run_prospect(n, cab, car, cbrown, cw, cm, ant=anth, prospect_version="D")
    for k, w in enumerate(wv):
        if 400 <= w <= 800 and w % 10 == 0:
            rows.append(f"{name},{n},{cab},{car},{anth},{cbrown},{cw},{cm},{int(w)},{r[k]:.12g},{t[k]:.12g}")
open("crates/scatter/tests/data/prosail_prospect_d.csv", "w").write("\n".join(rows) + "\n")
print(f"{len(rows) - 1} rows")
