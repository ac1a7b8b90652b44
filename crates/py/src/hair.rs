//! `fiberlab._native.hair_*`: `.hair` strand files (`fiberlab_io::hair`) and the procedural
//! generator of `fiberlab hair generate` (`fiberlab_procedural::generator`) as arrays.

use fiberlab_io::{Format, HairError, HairFile, StrandsError, strand_files};
use fiberlab_procedural::generator::HairParams;
use numpy::ndarray::{Array1, Array2};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::{PyMemoryError, PyValueError};
use pyo3::prelude::*;

/// What reading returns: `(points (N, 3) float32, points per strand (S,) int64, thickness
/// (N,) float32, has a thickness array, default thickness)`; the thickness is the per-point
/// array or the file's default at every point.
type Strands<'py> = (Bound<'py, PyArray2<f32>>, Bound<'py, PyArray1<i64>>, Bound<'py, PyArray1<f32>>, bool, f32);

fn strands<'py>(py: Python<'py>, hair: &HairFile) -> Strands<'py> {
    let n = hair.points.len();
    let points: Vec<f32> = hair.points.iter().flatten().copied().collect();
    let counts: Vec<i64> = hair.strand_ranges().iter().map(|r| r.len() as i64).collect();
    let thickness: Vec<f32> = (0..n).map(|i| hair.thickness_at(i)).collect();
    (
        Array2::from_shape_vec((n, 3), points).expect("three coordinates per point").into_pyarray(py),
        Array1::from_vec(counts).into_pyarray(py),
        Array1::from_vec(thickness).into_pyarray(py),
        hair.thickness.is_some(),
        hair.default_thickness,
    )
}

/// Reads a hair file of any format by extension (`.hair`, `.pbrt`, `.pbrt.gz`, `.usda`, as
/// `fiberlab hair info`): see [`Strands`]. Cubic curves come back as polylines, each span
/// evaluated at `segments_per_curve` steps (as `fiberlab hair convert` writes them to `.hair`).
#[pyfunction]
#[pyo3(signature = (path, segments_per_curve = 8))]
pub(crate) fn hair_read<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    segments_per_curve: usize,
) -> PyResult<Strands<'py>> {
    if !(1..=1024).contains(&segments_per_curve) {
        return Err(PyValueError::new_err(format!("segments_per_curve = {segments_per_curve}: expected 1 to 1024")));
    }
    let hair = match Format::of(&path).map_err(|e| strands_error(&e))? {
        Format::Hair => HairFile::read(&path).map_err(|e| hair_error(&e))?,
        // The strands returned are round (points and diameters): ribbon normals are not part of them.
        _ => strand_files::read(&path)
            .map(|s| fiberlab_io::Strands { normals: Vec::new(), ..s })
            .and_then(|s| s.to_polylines(segments_per_curve))
            .and_then(|s| s.to_hair())
            .map_err(|e| strands_error(&e))?,
    };
    Ok(strands(py, &hair))
}

/// A hair file's error: `MemoryError` for more than the memory budget, `ValueError` otherwise.
fn hair_error(e: &HairError) -> PyErr {
    match e {
        HairError::Input(i) => crate::input_error(i),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// [`hair_error`] for the other formats.
fn strands_error(e: &StrandsError) -> PyErr {
    match e {
        StrandsError::Input(i) => crate::input_error(i),
        StrandsError::Hair(h) => hair_error(h),
        StrandsError::Inconsistent(m) if m.contains("needs ~") => PyMemoryError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// Writes a `.hair` file from all points `(N, 3)` float32, the points per strand `(S,)` (each
/// at least 1, at most 65,536) and an optional per-point diameter `(N,)` float32 (without it
/// every strand has diameter `default_thickness`).
#[pyfunction]
#[pyo3(signature = (path, points, counts, thickness = None, default_thickness = 1.0))]
pub(crate) fn hair_write(
    path: std::path::PathBuf,
    points: PyReadonlyArray2<'_, f32>,
    counts: PyReadonlyArray1<'_, i64>,
    thickness: Option<PyReadonlyArray1<'_, f32>>,
    default_thickness: f32,
) -> PyResult<()> {
    let bad = |m: String| PyValueError::new_err(m);
    let p = points.as_slice().map_err(|_| bad("points: expected a C-contiguous (N, 3) array".into()))?;
    if points.shape()[1] != 3 {
        return Err(bad(format!("points: expected shape (N, 3), got {:?}", points.shape())));
    }
    let counts = counts.as_slice().map_err(|_| bad("strand lengths: expected a contiguous array".into()))?;
    let mut segments = Vec::with_capacity(counts.len());
    for (i, &c) in counts.iter().enumerate() {
        if !(1..=i64::from(u16::MAX) + 1).contains(&c) {
            return Err(bad(format!("strand {i} has {c} points: expected 1 to 65536")));
        }
        segments.push((c - 1) as u16);
    }
    let thickness = match &thickness {
        Some(t) => Some(t.as_slice().map_err(|_| bad("thickness: expected a contiguous array".into()))?.to_vec()),
        None => None,
    };
    // The format follows the name, as everywhere else: `.hair` or `.usda`; a pbrt file or an
    // unknown extension is refused (not written as `.hair` bytes under another name).
    let format = Format::of(&path).map_err(|e| strands_error(&e))?;
    if format == Format::Pbrt {
        return Err(bad(format!("{}: writing pbrt files is not supported; write .hair or .usda", path.display())));
    }
    let hair = HairFile {
        segments: Some(segments),
        points: p.chunks_exact(3).map(|v| [v[0], v[1], v[2]]).collect(),
        thickness,
        strand_count: u32::try_from(counts.len()).map_err(|_| bad("too many strands".into()))?,
        default_thickness,
        ..HairFile::default()
    };
    match format {
        Format::Hair => hair.write(&path).map_err(|e| hair_error(&e)),
        _ => {
            hair.validate().map_err(|e| hair_error(&e))?;
            strand_files::write(&path, &fiberlab_io::Strands::from(&hair), 1).map_err(|e| strands_error(&e))
        }
    }
}

/// Grows procedural hair like `fiberlab hair generate`, from the generator's parameters as
/// TOML text (the keys of a scene file's `[hair.generator]` table): the same arrays as
/// [`hair_read`].
#[pyfunction]
pub(crate) fn hair_generate<'py>(py: Python<'py>, toml_text: &str) -> PyResult<Strands<'py>> {
    let params: HairParams =
        toml::from_str(toml_text).map_err(|e| PyValueError::new_err(format!("hair generator: {}", e.message())))?;
    crate::check_memory(&[fiberlab_io::memory_budget::Need::new(
        format!("hair {} strands × {} segments", params.strands, params.segments),
        params.estimated_bytes(),
    )])?;
    let hair = py.detach(|| params.generate()).map_err(|e| PyValueError::new_err(e.to_string()))?;
    Ok(strands(py, &hair))
}
