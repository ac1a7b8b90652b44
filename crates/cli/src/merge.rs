//! `fiberlab merge`: combine parts rendered with `--tile I/N` (or disjoint `--crop`s) of one
//! scene, seed and sample count into the image a single machine would have rendered, bit for
//! bit.
//!
//! Every part carries, in its EXR header, what it is: the scene's hash, the seed, the samples
//! per pixel and `part = I/N` (or `crop = X0,Y0,X1,Y1`), written by `fiberlab render`. The
//! parts are checked before anything is added: each must be a part, all of one render
//! (scene, seed, spp, N and size), each `I` exactly once with none missing (crops: no two
//! overlapping, and together covering the whole image), and every pixel finite. The output
//! may not be one of the parts (`--out q0` would overwrite `q0.exr`). A problem is an error
//! naming the file and what is wrong; nothing is written then.

use anyhow::{Context, bail};
use fiberlab_io::{LinearImage, ToneMap};
use fiberlab_render::integrator::merge;
use std::path::{Path, PathBuf};

/// Flags of `fiberlab merge`.
#[derive(clap::Args)]
pub struct Args {
    /// Part images (EXR) written by `fiberlab render --tile I/N`.
    #[arg(required = true)]
    parts: Vec<PathBuf>,
    /// Output prefix: writes PREFIX.exr and PREFIX.png.
    #[arg(long, value_name = "PREFIX", default_value = "render", value_parser = crate::arg_values::out_prefix)]
    out: crate::arg_values::OutPrefix,
    /// Exposure for the PNG in stops.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true, value_parser = crate::arg_values::finite)]
    exposure: f64,
}

/// The header attributes every part has: the scene's hash, seed, samples per pixel; and
/// `part` (`I/N`) or `crop` (`X0,Y0,X1,Y1`).
pub const PART_ATTRIBUTES: [&str; 3] = ["scene", "seed", "spp"];

/// Where a part lies in the image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Place {
    /// Band `index` of `count`.
    Tile { index: usize, count: usize },
    /// The half-open rectangle x0, y0, x1, y1.
    Crop([u32; 4]),
}

/// What a part's header says it is.
#[derive(Clone, Debug, PartialEq, Eq)]
struct PartInfo {
    scene: String,
    seed: String,
    spp: String,
    place: Place,
}

fn part_info(path: &Path, image: &LinearImage) -> anyhow::Result<PartInfo> {
    let not_a_part = |key: &str| {
        format!(
            "{}: not a part written by `fiberlab render --tile I/N` or `--crop` (its header has no `{key}`)",
            path.display()
        )
    };
    if let Some(most) = image.attribute("spp_max") {
        bail!(
            "{}: an interrupted part (its pixels have {} to {most} spp); finish it with `fiberlab render … --resume {}` first",
            path.display(),
            image.attribute("spp").unwrap_or("?"),
            path.display()
        );
    }
    let get = |key: &str| image.attribute(key).map(str::to_string).with_context(|| not_a_part(key));
    let [scene, seed, spp] = PART_ATTRIBUTES.map(get);
    let place = match (image.attribute("part"), image.attribute("crop")) {
        (Some(part), _) => {
            let (index, count) = part
                .split_once('/')
                .and_then(|(i, n)| Some((i.parse::<usize>().ok()?, n.parse::<usize>().ok()?)))
                .filter(|&(i, n)| i < n)
                .with_context(|| format!("{}: its part `{part}` is not I/N with 0 ≤ I < N", path.display()))?;
            Place::Tile { index, count }
        }
        (None, Some(crop)) => {
            let v: Vec<u32> = crop.split(',').filter_map(|x| x.parse().ok()).collect();
            match v.as_slice() {
                &[x0, y0, x1, y1] if x0 < x1 && y0 < y1 => Place::Crop([x0, y0, x1, y1]),
                _ => bail!("{}: its crop `{crop}` is not X0,Y0,X1,Y1 with X0 < X1, Y0 < Y1", path.display()),
            }
        }
        (None, None) => bail!(not_a_part("part")),
    };
    Ok(PartInfo { scene: scene?, seed: seed?, spp: spp?, place })
}

/// Checks that `parts` are the whole set of parts of one render (see the module docs).
pub fn check_parts(parts: &[(PathBuf, LinearImage)]) -> anyhow::Result<()> {
    let Some((first_path, first)) = parts.first() else { bail!("no parts given") };
    let reference = part_info(first_path, first)?;
    let count = match reference.place {
        Place::Tile { count, .. } => count,
        Place::Crop(_) => 0,
    };
    let mut seen: Vec<Option<&Path>> = vec![None; count];
    let mut crops: Vec<(&Path, [u32; 4])> = Vec::new();
    for (path, image) in parts {
        let info = part_info(path, image)?;
        let differs = |what: &str, a: &str, b: &str| {
            anyhow::anyhow!(
                "{} and {}: not parts of one render ({what} {a} against {b})",
                first_path.display(),
                path.display()
            )
        };
        if info.scene != reference.scene {
            return Err(differs("scene hash", &reference.scene, &info.scene));
        }
        if info.seed != reference.seed {
            return Err(differs("seed", &reference.seed, &info.seed));
        }
        if info.spp != reference.spp {
            return Err(differs("spp", &reference.spp, &info.spp));
        }
        if (image.width(), image.height()) != (first.width(), first.height()) {
            let size = |i: &LinearImage| format!("{}×{}", i.width(), i.height());
            return Err(differs("size", &size(first), &size(image)));
        }
        match info.place {
            Place::Tile { count: n, .. } if n != count => {
                let shown = if count == 0 { "a crop".to_string() } else { count.to_string() };
                return Err(differs("split into", &shown, &n.to_string()));
            }
            Place::Tile { index, count } => {
                if let Some(other) = seen[index] {
                    bail!(
                        "{} and {}: both are part {index}/{count}; give each part once",
                        other.display(),
                        path.display()
                    );
                }
                seen[index] = Some(path);
            }
            Place::Crop(_) if count > 0 => return Err(differs("split into", &count.to_string(), "a crop")),
            Place::Crop(r) => {
                let overlaps = |a: [u32; 4], b: [u32; 4]| a[0] < b[2] && b[0] < a[2] && a[1] < b[3] && b[1] < a[3];
                if let Some((other, _)) = crops.iter().find(|(_, c)| overlaps(*c, r)) {
                    bail!("{} and {}: their crops overlap; give disjoint crops", other.display(), path.display());
                }
                crops.push((path, r));
            }
        }
        let bad = image.pixels().iter().position(|p| p.iter().any(|c| !c.is_finite()));
        if let Some(at) = bad {
            let count = image.pixels().iter().filter(|p| p.iter().any(|c| !c.is_finite())).count();
            bail!(
                "{}: {count} non-finite pixel(s), the first at x = {}, y = {}",
                path.display(),
                at % image.width(),
                at / image.width()
            );
        }
    }
    let missing: Vec<String> =
        seen.iter().enumerate().filter(|(_, s)| s.is_none()).map(|(i, _)| format!("{i}/{count}")).collect();
    if !missing.is_empty() {
        bail!("missing part(s) {} of the render of {}", missing.join(", "), first_path.display());
    }
    if !crops.is_empty() {
        // Disjoint crops cover the image exactly when their areas add up to it.
        let (w, h) = (first.width() as u64, first.height() as u64);
        let area = |c: [u32; 4]| u64::from(c[2].saturating_sub(c[0])) * u64::from(c[3].saturating_sub(c[1]));
        let covered: u64 = crops.iter().map(|(_, c)| area(*c)).sum();
        if covered < w * h {
            let inside = |x: u32, y: u32, c: [u32; 4]| x >= c[0] && x < c[2] && y >= c[1] && y < c[3];
            let hole = (0..h as u32)
                .flat_map(|y| (0..w as u32).map(move |x| (x, y)))
                .find(|&(x, y)| !crops.iter().any(|(_, c)| inside(x, y, *c)))
                .unwrap_or((0, 0));
            bail!(
                "the crops ({}) cover {covered} of the {w}×{h} image's {} pixels; the first pixel not covered is \
                 x = {}, y = {}: render the missing crops too",
                crops.iter().map(|(p, _)| p.display().to_string()).collect::<Vec<_>>().join(", "),
                w * h,
                hole.0,
                hole.1
            );
        }
    }
    Ok(())
}

/// Refuses outputs that are one of the parts (the same file, by name or by link): merging
/// would overwrite what it reads.
fn check_outputs_are_not_parts(parts: &[PathBuf], outputs: &[PathBuf]) -> anyhow::Result<()> {
    for out in outputs {
        for part in parts {
            if same_file(part, out) {
                bail!(
                    "--out {}: {} is the part {}; give another prefix (merging would overwrite a part)",
                    out.with_extension("").display(),
                    out.display(),
                    part.display()
                );
            }
        }
    }
    Ok(())
}

/// Whether `a` and `b` name one existing file (same device and inode on Unix; the same
/// canonical path elsewhere).
fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (std::fs::metadata(a), std::fs::metadata(b)) {
            (Ok(x), Ok(y)) => x.dev() == y.dev() && x.ino() == y.ino(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        matches!((std::fs::canonicalize(a), std::fs::canonicalize(b)), (Ok(x), Ok(y)) if x == y)
    }
}

/// Runs `fiberlab merge`.
pub fn run(args: &Args) -> anyhow::Result<()> {
    check_outputs_are_not_parts(&args.parts, &[args.out.with(".exr"), args.out.with(".png")])?;
    let parts: Vec<(PathBuf, LinearImage)> =
        args.parts.iter().map(|p| Ok((p.clone(), LinearImage::read_exr(p)?))).collect::<anyhow::Result<_>>()?;
    check_parts(&parts)?;
    let images: Vec<LinearImage> = parts.into_iter().map(|(_, image)| image).collect();
    // The attributes every part shares (scene, seed, spp) and the saved state travel on, so
    // the merged image can be continued with `fiberlab render --resume`.
    let image = merge(&images)?;
    image.write_exr(&args.out.with(".exr"))?;
    image.write_png(&args.out.with(".png"), args.exposure, ToneMap::Filmic)?;
    eprintln!("merged {} parts → {}.exr, {}.png", images.len(), args.out, args.out);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn part(i: usize, n: usize, seed: &str) -> (PathBuf, LinearImage) {
        let mut image = LinearImage::new(4, 4);
        for (k, v) in [("scene", "5f3a"), ("seed", seed), ("spp", "16")] {
            image.set_attribute(k, v);
        }
        image.set_attribute("part", format!("{i}/{n}"));
        (PathBuf::from(format!("p{i}_{seed}.exr")), image)
    }

    fn error(parts: &[(PathBuf, LinearImage)]) -> String {
        format!("{:#}", check_parts(parts).unwrap_err())
    }

    #[test]
    fn a_complete_set_passes() {
        check_parts(&[part(1, 3, "7"), part(0, 3, "7"), part(2, 3, "7")]).unwrap();
    }

    #[test]
    fn duplicates_missing_parts_and_mixed_renders_are_named() {
        let e = error(&[part(0, 2, "7"), part(0, 2, "7")]);
        assert!(e.contains("both are part 0/2"), "{e}");
        let e = error(&[part(0, 2, "7")]);
        assert!(e.contains("missing part(s) 1/2"), "{e}");
        // Crops: disjoint ones merge, overlapping ones and crops mixed with tiles do not.
        let crop = |r: &str| {
            let mut image = LinearImage::new(4, 4);
            for (k, v) in [("scene", "5f3a"), ("seed", "7"), ("spp", "16"), ("crop", r)] {
                image.set_attribute(k, v);
            }
            (PathBuf::from(format!("crop_{r}.exr")), image)
        };
        check_parts(&[crop("0,0,2,4"), crop("2,0,4,4")]).unwrap();
        let e = error(&[crop("0,0,3,4"), crop("2,0,4,4")]);
        assert!(e.contains("crops overlap"), "{e}");
        assert!(error(&[part(0, 2, "7"), crop("0,0,2,4")]).contains("split into 2 against a crop"));
        let e = error(&[part(0, 2, "7"), part(1, 2, "8")]);
        assert!(e.contains("seed 7 against 8") && e.contains("p1_8.exr"), "{e}");
        let e = error(&[part(0, 2, "7"), part(1, 3, "7")]);
        assert!(e.contains("split into 2 against 3"), "{e}");
        let mut other_scene = part(1, 2, "7");
        other_scene.1.set_attribute("scene", "beef");
        assert!(error(&[part(0, 2, "7"), other_scene]).contains("scene hash"));
    }

    #[test]
    fn parts_without_headers_or_with_bad_pixels_are_refused() {
        let plain = (PathBuf::from("plain.exr"), LinearImage::new(4, 4));
        let e = error(&[plain]);
        assert!(e.contains("plain.exr") && e.contains("not a part"), "{e}");
        let mut nan = part(1, 2, "7");
        nan.1.set(2, 3, [f32::NAN, 0.0, 0.0]);
        let e = error(&[part(0, 2, "7"), nan]);
        assert!(e.contains("1 non-finite pixel(s), the first at x = 2, y = 3"), "{e}");
        let mut bad = part(0, 2, "7");
        bad.1.set_attribute("part", "2/2");
        assert!(error(&[bad]).contains("not I/N"));
        let mut interrupted = part(1, 2, "7");
        interrupted.1.set_attribute("spp_max", "17");
        let e = error(&[part(0, 2, "7"), interrupted]);
        assert!(
            e.contains("p1_7.exr: an interrupted part") && e.contains("16 to 17 spp") && e.contains("--resume"),
            "{e}"
        );
    }
}
