//! `fiberlab texture wood`: the maps it writes read back as the figure's functions.

use fiberlab_procedural::figured_maple::MapleFigure;
use fiberlab_render::texture::{Encoding, Texture, Wrap};
use std::process::Command;

#[test]
fn texture_wood_writes_maps_that_read_back_as_the_figure() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("maple");
    let status = Command::new(env!("CARGO_BIN_EXE_fiberlab"))
        .args(["texture", "wood", "--width", "64", "--height", "16", "--stripes", "5", "--dip", "25", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
    let figure = MapleFigure { width: 64, height: 16, stripes: 5.0, dip_amplitude_deg: 25.0, ..MapleFigure::default() };
    let dip = Texture::read(&out.join("fiber_dip.png"), Encoding::Linear, Wrap::Clamp).unwrap().remapped(-90.0, 90.0);
    let angle =
        Texture::read(&out.join("fiber_angle.png"), Encoding::Linear, Wrap::Clamp).unwrap().remapped(-90.0, 90.0);
    assert_eq!((dip.width(), dip.height()), (64, 16));
    // 16-bit codes over 180°: within half a code.
    let code = 180.0 / 65535.0;
    for (x, y) in [(0, 0), (17, 3), (63, 15), (40, 9)] {
        let (u, v) = ((x as f64 + 0.5) / 64.0, 1.0 - (y as f64 + 0.5) / 16.0);
        assert!((dip.texel(x, y)[0] - figure.dip_deg(u, v)).abs() <= 0.5 * code + 1e-4, "dip at ({x}, {y})");
        assert!((angle.texel(x, y)[0] - figure.angle_deg(u, v)).abs() <= 0.5 * code + 1e-4, "angle at ({x}, {y})");
    }
    let k_d = Texture::read(&out.join("k_d.png"), Encoding::Srgb, Wrap::Clamp).unwrap();
    let expected = figure.k_d((3.5) / 64.0, 1.0 - 2.5 / 16.0);
    for k in 0..3 {
        // 8-bit sRGB: within a code's step at these levels.
        assert!((k_d.texel(3, 2)[k] - expected[k]).abs() < 5e-3, "{:?} vs {expected:?}", k_d.texel(3, 2));
    }
    let bad = Command::new(env!("CARGO_BIN_EXE_fiberlab"))
        .args(["texture", "wood", "--dip", "120", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!bad.status.success() && String::from_utf8_lossy(&bad.stderr).contains("--dip"));
}
