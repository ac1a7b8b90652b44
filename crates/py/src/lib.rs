//! `fiberlab._native`: the compiled core of the `fiberlab` Python package (the Python layer,
//! `crates/py/python/fiberlab/__init__.py`, adds broadcasting, typed constructors and docs).
//! The tools beside the models have one file each: [`measure`] (goniophotometer), [`compare`]
//! (image metrics), [`hair`] (strand files and the generator), [`check`] (validation
//! harness), [`bench`] (the Rust reference loop of the evaluation benchmark).
//!
//! Everything here works on flat, C-contiguous float64 arrays: directions `(N, 3)`, offsets
//! `h` `(N,)`, uniforms `(N, 4)`. Inputs are borrowed without copying; loops run on rayon
//! threads with the GIL released; each output is allocated once. Directions follow the
//! convention of `docs/theory/conventions.md` (fiber frame, x = tangent root → tip) and are
//! checked like the command line checks them: finite, length within 1e−3 of 1 (then
//! normalized), `h` in [−1, 1]; a bad value raises `ValueError` naming the array and the
//! flat index of the first bad element.
//!
//! Every call that allocates in proportion to its input (the output arrays, a render's image
//! and scene, a measurement's bins, generated hair) first runs the command line's memory
//! check ([`fiberlab_io::memory_budget`]) and raises `MemoryError` with its message when the
//! estimate is above what the process may use; the arrays themselves are allocated by NumPy,
//! whose failure is a `MemoryError` too, never a panic. Files are opened like the command
//! line opens them ([`fiberlab_io::input_file`]): a FIFO or a device raises `ValueError`, a
//! file larger than the memory budget `MemoryError`.

mod bench;
mod check;
mod compare;
mod fit;
mod hair;
mod interrupt;
mod measure;
mod model_comparison;

use fiberlab_math::{DVec3, Rgb};
use fiberlab_render::model_loader::{AnyModel, ModelRequest};
use fiberlab_scatter::params::{ParamKind, RawValue};
use fiberlab_scatter::{Field, Lobes, Model, Sample, ScatteringFunction, SurfaceModel, SurfaceScattering};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::{PyMemoryError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use rayon::prelude::*;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

use fiberlab_math::frame::{UNIT_TOLERANCE, unit_direction};

/// A Python value as a parameter value of any edge ([`RawValue`]): str → text, bool →
/// boolean, int/float → number, list/tuple → list.
pub(crate) fn raw_value(key: &str, value: &Bound<'_, PyAny>) -> PyResult<RawValue> {
    if value.is_instance_of::<PyBool>() {
        return Ok(RawValue::Bool(value.extract()?));
    }
    if value.is_instance_of::<PyString>() {
        return Ok(RawValue::Text(value.extract()?));
    }
    if value.is_instance_of::<PyInt>() || value.is_instance_of::<PyFloat>() {
        return Ok(RawValue::Number(value.extract()?));
    }
    if value.is_instance_of::<PyList>() || value.is_instance_of::<PyTuple>() {
        let items: Vec<Bound<'_, PyAny>> = value.try_iter()?.collect::<PyResult<_>>()?;
        return Ok(RawValue::List(items.iter().map(|v| raw_value(key, v)).collect::<PyResult<_>>()?));
    }
    // NumPy scalars and arrays: numbers or lists of numbers.
    if let Ok(x) = value.extract::<f64>() {
        return Ok(RawValue::Number(x));
    }
    if let Ok(v) = value.extract::<Vec<f64>>() {
        return Ok(RawValue::List(v.into_iter().map(RawValue::Number).collect()));
    }
    Err(PyValueError::new_err(format!(
        "parameter `{key}`: expected a number, a string, a boolean or a list, got {}",
        value.get_type().name()?
    )))
}

/// What `sample` returns: `(wi, weight, pdf, lobe)`.
type Samples<'py> =
    (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>, Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<i32>>);

/// A scattering model of either registry (fiber or surface), built from its name and
/// parameters.
#[pyclass(name = "Model", module = "fiberlab._native", frozen)]
pub(crate) struct PyModel {
    pub(crate) model: AnyModel,
    /// What it was built from (for the calls that rebuild it, e.g. per lobe).
    pub(crate) request: ModelRequest,
    name: String,
    given: Vec<(String, String)>,
}

/// What the loops need of a model of either registry. A fiber model reads `h` and its
/// cosine is the light direction's from the normal plane (fiber frame, x = tangent); a
/// surface model ignores `h` and its cosine is |cos θ_i| from the normal (local frame,
/// z = normal), the factor of its sample weights.
pub(crate) trait Scatterer: Sync {
    /// f_s (fiber) or f_r (surface), sr⁻¹.
    fn f(&self, wi: DVec3, wo: DVec3, h: f64) -> Rgb;
    /// The density of `draw`, sr⁻¹.
    fn density(&self, wi: DVec3, wo: DVec3, h: f64) -> f64;
    /// One importance sample of ω_i.
    fn draw(&self, wo: DVec3, h: f64, u: [f64; 4]) -> Option<Sample>;
    /// The cosine that turns `f` into what multiplies incident radiance.
    fn cos_light(&self, wi: DVec3) -> f64;
}

impl Scatterer for Model {
    #[inline]
    fn f(&self, wi: DVec3, wo: DVec3, h: f64) -> Rgb {
        self.eval(wi, wo, h)
    }
    #[inline]
    fn density(&self, wi: DVec3, wo: DVec3, h: f64) -> f64 {
        self.pdf(wi, wo, h)
    }
    #[inline]
    fn draw(&self, wo: DVec3, h: f64, u: [f64; 4]) -> Option<Sample> {
        self.sample(wo, h, u)
    }
    #[inline]
    fn cos_light(&self, wi: DVec3) -> f64 {
        fiberlab_math::frame::cos_theta(wi)
    }
}

impl Scatterer for SurfaceModel {
    #[inline]
    fn f(&self, wi: DVec3, wo: DVec3, _h: f64) -> Rgb {
        self.eval(wi, wo)
    }
    #[inline]
    fn density(&self, wi: DVec3, wo: DVec3, _h: f64) -> f64 {
        self.pdf(wi, wo)
    }
    #[inline]
    fn draw(&self, wo: DVec3, _h: f64, u: [f64; 4]) -> Option<Sample> {
        self.sample(wo, u)
    }
    #[inline]
    fn cos_light(&self, wi: DVec3) -> f64 {
        wi.z.abs()
    }
}

/// Checks direction `k` of a flat `(N, 3)` array; returns it normalized.
#[inline]
pub(crate) fn direction(v: &[f64], k: usize) -> Option<DVec3> {
    unit_direction(DVec3::new(v[3 * k], v[3 * k + 1], v[3 * k + 2]))
}

/// The first index at which `ok` fails, searched in parallel.
fn first_bad(n: usize, ok: impl Fn(usize) -> bool + Sync) -> Option<usize> {
    (0..n).into_par_iter().find_first(|&k| !ok(k))
}

fn bad_direction(name: &str, v: &[f64], k: usize) -> PyErr {
    PyValueError::new_err(format!(
        "{name}[{k}] = ({}, {}, {}): expected a finite unit vector (length within {UNIT_TOLERANCE} of 1)",
        v[3 * k],
        v[3 * k + 1],
        v[3 * k + 2]
    ))
}

/// Checks that the arrays of one call hold `n` elements each.
fn check_sizes(dirs: &[(&str, &[f64])], h: &[f64], n: usize) -> PyResult<()> {
    for (name, v) in dirs {
        if v.len() != 3 * n {
            return Err(PyValueError::new_err(format!("{name}: expected {n} directions, got {}", v.len() / 3)));
        }
    }
    if h.len() != n {
        return Err(PyValueError::new_err(format!("h: expected {n} values, got {}", h.len())));
    }
    Ok(())
}

/// Checks the arrays of one call: sizes equal, directions finite and unit, `h` in [−1, 1];
/// the error names the first bad element of the first bad array.
pub(crate) fn check_inputs(dirs: &[(&str, &[f64])], h: &[f64], n: usize) -> PyResult<()> {
    check_sizes(dirs, h, n)?;
    for (name, v) in dirs {
        if let Some(k) = first_bad(n, |k| direction(v, k).is_some()) {
            return Err(bad_direction(name, v, k));
        }
    }
    if let Some(k) = first_bad(n, |k| (-1.0..=1.0).contains(&h[k])) {
        return Err(PyValueError::new_err(format!("h[{k}] = {}: expected a value in [-1, 1]", h[k])));
    }
    Ok(())
}

/// The elements of a C-contiguous float64 array (a `ValueError` naming it otherwise).
pub(crate) fn slice<'a, D: numpy::ndarray::Dimension>(
    name: &str,
    a: &'a numpy::PyReadonlyArray<'_, f64, D>,
) -> PyResult<&'a [f64]> {
    a.as_slice().map_err(|_| PyValueError::new_err(format!("{name}: expected a C-contiguous float64 array")))
}

/// Checks `needs` with the command line's memory check; `MemoryError` with its message when
/// they are above the budget.
pub(crate) fn check_memory(needs: &[fiberlab_io::memory_budget::Need]) -> PyResult<()> {
    fiberlab_io::memory_budget::check_needs(needs).map_err(|e| PyMemoryError::new_err(e.to_string()))
}

/// An input file's error: `MemoryError` for a file larger than the memory budget,
/// `ValueError` otherwise (not a regular file, unreadable, not UTF-8).
pub(crate) fn input_error(e: &fiberlab_io::input_file::InputError) -> PyErr {
    match e {
        fiberlab_io::input_file::InputError::TooLarge { .. } => PyMemoryError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    }
}

/// A zeroed C-contiguous NumPy array of `shape`, allocated by NumPy (so that Python's
/// `tracemalloc` accounts for it) for a loop to fill in place; its bytes are checked against
/// the memory budget first (`MemoryError`), and an allocation NumPy cannot make is
/// NumPy's `MemoryError`.
fn output<'py, T: numpy::Element + Copy, D: numpy::ndarray::Dimension>(
    py: Python<'py>,
    what: &str,
    shape: D,
) -> PyResult<Bound<'py, numpy::PyArray<T, D>>> {
    let dims = shape.slice().to_vec();
    let elements = dims.iter().try_fold(1u64, |n, &d| n.checked_mul(d as u64));
    let bytes = elements.and_then(|n| n.checked_mul(std::mem::size_of::<T>() as u64));
    check_memory(&[fiberlab_io::memory_budget::Need::new(format!("{what} {dims:?}"), bytes)])?;
    let zeros = py.import("numpy")?.call_method1("zeros", (dims, numpy::dtype::<T>(py)))?;
    Ok(zeros.cast_into::<numpy::PyArray<T, D>>()?)
}

/// What `eval_pdf`-like calls compute per direction pair.
#[derive(Clone, Copy)]
pub(crate) enum Quantity {
    /// f_s (sr⁻¹), three channels.
    Fs,
    /// f_s · cosθ_i, three channels.
    FsCos,
    /// The pdf of `sample`, one value.
    Pdf,
}

impl Quantity {
    /// Values per pair.
    pub(crate) fn width(self) -> usize {
        if matches!(self, Quantity::Pdf) { 1 } else { 3 }
    }
}

/// Evaluates `what` for every pair, in parallel, into `out` (`what.width()` values per pair);
/// allocates nothing. Each element is checked as it is read (the same test as
/// [`check_inputs`]); `false` when one is invalid, for the caller to name it with
/// [`check_inputs`]: one pass over the arrays when they are valid.
pub(crate) fn eval_loop(
    model: &impl Scatterer,
    wi: &[f64],
    wo: &[f64],
    h: &[f64],
    what: Quantity,
    out: &mut [f64],
) -> bool {
    let width = what.width();
    debug_assert_eq!(out.len(), width * h.len());
    let bad = AtomicBool::new(false);
    out.par_chunks_mut(width).enumerate().for_each(|(k, o)| match (direction(wi, k), direction(wo, k)) {
        (Some(a), Some(b)) if (-1.0..=1.0).contains(&h[k]) => match what {
            Quantity::Pdf => o[0] = model.density(a, b, h[k]),
            Quantity::Fs | Quantity::FsCos => {
                let f = model.f(a, b, h[k]);
                let c = if matches!(what, Quantity::FsCos) { model.cos_light(a) } else { 1.0 };
                o.copy_from_slice(&[f[0] * c, f[1] * c, f[2] * c]);
            }
        },
        _ => bad.store(true, Ordering::Relaxed),
    });
    !bad.into_inner()
}

impl PyModel {
    /// Evaluates `what` for every pair into `out`, in parallel without the GIL.
    fn map_pairs(
        &self,
        py: Python<'_>,
        wi: &[f64],
        wo: &[f64],
        h: &[f64],
        what: Quantity,
        out: &mut [f64],
    ) -> PyResult<()> {
        let dirs = [("wi", wi), ("wo", wo)];
        check_sizes(&dirs, h, h.len())?;
        let valid = py.detach(|| match &self.model {
            AnyModel::Fiber(m) => eval_loop(m, wi, wo, h, what, out),
            AnyModel::Surface(m) => eval_loop(m, wi, wo, h, what, out),
        });
        if valid {
            Ok(())
        } else {
            check_inputs(&dirs, h, h.len())?;
            Err(PyValueError::new_err("invalid input"))
        }
    }
}

#[pymethods]
impl PyModel {
    /// `Model(name, params)`: the registered model `name` (fiber or surface) with `params` (a
    /// dict of key → number, string, bool or list, as in a scene file); invalid keys or
    /// values raise `ValueError` with the command line's message. Relative data paths (the
    /// `measured` model's `table`, `irawan-2012`'s `pattern`) are read from the working
    /// directory.
    #[new]
    #[pyo3(signature = (name, params = None))]
    fn new(name: &str, params: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let mut pairs = Vec::new();
        let mut given = Vec::new();
        if let Some(d) = params {
            for (k, v) in d.iter() {
                let key: String = k.extract().map_err(|_| PyValueError::new_err("parameter names must be strings"))?;
                let raw = raw_value(&key, &v)?;
                given.push((key.clone(), raw.to_string()));
                pairs.push((key, raw));
            }
        }
        let request = ModelRequest::new(name, pairs);
        let model = request.build_any().map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(Self { model, request, name: name.to_string(), given })
    }

    /// The model's registry name.
    #[getter]
    fn name(&self) -> &str {
        &self.name
    }

    /// What the model claims: a dict with `kind` (`"fiber"` or `"surface"`), `reciprocal`,
    /// `energy_conserving`, `lobes` (`"smooth"` or `"delta"`); fiber models add `field`
    /// (`"far"` or `"near"`: whether f_s depends on h), surface models `transmits` (light may
    /// leave below the surface).
    #[getter]
    fn flags<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let lobes = |delta: bool| if delta { "delta" } else { "smooth" };
        match &self.model {
            AnyModel::Fiber(m) => {
                let p = m.properties();
                d.set_item("kind", "fiber")?;
                d.set_item("reciprocal", p.reciprocal)?;
                d.set_item("energy_conserving", p.energy_conserving)?;
                d.set_item("field", if p.field == Field::Near { "near" } else { "far" })?;
                d.set_item("lobes", lobes(p.lobes == Lobes::Delta))?;
            }
            AnyModel::Surface(m) => {
                let p = m.properties();
                d.set_item("kind", "surface")?;
                d.set_item("reciprocal", p.reciprocal)?;
                d.set_item("energy_conserving", p.energy_conserving)?;
                d.set_item("transmits", p.transmits)?;
                d.set_item("lobes", lobes(p.has_delta))?;
            }
        }
        Ok(d)
    }

    fn __repr__(&self) -> String {
        let params: Vec<String> = self.given.iter().map(|(k, v)| format!("{k}={v}")).collect();
        format!("fiberlab.Model({:?}{}{})", self.name, if params.is_empty() { "" } else { ", " }, params.join(", "))
    }

    /// `what` of every pair of `(N, 3)` float64 arrays `wi`, `wo` with `h` `(N,)`: `"fs"`,
    /// f_s(ω_i, ω_o; h) in sr⁻¹, `(N, 3)`; `"fs_cos"`, f_s · cosθ_i (the cosine of the light
    /// direction ω_i from the normal plane), `(N, 3)`; `"pdf"`, the density (sr⁻¹) with which
    /// `sample(wo)` draws ω_i, `(N,)`.
    fn evaluate<'py>(
        &self,
        py: Python<'py>,
        wi: PyReadonlyArray2<'py, f64>,
        wo: PyReadonlyArray2<'py, f64>,
        h: PyReadonlyArray1<'py, f64>,
        what: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        let quantity = match what {
            "fs" => Quantity::Fs,
            "fs_cos" => Quantity::FsCos,
            "pdf" => Quantity::Pdf,
            _ => return Err(PyValueError::new_err(format!("evaluate: unknown quantity {what:?} (fs, fs_cos, pdf)"))),
        };
        let (wi, wo, h) = (slice("wi", &wi)?, slice("wo", &wo)?, slice("h", &h)?);
        let n = h.len();
        Ok(match quantity {
            Quantity::Pdf => {
                let out = output::<f64, _>(py, "pdf array", numpy::ndarray::Ix1(n))?;
                self.map_pairs(py, wi, wo, h, quantity, out.readwrite().as_slice_mut().expect("contiguous"))?;
                out.into_any()
            }
            _ => {
                let out = output::<f64, _>(py, "f_s array", numpy::ndarray::Ix2(n, 3))?;
                self.map_pairs(py, wi, wo, h, quantity, out.readwrite().as_slice_mut().expect("contiguous"))?;
                out.into_any()
            }
        })
    }

    /// The lobes `sample` chooses among, in the order of its `lobe` indices: a list of
    /// `(name, delta)` pairs (`delta`: samples of that lobe lie on a delta lobe).
    #[getter]
    fn lobes(&self) -> Vec<(&'static str, bool)> {
        let lobes = match &self.model {
            AnyModel::Fiber(m) => m.lobes(),
            AnyModel::Surface(m) => m.lobes(),
        };
        lobes.iter().map(|l| (l.name, l.delta)).collect()
    }

    /// Importance samples of ω_i for `wo` `(N, 3)`, `u` `(N, 4)` uniforms in [0, 1), `h`
    /// `(N,)`: `(wi (N, 3), weight (N, 3) = f_s·cosθ_i/pdf, pdf (N,), lobe (N,) int32)`, `lobe`
    /// indexing [`Self::lobes`]; a failed sample has wi = weight = 0, pdf = 0, lobe = −1. The
    /// four outputs are allocated once and written in place.
    fn sample<'py>(
        &self,
        py: Python<'py>,
        wo: PyReadonlyArray2<'py, f64>,
        u: PyReadonlyArray2<'py, f64>,
        h: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Samples<'py>> {
        let (wo, u, h) = (slice("wo", &wo)?, slice("u", &u)?, slice("h", &h)?);
        let n = h.len();
        check_sizes(&[("wo", wo)], h, n)?;
        if u.len() != 4 * n {
            return Err(PyValueError::new_err(format!("u: expected {n} rows of 4 uniforms, got {} values", u.len())));
        }
        // The four outputs together, then each.
        let per_sample = 3 * 8 + 3 * 8 + 8 + 4;
        check_memory(&[fiberlab_io::memory_budget::Need::items(format!("{n} samples"), n as u64, per_sample)])?;
        let arrays = (
            output::<f64, _>(py, "wi array", numpy::ndarray::Ix2(n, 3))?,
            output::<f64, _>(py, "weight array", numpy::ndarray::Ix2(n, 3))?,
            output::<f64, _>(py, "pdf array", numpy::ndarray::Ix1(n))?,
            output::<i32, _>(py, "lobe array", numpy::ndarray::Ix1(n))?,
        );
        let valid = {
            let (mut wi, mut weight, mut pdf, mut lobe) =
                (arrays.0.readwrite(), arrays.1.readwrite(), arrays.2.readwrite(), arrays.3.readwrite());
            let out = SampleOutputs {
                wi: wi.as_slice_mut().expect("contiguous"),
                weight: weight.as_slice_mut().expect("contiguous"),
                pdf: pdf.as_slice_mut().expect("contiguous"),
                lobe: lobe.as_slice_mut().expect("contiguous"),
            };
            py.detach(|| match &self.model {
                AnyModel::Fiber(m) => sample_loop(m, wo, u, h, out),
                AnyModel::Surface(m) => sample_loop(m, wo, u, h, out),
            })
        };
        if !valid {
            check_inputs(&[("wo", wo)], h, n)?;
            let k = first_bad(4 * n, |k| (0.0..1.0).contains(&u[k])).expect("an invalid input");
            return Err(PyValueError::new_err(format!(
                "u[{}, {}] = {}: expected a uniform in [0, 1)",
                k / 4,
                k % 4,
                u[k]
            )));
        }
        Ok(arrays)
    }
}

/// The four outputs of `sample`, flat: `wi` and `weight` three values per sample, `pdf` and
/// `lobe` one.
pub(crate) struct SampleOutputs<'a> {
    pub(crate) wi: &'a mut [f64],
    pub(crate) weight: &'a mut [f64],
    pub(crate) pdf: &'a mut [f64],
    pub(crate) lobe: &'a mut [i32],
}

/// One sample per `wo[k]`, `u[k]`, `h[k]`, in parallel, written into `out` (zeros and lobe −1
/// for a failed sample); allocates nothing. Each element is checked as it is read (`wo`
/// finite and unit, `h` in [−1, 1], `u` in [0, 1)); `false` when one is invalid, for the
/// caller to name it.
pub(crate) fn sample_loop(model: &impl Scatterer, wo: &[f64], u: &[f64], h: &[f64], out: SampleOutputs<'_>) -> bool {
    let bad = AtomicBool::new(false);
    out.wi
        .par_chunks_mut(3)
        .zip(out.weight.par_chunks_mut(3))
        .zip(out.pdf.par_iter_mut())
        .zip(out.lobe.par_iter_mut())
        .enumerate()
        .for_each(|(k, (((wi, weight), pdf), lobe))| {
            let uk = [u[4 * k], u[4 * k + 1], u[4 * k + 2], u[4 * k + 3]];
            let (Some(w), true, true) =
                (direction(wo, k), (-1.0..=1.0).contains(&h[k]), uk.iter().all(|x| (0.0..1.0).contains(x)))
            else {
                bad.store(true, Ordering::Relaxed);
                return;
            };
            match model.draw(w, h[k], uk) {
                Some(s) => {
                    wi.copy_from_slice(&[s.wi.x, s.wi.y, s.wi.z]);
                    weight.copy_from_slice(&[s.weight[0], s.weight[1], s.weight[2]]);
                    *pdf = s.pdf;
                    *lobe = i32::from(s.lobe);
                }
                None => *lobe = -1,
            }
        });
    !bad.into_inner()
}

/// Every registered model, fiber then surface: a list of dicts `{name, kind, summary,
/// citation, params}` (`kind`: `"fiber"` or `"surface"`), each parameter `{key, kind, unit,
/// default, doc, range | choices}` — what `fiberlab models` lists.
#[pyfunction]
fn models(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    let list = PyList::empty(py);
    for entry in fiberlab_scatter::registry() {
        let spec = entry.info();
        let d = PyDict::new(py);
        d.set_item("name", spec.name)?;
        d.set_item("kind", entry.kind().name())?;
        d.set_item("summary", spec.summary)?;
        d.set_item("citation", spec.citation)?;
        let params = PyList::empty(py);
        for p in spec.params {
            let q = PyDict::new(py);
            q.set_item("key", p.key)?;
            q.set_item("unit", p.unit)?;
            q.set_item("default", p.default)?;
            q.set_item("doc", p.doc)?;
            q.set_item("valid", p.valid())?;
            let (kind, range, choices) = match p.kind {
                ParamKind::Number(r) => ("number", Some(r), None),
                ParamKind::Integer(r) => ("integer", Some(r), None),
                ParamKind::Color(r) => ("color", Some(r), None),
                ParamKind::Choice(c) => ("choice", None, Some(c)),
                ParamKind::Subset(c) => ("subset", None, Some(c)),
                ParamKind::Text => ("text", None, None),
            };
            q.set_item("kind", kind)?;
            if let Some(r) = range {
                q.set_item("range", (r.min, r.max))?;
            }
            if let Some(c) = choices {
                q.set_item("choices", c.to_vec())?;
            }
            params.append(q)?;
        }
        d.set_item("params", params)?;
        list.append(d)?;
    }
    Ok(list)
}

/// An `(H, W, 3)` float32 array of a linear image.
fn image_array<'py>(py: Python<'py>, image: &fiberlab_io::LinearImage) -> Bound<'py, numpy::PyArray3<f32>> {
    let (w, h) = (image.width(), image.height());
    let flat: Vec<f32> = image.pixels().iter().flatten().copied().collect();
    numpy::ndarray::Array3::from_shape_vec((h, w, 3), flat).expect("three channels per pixel").into_pyarray(py)
}

/// Reads the R, G, B channels of an OpenEXR file as an `(H, W, 3)` float32 array.
#[pyfunction]
fn read_exr<'py>(py: Python<'py>, path: std::path::PathBuf) -> PyResult<Bound<'py, numpy::PyArray3<f32>>> {
    let image = fiberlab_io::LinearImage::read_exr(&path).map_err(|e| match &e {
        fiberlab_io::ImageError::Input(i) => input_error(i),
        _ if e.to_string().contains("needs ~") => PyMemoryError::new_err(e.to_string()),
        _ => PyValueError::new_err(e.to_string()),
    })?;
    Ok(image_array(py, &image))
}

/// The scene file at `path`, of TOML `text`, or the built-in default scene when both are
/// `None`; `verb` names the caller in the error for both.
pub(crate) fn scene_file(
    path: Option<&Path>,
    text: Option<&str>,
    verb: &str,
) -> PyResult<fiberlab_render::scene_file::SceneFile> {
    use fiberlab_render::scene_file::SceneFile;
    let scene_error = |e: fiberlab_render::scene_file::SceneError| PyValueError::new_err(e.to_string());
    match (path, text) {
        (Some(_), Some(_)) => Err(PyValueError::new_err(format!("{verb}: give a scene path or its text, not both"))),
        (Some(p), None) => SceneFile::read(p).map_err(scene_error),
        (None, Some(t)) => SceneFile::parse(t, Path::new("<text>")).map_err(scene_error),
        (None, None) => Ok(SceneFile::default_scene()),
    }
}

/// Renders a scene (a TOML file `path`, TOML `text`, or the built-in default scene when both
/// are `None`) like `fiberlab render`, returning `(H, W, 3)` float32 linear RGB. `spp`,
/// `seed`, `max_depth` override the scene's; `threads` 0 uses every core. `progress(done,
/// total)` (pixel samples) is called as tiles finish; Ctrl-C (KeyboardInterrupt) stops the
/// render and raises it. `integrator` (`path` or `dual-scattering`) and `fiber_count`
/// (`exact` or `grid`) override the scene's `[render]` entries; `dual` holds `KEY=VALUE`
/// dual-scattering options, as `fiberlab render --dual`. `device` is `cpu` (the default),
/// `gpu` or `auto`, as `fiberlab render --device`.
#[pyfunction]
#[pyo3(signature = (path = None, text = None, spp = None, seed = None, max_depth = None, threads = 0, progress = None,
                    integrator = None, fiber_count = None, dual = Vec::new(), device = "cpu".to_string()))]
#[allow(clippy::too_many_arguments)]
fn render<'py>(
    py: Python<'py>,
    path: Option<std::path::PathBuf>,
    text: Option<String>,
    spp: Option<u32>,
    seed: Option<u64>,
    max_depth: Option<u32>,
    threads: usize,
    progress: Option<Py<PyAny>>,
    integrator: Option<String>,
    fiber_count: Option<String>,
    dual: Vec<String>,
    device: String,
) -> PyResult<Bound<'py, numpy::PyArray3<f32>>> {
    use std::sync::atomic::AtomicU64;
    let scene_error = |e: fiberlab_render::scene_file::SceneError| PyValueError::new_err(e.to_string());
    let file = scene_file(path.as_deref(), text.as_deref(), "render")?;
    // The command line's check, before anything is built: the image, the hair, its BVH.
    fiberlab_io::memory_budget::check_needs(&file.memory_estimate().map_err(scene_error)?.needs())
        .map_err(|e| PyMemoryError::new_err(format!("render: {e}")))?;
    let device =
        fiberlab_gpu::DeviceChoice::named(&device).map_err(|e| PyValueError::new_err(format!("render: {e}")))?;
    let options =
        fiberlab_render::render_request::RenderOptions { spp, seed, max_depth, threads, integrator, fiber_count, dual };
    let request = options.validate(&file).map_err(|e| PyValueError::new_err(format!("render: {e}")))?;
    let (scene, settings, gpu) = py.detach(|| -> PyResult<_> {
        let (scene, _) = file.build().map_err(scene_error)?;
        let settings = request.settings_for(&scene).map_err(|e| {
            use fiberlab_render::dual_scattering::{DualScatteringError, IntegratorError};
            match e {
                // The density grid is checked against the memory budget: MemoryError.
                IntegratorError::DualScattering(DualScatteringError::Memory(_)) => {
                    PyMemoryError::new_err(format!("render: {e}"))
                }
                _ => PyValueError::new_err(format!("render: {e}")),
            }
        })?;
        let (gpu, _note) = fiberlab_gpu::render_device::open(device)
            .map_err(|e| PyValueError::new_err(format!("render: device: {e}")))?;
        Ok((scene, settings, gpu))
    })?;
    let (w, h) = (scene.camera().width, scene.camera().height);
    let (done, total) = (AtomicU64::new(0), AtomicU64::new(0));
    let report = |p: &fiberlab_render::integrator::Progress| {
        done.store(p.samples_done, Ordering::Relaxed);
        total.store(p.samples_total, Ordering::Relaxed);
    };
    let out = interrupt::interruptible(
        py,
        |stop| {
            let start = fiberlab_render::accumulation::Accumulation::new(w, h);
            fiberlab_gpu::render_device::render_continuing(gpu.as_ref(), &scene, &settings, start, &report, stop)
        },
        |py| match &progress {
            Some(cb) => cb.call1(py, (done.load(Ordering::Relaxed), total.load(Ordering::Relaxed))).map(drop),
            None => Ok(()),
        },
    )?
    .map_err(|e| PyValueError::new_err(format!("render: {e}")))?
    .output;
    if let Some(cb) = &progress {
        cb.call1(py, (out.stats.samples, out.stats.samples))?;
    }
    Ok(image_array(py, &out.image))
}

/// The compiled core of `fiberlab`.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyModel>()?;
    m.add_function(wrap_pyfunction!(models, m)?)?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add_function(wrap_pyfunction!(read_exr, m)?)?;
    m.add_function(wrap_pyfunction!(measure::measure, m)?)?;
    m.add_function(wrap_pyfunction!(compare::compare, m)?)?;
    m.add_function(wrap_pyfunction!(model_comparison::compare_model, m)?)?;
    m.add_function(wrap_pyfunction!(model_comparison::evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(fit::fit, m)?)?;
    m.add_function(wrap_pyfunction!(hair::hair_read, m)?)?;
    m.add_function(wrap_pyfunction!(hair::hair_write, m)?)?;
    m.add_function(wrap_pyfunction!(hair::hair_generate, m)?)?;
    m.add_function(wrap_pyfunction!(check::check, m)?)?;
    m.add_function(wrap_pyfunction!(bench::_bench_rust, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
