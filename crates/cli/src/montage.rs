//! `fiberlab montage`: PNG images of one size laid out in a labelled grid (a contact sheet),
//! row by row, each under its label; used by `gallery/cloth.sh`.

use anyhow::Context;
use std::path::PathBuf;

/// Flags of `fiberlab montage`.
#[derive(clap::Args)]
pub struct Args {
    /// Images as `FILE.png=LABEL` (or `FILE.png`: labelled with its file stem), in grid order.
    #[arg(required = true)]
    images: Vec<String>,
    /// Images per row.
    #[arg(long, default_value_t = 6)]
    columns: usize,
    /// Output PNG.
    #[arg(long)]
    out: PathBuf,
    /// Optional title over the grid.
    #[arg(long)]
    title: Option<String>,
}

/// Runs `fiberlab montage`.
pub fn run(args: &Args) -> anyhow::Result<()> {
    use plotters::prelude::*;
    anyhow::ensure!(args.columns > 0, "--columns must be > 0");
    let mut tiles = Vec::with_capacity(args.images.len());
    for item in &args.images {
        let (file, label) = match item.split_once('=') {
            Some((f, l)) => (PathBuf::from(f), l.to_string()),
            None => {
                let f = PathBuf::from(item);
                let stem = f.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
                (f, stem)
            }
        };
        let img = fiberlab_io::image_file::decode_image(&file)?.to_rgb8();
        tiles.push((file, label, img));
    }
    let (iw, ih) = tiles[0].2.dimensions();
    if let Some((file, _, img)) = tiles.iter().find(|t| t.2.dimensions() != (iw, ih)) {
        let (w, h) = img.dimensions();
        anyhow::bail!("{}: {w}×{h}, the first image is {iw}×{ih}", file.display());
    }
    let (label, title) = (20u32, if args.title.is_some() { 26u32 } else { 0 });
    let columns = args.columns.min(tiles.len()) as u32;
    let rows = tiles.len().div_ceil(args.columns) as u32;
    let (cw, ch) = (iw + 4, ih + label + 4);
    let (width, height) = (u64::from(columns) * u64::from(cw), u64::from(title) + u64::from(rows) * u64::from(ch));
    crate::memory_budget::check(&[crate::memory_budget::Need::items(
        format!("montage {width}×{height}"),
        width.saturating_mul(height),
        6,
    )])?;
    let size = (
        u32::try_from(width).context("the montage is wider than 2³² pixels")?,
        u32::try_from(height).context("the montage is taller than 2³² pixels")?,
    );
    let mut buf = vec![255u8; (size.0 as usize) * (size.1 as usize) * 3];
    for (k, (_, _, img)) in tiles.iter().enumerate() {
        let (x0, y0) = ((k as u32 % columns) * cw + 2, title + (k as u32 / columns) * ch + label + 2);
        for (x, y, p) in img.enumerate_pixels() {
            let i = ((y0 + y) as usize * size.0 as usize + (x0 + x) as usize) * 3;
            buf[i..i + 3].copy_from_slice(&p.0);
        }
    }
    if let Some(dir) = args.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    crate::plot::draw_png_over(&args.out, size, buf, |root| {
        let err = |e: DrawingAreaErrorKind<_>| anyhow::anyhow!("drawing: {e:?}");
        let style = ("sans-serif", 14).into_text_style(&root);
        if let Some(t) = &args.title {
            root.draw_text(t, &("sans-serif", 18).into_text_style(&root), (6, 4)).map_err(err)?;
        }
        for (k, (_, text, _)) in tiles.iter().enumerate() {
            let (x0, y0) = ((k as u32 % columns) * cw + 4, title + (k as u32 / columns) * ch + 3);
            root.draw_text(text, &style, (x0 as i32, y0 as i32)).map_err(err)?;
        }
        root.present().map_err(err)?;
        Ok(())
    })?;
    println!("{} ({} images, {}×{})", args.out.display(), tiles.len(), size.0, size.1);
    Ok(())
}
