//! The factor by which Cycles brightens every rough interface crossing of its Huang hair,
//! `1/E(μ)` with `E = E_R + E_T` the single-scattering directional albedo of a GGX dielectric
//! interface (Cycles reads it from its glass tables in `bsdf_hair_huang_energy_scale`; fiberlab
//! and the paper use no such factor). Computed here by fiberlab's own quadrature
//! (`hair::rough_interface::InterfaceAlbedo::albedos`), entering the fiber (η = 1.55) and leaving
//! it (1/1.55), to explain the Cycles comparison of `bench/huang_cycles` (docs/theory/
//! peer-discrepancies.md, "Huang 2022 against Cycles").
//!
//! `cargo run --release -p fiberlab-scatter --example huang_energy_scale`

use fiberlab_math::microfacet::Ggx;
use fiberlab_scatter::hair::rough_interface::InterfaceAlbedo;

fn main() {
    let eta = 1.55;
    let mus = [1.0, 0.9, 0.7, 0.5, 0.3];
    println!("1/E(μ), E = E_R + E_T of one GGX interface (single scattering), η = {eta} (entering) | 1/η (leaving)");
    print!("| α |");
    for mu in mus {
        print!(" μ = {mu} |");
    }
    println!();
    println!("|---|{}", "---|".repeat(mus.len()));
    for alpha in [0.05, 0.1, 0.2, 0.3, 0.5] {
        let ggx = Ggx::new(alpha);
        print!("| {alpha} |");
        for mu in mus {
            let (r, t) = InterfaceAlbedo::albedos(&ggx, eta, mu);
            let (ri, ti) = InterfaceAlbedo::albedos(&ggx, 1.0 / eta, mu);
            print!(" {:.3} \\| {:.3} |", 1.0 / (r + t), 1.0 / (ri + ti));
        }
        println!();
    }
}
