//! fiberlab's PROSPECT-D (`feret_2017`) against the independent `prosail` package: six leaves
//! (healthy, pale, dark, anthocyanin-red, senescent with brown pigments, a single plate), their
//! hemispherical reflectance and transmittance every 10 nm from 400 to 800 nm, in a table that
//! `bench/leaf_proof/prosail_table.py` produced from `prosail` 2.0.5 (not from fiberlab).
//! fiberlab integrates the face transmissivity numerically where `prosail` uses its closed
//! form, so agreement is to the quadrature's accuracy, not bit for bit.

use fiberlab_scatter::feret_2017::{LeafContents, START_NM, WAVELENGTHS, leaf_spectra};

/// A leaf's reflectance and transmittance spectra, 400 … 800 nm.
type Spectra = ([f64; WAVELENGTHS], [f64; WAVELENGTHS]);

#[test]
fn reflectance_and_transmittance_match_prosail() {
    let table = include_str!("data/prosail_prospect_d.csv");
    let (mut worst_r, mut worst_t, mut rows) = (0.0f64, 0.0f64, 0);
    let mut cached: Option<(String, Spectra)> = None;
    for line in table.lines().skip(1) {
        let v: Vec<&str> = line.split(',').collect();
        let x: Vec<f64> = v[1..].iter().map(|s| s.parse().unwrap()).collect();
        if cached.as_ref().is_none_or(|(name, _)| name != v[0]) {
            let c = LeafContents { n: x[0], cab: x[1], car: x[2], anth: x[3], cbrown: x[4], cw: x[5], cm: x[6] };
            cached = Some((v[0].to_string(), leaf_spectra(&c)));
        }
        let (_, (r, t)) = cached.as_ref().unwrap();
        let k = (x[7] - START_NM) as usize;
        worst_r = worst_r.max((r[k] - x[8]).abs());
        worst_t = worst_t.max((t[k] - x[9]).abs());
        rows += 1;
    }
    println!("{rows} values: largest |ΔR| {worst_r:.2e}, |ΔT| {worst_t:.2e}");
    assert_eq!(rows, 6 * 41);
    assert!(worst_r < 1e-9 && worst_t < 1e-9, "ΔR {worst_r}, ΔT {worst_t}");
}
