//! `fiberlab mesh cloth` and `fiberlab montage`, the two commands of `gallery/cloth.sh`: the
//! written mesh reads back with its uvs and the sphere outside it; the sheet has the grid's
//! size and each tile's pixels; bad input is refused.

mod fiberlab_process;
use fiberlab_math::DVec3;
use fiberlab_process::fiberlab;

#[test]
fn mesh_cloth_writes_a_textured_mesh_clear_of_the_sphere() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sub/cloth.obj");
    fiberlab().args(["mesh", "cloth", "--resolution", "40", "--out"]).arg(&out).assert().success();
    let mesh = fiberlab_io::obj::read_obj(&out, 1.0, DVec3::ZERO).unwrap();
    assert!(mesh.has_uvs());
    assert_eq!(mesh.len(), 2 * 40 * 40);
    // Straight down from above the top onto the sphere (radius 0.5, centre (0, 0.5, 0)): the
    // cloth is hit first, above the sphere's top y = 1.
    let text = std::fs::read_to_string(&out).unwrap();
    let top = text
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| l.split_whitespace().map(|w| w.parse::<f64>().unwrap()).collect::<Vec<_>>())
        .filter(|p| p[0].hypot(p[2]) < 0.05)
        .map(|p| p[1])
        .fold(f64::INFINITY, f64::min);
    assert!(top > 1.0 && top < 1.02, "cloth height over the sphere's top: {top}");
    let refused = fiberlab().args(["mesh", "cloth", "--resolution", "8", "--out"]).arg(&out).assert().failure();
    let err = String::from_utf8(refused.get_output().stderr.clone()).unwrap();
    assert!(err.contains("resolution = 8 must be ≥ 32"), "{err}");
}

#[test]
fn montage_lays_tiles_out_in_a_grid() {
    let dir = tempfile::tempdir().unwrap();
    let colours = [[255u8, 0, 0], [0, 255, 0], [0, 0, 255]];
    let mut files = Vec::new();
    for (k, c) in colours.iter().enumerate() {
        let path = dir.path().join(format!("t{k}.png"));
        image::RgbImage::from_pixel(30, 20, image::Rgb(*c)).save(&path).unwrap();
        files.push(format!("{}=tile {k}", path.display()));
    }
    let out = dir.path().join("sheet.png");
    fiberlab().args(["montage", "--columns", "2", "--out"]).arg(&out).args(&files).assert().success();
    let sheet = image::open(&out).unwrap().to_rgb8();
    // Cells of (30 + 4) × (20 + 20 label + 4), two columns, two rows.
    assert_eq!(sheet.dimensions(), (2 * 34, 2 * 44));
    for (k, c) in colours.iter().enumerate() {
        let (x0, y0) = ((k as u32 % 2) * 34 + 2, (k as u32 / 2) * 44 + 22);
        for (x, y) in [(0, 0), (29, 19), (15, 10)] {
            assert_eq!(sheet.get_pixel(x0 + x, y0 + y).0, *c, "tile {k} at ({x}, {y})");
        }
    }
    let small = dir.path().join("small.png");
    image::RgbImage::new(10, 10).save(&small).unwrap();
    let refused = fiberlab().args(["montage", "--out"]).arg(&out).arg(&files[0]).arg(&small).assert().failure();
    let err = String::from_utf8(refused.get_output().stderr.clone()).unwrap();
    assert!(err.contains("10×10, the first image is 30×20"), "{err}");
}
