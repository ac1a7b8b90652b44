"""fiberlab: light scattering by fibers (hair, fur, cloth) from Python, on NumPy arrays.

Every scattering model of the command line (``fiberlab models``), fiber and surface, is
reachable:

>>> import numpy as np, fiberlab as fl
>>> m = fl.load_dict({"type": "chiang", "eumelanin": 1.3, "beta_m": 0.3})
>>> m = fl.Chiang(eumelanin=1.3, beta_m=0.3)          # the same model
>>> wi = np.array([0.0, 1.0, 0.0]); wo = np.array([0.0, 0.0, 1.0])
>>> m.eval_fs(wi, wo).shape
(3,)

Conventions (``docs/theory/conventions.md`` in the repository):

* Directions are float64 arrays of shape ``(..., 3)`` in the **fiber frame**: x is the fiber
  tangent (root → tip), y and z span the normal plane; ``h`` in [-1, 1] is the offset across the
  fiber along +y. ``wi`` points toward the light, ``wo`` toward the viewer. Leading dimensions
  broadcast against each other and against ``h``.
* Angles are radians: θ is the inclination from the normal plane (sin θ = ω.x) and
  φ = atan2(ω.z, ω.y).
* **Surface models** (``wood``, ``lambertian``, ``sadeghi-2013``, ``irawan-2012``;
  ``m.flags["kind"] == "surface"``) take the same calls in the surface's local frame: z is the
  shading normal, x the tangent (along the texture's u); ``eval_fs`` is the BRDF f_r in sr⁻¹,
  ``eval`` is f_r · |cos θ_i| with θ_i from the normal, and ``h`` is ignored.
* ``eval_fs`` is fiberlab's scattering function f_s in sr⁻¹ (no cosine); ``eval`` is
  f_s · cos θ_i, the cosine of the *light* direction measured from the normal plane — the
  quantity a renderer multiplies by incident radiance, and what Mitsuba 3's ``BSDF.eval``
  returns (Mitsuba names the light direction ``wo``). Spectra are RGB: shape ``(..., 3)``.
* Bad input raises ``ValueError``: wrong shapes, NaN or infinite values, directions whose
  length is not within 1e-3 of 1, ``h`` outside [-1, 1], unknown models or parameters, values
  outside their range (the same messages as the command line).

Tools, each running the code of the command of the same name: :func:`render`, :func:`measure`
(the goniophotometer), :func:`compare` (image metrics), :func:`compare_model` (a model against a
measured table), :func:`evaluate` (hair models in renders against a reference), :func:`check`
(the validation harness),
:mod:`fiberlab.hair` (``.hair`` strands as arrays, the hair generator) and
:mod:`fiberlab.frames` (Mitsuba 3's hair frame); :mod:`fiberlab.mitsuba` registers any model as a
Mitsuba 3 BSDF.
"""

from __future__ import annotations

import re
from typing import Any, Mapping, NamedTuple, Optional

import numpy as np

from . import _native

__version__ = _native.__version__

__all__ = ["Model", "Sample", "load_dict", "models", "directions_from_angles", "render", "read_exr", "scene_toml", "fit",
           "measure", "compare", "compare_model", "evaluate", "check", "hair", "frames", "mitsuba"]

import json as _json


class Sample(NamedTuple):
    """Importance samples drawn by :meth:`Model.sample`."""

    wi: np.ndarray
    """Sampled light directions, ``(..., 3)`` (zero where sampling failed)."""
    weight: np.ndarray
    """``f_s · cos θ_i / pdf``, ``(..., 3)`` (zero where sampling failed)."""
    pdf: np.ndarray
    """Density of ``wi`` in sr⁻¹, ``(...)`` (zero for a failed sample)."""
    lobe: np.ndarray
    """Which lobe drew ``wi``: int32 indices into :attr:`Model.lobes`, ``(...)`` (−1 for a
    failed sample). :meth:`Model.is_delta` tells which samples lie on a delta lobe (their pdf
    is not a density)."""


def models() -> list:
    """Every registered model, fiber then surface: dicts ``{name, kind, summary, citation,
    params}`` (``kind`` is ``"fiber"`` or ``"surface"``); each parameter ``{key, kind, unit,
    default, doc, valid, range | choices}`` (what ``fiberlab models`` prints)."""
    return _native.models()


def _as_directions(name: str, a: Any) -> np.ndarray:
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise ValueError(f"{name}: expected an array of shape (..., 3), got shape {arr.shape}")
    return arr


def _flatten(batch: tuple, arr: np.ndarray, width: Optional[int]) -> np.ndarray:
    shape = batch if width is None else batch + (width,)
    flat = np.ascontiguousarray(np.broadcast_to(arr, shape))
    return flat.reshape((-1,) if width is None else (-1, width))


def _batch(name_shapes: list) -> tuple:
    try:
        return np.broadcast_shapes(*(s for _, s in name_shapes))
    except ValueError:
        shapes = ", ".join(f"{n} {s}" for n, s in name_shapes)
        raise ValueError(f"shapes do not broadcast: {shapes}") from None


_INDEXED = re.compile(r"^(\w+)\[(\d+)\]")


def _call(batch: tuple, f, *args):
    """Calls the native ``f``; a flat index in its error becomes an index into ``batch``."""
    try:
        return f(*args)
    except ValueError as e:
        text = str(e)
        m = _INDEXED.match(text)
        if m and not batch:
            text = m.group(1) + text[m.end():]
        elif m and len(batch) > 1:
            index = np.unravel_index(int(m.group(2)), batch)
            where = ", ".join(str(int(i)) for i in index)
            text = f"{m.group(1)}[{where}]" + text[m.end():]
        raise ValueError(text) from None


class Model:
    """A scattering model of the registry, fiber or surface: ``Model("chiang", eumelanin=1.3)``,
    ``Model("lambertian", k_d=0.5)`` or :func:`load_dict`. See the module docs for frames,
    units and shapes (a surface model works in its local frame, z = normal, and ignores
    ``h``)."""

    def __init__(self, type: str, **params: Any) -> None:
        self._native = _native.Model(type, params)
        self._type = type
        self._given = dict(params)

    @property
    def name(self) -> str:
        """The registry name (``"chiang"``, ``"kajiya-kay"``, …)."""
        return self._type

    @property
    def params(self) -> dict:
        """The model's parameters: key → ``{value, unit, default, valid, doc, kind}``
        (``value`` is what was given, else ``None``: the default applies)."""
        spec = next(m for m in models() if m["name"] == self._type)
        return {
            p["key"]: {**p, "value": self._given.get(p["key"])}
            for p in spec["params"]
        }

    @property
    def flags(self) -> dict:
        """What the model claims: ``kind`` (``"fiber"`` or ``"surface"``), ``reciprocal``,
        ``energy_conserving``, ``lobes`` (``"smooth"`` or ``"delta"``); a fiber model adds
        ``field`` (``"near"`` when f_s depends on h), a surface model ``transmits``."""
        return self._native.flags

    @property
    def lobes(self) -> tuple:
        """Names of the lobes :meth:`sample` chooses among, in the order of
        :attr:`Sample.lobe` (e.g. ``("R", "TT", "TRT", "TRRT+")`` for ``chiang``,
        ``("diffuse", "specular")`` for ``kajiya-kay``)."""
        return tuple(name for name, _ in self._native.lobes)

    @property
    def lobe_delta(self) -> tuple:
        """Per lobe of :attr:`lobes`: whether it is a delta lobe (all its light leaves on the
        specular cone; pdf 0, weight the lobe's throughput)."""
        return tuple(delta for _, delta in self._native.lobes)

    def is_delta(self, lobe) -> np.ndarray:
        """Whether each lobe index (e.g. :attr:`Sample.lobe`) names a delta lobe; −1 (a failed
        sample) is not. Same shape as ``lobe``."""
        idx = np.asarray(lobe)
        if not np.issubdtype(idx.dtype, np.integer):
            raise ValueError(f"is_delta: expected integer lobe indices, got dtype {idx.dtype}")
        n = len(self.lobe_delta)
        if idx.size and (idx.min() < -1 or idx.max() >= n):
            raise ValueError(f"is_delta: lobe indices must be in [-1, {n - 1}] ({n} lobes: {self.lobes})")
        table = np.array(self.lobe_delta + (False,), dtype=bool)  # index -1 → False
        return table[idx]

    def __repr__(self) -> str:
        return repr(self._native)

    __str__ = __repr__

    def _pairs(self, wi, wo, h):
        wi, wo = _as_directions("wi", wi), _as_directions("wo", wo)
        hh = np.zeros(()) if h is None else np.asarray(h, dtype=np.float64)
        batch = _batch([("wi", wi.shape[:-1]), ("wo", wo.shape[:-1]), ("h", hh.shape)])
        return batch, _flatten(batch, wi, 3), _flatten(batch, wo, 3), _flatten(batch, hh, None)

    def eval_fs(self, wi, wo, h=None) -> np.ndarray:
        """f_s(ω_i, ω_o; h) in sr⁻¹ (no cosine): shape ``batch + (3,)``."""
        batch, a, b, c = self._pairs(wi, wo, h)
        return _call(batch, self._native.evaluate, a, b, c, "fs").reshape(batch + (3,))

    def eval(self, wi, wo, h=None) -> np.ndarray:
        """f_s · cos θ_i (cosine of the light direction from the normal plane; Mitsuba's
        ``eval``): shape ``batch + (3,)``."""
        batch, a, b, c = self._pairs(wi, wo, h)
        return _call(batch, self._native.evaluate, a, b, c, "fs_cos").reshape(batch + (3,))

    def pdf(self, wi, wo, h=None) -> np.ndarray:
        """Density in sr⁻¹ with which :meth:`sample` draws ``wi`` given ``wo``: shape ``batch``."""
        batch, a, b, c = self._pairs(wi, wo, h)
        return _call(batch, self._native.evaluate, a, b, c, "pdf").reshape(batch)

    def eval_pdf(self, wi, wo, h=None):
        """``(eval(wi, wo, h), pdf(wi, wo, h))``."""
        return self.eval(wi, wo, h), self.pdf(wi, wo, h)

    def eval_angles(self, theta_i, phi_i, theta_r, phi_r, h=None) -> np.ndarray:
        """:meth:`eval_fs` at directions given by angles in radians (θ from the normal plane,
        φ = atan2(ω.z, ω.y)); the arguments broadcast."""
        return self.eval_fs(directions_from_angles(theta_i, phi_i), directions_from_angles(theta_r, phi_r), h)

    def sample(self, wo, u, h=None) -> Sample:
        """Importance-samples ω_i given ``wo``: ``u`` has shape ``(..., 4)``, uniforms in
        [0, 1) (two 2D pairs, as the renderer uses them). Returns a :class:`Sample`
        ``(wi, weight, pdf, lobe)``; ``weight = f_s · cos θ_i / pdf``."""
        wo = _as_directions("wo", wo)
        uu = np.asarray(u, dtype=np.float64)
        if uu.ndim == 0 or uu.shape[-1] != 4:
            raise ValueError(f"u: expected an array of shape (..., 4), got shape {uu.shape}")
        hh = np.zeros(()) if h is None else np.asarray(h, dtype=np.float64)
        batch = _batch([("wo", wo.shape[:-1]), ("u", uu.shape[:-1]), ("h", hh.shape)])
        wi, weight, pdf, lobe = _call(
            batch, self._native.sample, _flatten(batch, wo, 3), _flatten(batch, uu, 4), _flatten(batch, hh, None)
        )
        return Sample(wi.reshape(batch + (3,)), weight.reshape(batch + (3,)), pdf.reshape(batch), lobe.reshape(batch))


def directions_from_angles(theta, phi) -> np.ndarray:
    """Unit vectors ``(sin θ, cos θ cos φ, cos θ sin φ)`` of angles in radians (θ from the normal
    plane); the arguments broadcast: shape ``broadcast(θ, φ) + (3,)``."""
    t, p = np.broadcast_arrays(np.asarray(theta, dtype=np.float64), np.asarray(phi, dtype=np.float64))
    return np.stack([np.sin(t), np.cos(t) * np.cos(p), np.cos(t) * np.sin(p)], axis=-1)


def load_dict(d: Mapping[str, Any]) -> Model:
    """A model from a dict in Mitsuba's style: ``{"type": "chiang", "beta_m": 0.3, …}``
    (values: numbers, strings, booleans, lists — as in a scene file)."""
    if "type" not in d:
        raise ValueError("load_dict: the dict needs a 'type' key naming the model (see fiberlab.models())")
    params = {k: v for k, v in d.items() if k != "type"}
    return Model(d["type"], **params)


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float, np.integer, np.floating)):
        x = float(v) if isinstance(v, (float, np.floating)) else int(v)
        if isinstance(x, float) and not np.isfinite(x):
            return "nan" if np.isnan(x) else ("inf" if x > 0 else "-inf")
        return repr(x)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, Mapping):
        return "{ " + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + " }"
    if isinstance(v, (list, tuple, np.ndarray)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise ValueError(f"scene: cannot write {type(v).__name__} {v!r} as TOML")


def scene_toml(scene: Mapping[str, Any]) -> str:
    """The TOML text of a scene given as a dict with the scene file's structure
    (``{"camera": {...}, "materials": {"hair": {...}}, "hair": [{...}], "light": [{...}]}``):
    dicts of dicts become tables, lists of dicts arrays of tables (``[[hair]]``)."""
    lines = []

    def table(prefix: str, d: Mapping[str, Any]) -> None:
        scalars = {k: v for k, v in d.items() if not _is_table(v) and not _is_table_list(v)}
        if prefix and (scalars or not d):
            lines.append(f"[{prefix}]")
        for k, v in scalars.items():
            lines.append(f"{k} = {_toml_value(v)}")
        for k, v in d.items():
            name = f"{prefix}.{k}" if prefix else k
            if _is_table(v):
                table(name, v)
            elif _is_table_list(v):
                for item in v:
                    lines.append(f"[[{name}]]")
                    for ik, iv in item.items():
                        lines.append(f"{ik} = {_toml_value(iv)}")

    table("", scene)
    return "\n".join(lines) + "\n"


def _is_table(v: Any) -> bool:
    return isinstance(v, Mapping)


def _is_table_list(v: Any) -> bool:
    return isinstance(v, (list, tuple)) and len(v) > 0 and all(isinstance(x, Mapping) for x in v)


def render(scene=None, *, text: Optional[str] = None, spp: Optional[int] = None, seed: Optional[int] = None,
           max_depth: Optional[int] = None, threads: int = 0, progress=None, integrator: Optional[str] = None,
           fiber_count: Optional[str] = None, dual: Optional[Mapping[str, Any]] = None,
           device: str = "cpu") -> np.ndarray:
    """Renders a scene like ``fiberlab render`` and returns ``(H, W, 3)`` float32 linear RGB.

    ``scene``: a TOML file path, a dict with the scene file's structure (see
    :func:`scene_toml`), or ``None`` with ``text=None`` for the built-in default scene.
    ``spp``, ``seed``, ``max_depth`` override the scene's. ``integrator`` (``"path"`` or
    ``"dual-scattering"``) and ``fiber_count`` (``"exact"`` or ``"grid"``) override its
    ``[render]`` entries; ``dual`` maps dual-scattering options to values, the keys and values
    of ``fiberlab render --dual KEY=VALUE`` (e.g. ``{"d_f": 0.5, "surface_bounce": "on"}``).
    ``device``: ``"cpu"`` (default), ``"gpu"`` (the GPU path tracer; software Vulkan counts) or
    ``"auto"`` (a hardware GPU when there is one, else the CPU), as ``fiberlab render --device``.
    ``progress(done, total)`` is called
    about every 50 ms with the pixel samples done (e.g. to drive tqdm); ``progress=True`` prints
    the percentage done to standard error instead. Ctrl-C raises KeyboardInterrupt after stopping
    the render. The same scene and seed give the same image as the command line, bit for bit.
    A scene whose image, hair and BVH need more memory than the process may use raises
    ``MemoryError`` (the command line's check and message) before anything is built.
    """
    path = None
    if isinstance(scene, Mapping):
        if text is not None:
            raise ValueError("render: give a scene dict or its text, not both")
        text = scene_toml(scene)
    elif scene is not None:
        path = str(scene)
    options = [f"{k}={_option_text(v)}" for k, v in (dual or {}).items()]
    return _native.render(path, text, spp, seed, max_depth, threads, _progress_callback(progress), integrator,
                          fiber_count, options, device)


def _progress_callback(progress):
    """``render``'s ``progress``: ``None``/``False`` (none), ``True`` (a percentage on standard
    error) or a callable ``(done, total)``."""
    if progress is None or progress is False:
        return None
    if progress is True:
        import sys

        def report(done: int, total: int) -> None:
            percent = 100.0 * done / total if total else 100.0
            end = "\n" if total and done >= total else ""
            print(f"\rrendering: {percent:5.1f}%", end=end, file=sys.stderr, flush=True)

        return report
    if not callable(progress):
        raise TypeError(f"render: progress must be a callable (done, total), True or None, got {type(progress).__name__}")
    return progress


def _option_text(v: Any) -> str:
    """A dual-scattering option value as the command line writes it (``pi=True`` → ``on``)."""
    if isinstance(v, bool):
        return "on" if v else "off"
    return str(v)


def read_exr(path) -> np.ndarray:
    """The R, G, B channels of an OpenEXR file as an ``(H, W, 3)`` float32 array."""
    return _native.read_exr(str(path))


def measure(fiber: Optional[Mapping[str, Any]] = None, theta_i=0.0, phi_i: float = 0.0, rays: int = 100_000,
            bins=(180, 360), seed: int = 1):
    """Measures a fiber with the virtual goniophotometer, like ``fiberlab measure`` (the same
    numbers for the same parameters and seed).

    ``fiber``: a dict of the fiber's parameters — the keys of ``fiberlab measure --param``
    (``eta``, ``sigma_a``, ``aspect``, ``orientation``, ``scale_angle``, ``scale_length``,
    ``medulla_radius``, ``medulla_sigma_s``, ``medulla_sigma_a``, ``medulla_g``, ``surface``,
    ``albedo``) with the units of a fiber TOML file (``orientation`` and ``scale_angle`` in
    degrees). ``theta_i`` (radians, |θ_i| < 89.9°) is a number or a list; ``phi_i`` radians;
    ``bins = (nθ, nφ)`` over θ_r ∈ [−π/2, π/2] and φ = φ_r − φ_i ∈ [−π, π].

    Returns, for a scalar ``theta_i``, a dict with ``theta_i``, ``phi_i``, bin centres
    ``theta_r`` ``(nθ,)`` and ``phi`` ``(nφ,)`` (radians), ``lobes`` (``"r"``, ``"tt"``,
    ``"trt"``, ``"higher"``, ``"medulla"``, ``"all"`` → ``{"f", "std"}`` ``(nθ, nφ, 3)`` f_s in
    sr⁻¹ and its Monte Carlo standard error, and ``"albedo"`` ``(3,)``) and the ray counts
    ``traced``, ``missed``, ``dropped``, ``masked`` (paths ended by a rough interface); for a
    list, a list of such dicts.
    """
    thetas = np.atleast_1d(np.asarray(theta_i, dtype=np.float64))
    if thetas.ndim != 1:
        raise ValueError(f"measure: theta_i must be a number or a list, got shape {thetas.shape}")
    try:
        nt, nphi = (int(b) for b in bins)
    except (TypeError, ValueError):
        raise ValueError(f"measure: bins must be two positive integers (nθ, nφ), got {bins!r}") from None
    if int(rays) < 1 or nt < 1 or nphi < 1 or int(seed) < 0:
        raise ValueError(f"measure: rays and bins must be positive and seed non-negative, got rays={rays}, "
                         f"bins={bins!r}, seed={seed}")
    out = _native.measure(dict(fiber or {}), [float(t) for t in thetas], float(phi_i), int(rays), nt, nphi,
                          int(seed))
    return out if np.ndim(theta_i) else out[0]


def _image(name: str, a) -> np.ndarray:
    arr = np.ascontiguousarray(np.asarray(a, dtype=np.float64))
    if arr.ndim != 3 or arr.shape[2] != 3:
        raise ValueError(f"{name}: expected an (H, W, 3) array, got shape {arr.shape}")
    return arr


def compare(a, b, mask=None, align: bool = False) -> dict:
    """Image metrics of ``b`` against the reference ``a`` (``(H, W, 3)`` linear RGB), computed
    by the code of ``fiberlab compare``: ``{"rmse", "relmse", "ssim", "flip"}`` (RMSE and
    relative MSE of linear values, SSIM of the sRGB-encoded luminance, mean ꟻLIP error), plus
    ``"scale"`` (the per-channel least-squares factors applied to ``b``) when ``align``.
    ``mask`` (``(H, W, 3)`` or ``(H, W)``) selects the pixels whose mean is above one half."""
    m = None
    if mask is not None:
        m = np.asarray(mask, dtype=np.float64)
        if m.ndim == 2:
            m = np.repeat(m[..., None], 3, axis=2)
        m = _image("mask", m)
    return _native.compare(_image("a", a), _image("b", b), m, bool(align))


def fit(type: str, wi, wo, value, sigma=None, *, init: Mapping[str, Any], fixed: Optional[Mapping[str, Any]] = None,
        channel=None, max_iters: int = 400) -> dict:
    """Fits model ``type``'s parameters ``init`` (key → starting number, or ``[r, g, b]`` to fit
    a colour per channel) to measured f_s, like ``fiberlab fit``: weighted least squares
    (Nelder–Mead, then Levenberg–Marquardt steps) of ``(f_s(wi, wo) − value)/sigma``, the model
    averaged over the fiber's width when it is near-field.

    ``wi``, ``wo``: ``(N, 3)`` directions; ``value`` ``(N,)`` in sr⁻¹; ``sigma`` ``(N,)``
    standard errors (default: all 1); ``channel`` ``(N,)``: −1 luminance (default), 0/1/2 red,
    green, blue. ``fixed``: the other parameters. Returns ``{"params", "uncertainty",
    "at_bound", "chi2", "dof", "iterations", "model"}``: an uncertainty is a σ or the reason
    none can be given; ``at_bound`` names each fitted number that ended on its bound;
    ``model`` is the fitted :class:`Model`.
    """
    wi, wo = _as_directions("wi", wi), _as_directions("wo", wo)
    v = np.ascontiguousarray(np.asarray(value, dtype=np.float64).reshape(-1))
    n = v.shape[0]
    s = np.ones(n) if sigma is None else np.ascontiguousarray(np.broadcast_to(np.asarray(sigma, dtype=np.float64), (n,)))
    c = np.full(n, -1, dtype=np.int64) if channel is None else np.ascontiguousarray(
        np.broadcast_to(np.asarray(channel, dtype=np.int64), (n,)))
    a = np.ascontiguousarray(np.broadcast_to(wi, (n, 3)))
    b = np.ascontiguousarray(np.broadcast_to(wo, (n, 3)))
    fixed = dict(fixed or {})
    r = _native.fit(type, fixed, dict(init), a, b, v, s, c, max_iters)
    r["model"] = Model(type, **fixed, **r["params"])
    return r


def compare_model(model: Model, table, *, subsamples: int = 3, viewer_first: bool = False) -> dict:
    """Compares ``model`` with a measured table (a CSV written by ``fiberlab measure`` or
    :func:`measure`'s command-line twin; fiber or surface), like ``fiberlab compare-model
    --json``, by the same library call (``fiberlab_compare::model_table::compare_model``):
    the same dict as that JSON. A fiber table gives one entry per lobe both have (``r``,
    ``tt``, ``trt``, ``medulla``, ``all``: ``{rel_l2, mc_rel_l2, peak_measured, peak_model,
    per_theta_i}``, angles in degrees, ``None`` where the command line writes ``null``); a
    surface table ``{"fiber": [...]}`` (a fiber highlight) or ``{"all": [...]}`` (the
    residual). ``subsamples``: midpoint nodes per bin along θ; ``viewer_first``: the table's
    incidence is the viewer's direction."""
    if int(subsamples) < 1:
        raise ValueError(f"compare_model: subsamples must be at least 1, got {subsamples}")
    return _json.loads(_native.compare_model(model._native, str(table), int(subsamples), bool(viewer_first)))


def evaluate(scene=None, *, text: Optional[str] = None, models=("kajiya-kay", "marschner", "chiang"),
             params: Optional[Mapping[str, Mapping[str, Any]]] = None, table=None, reference=None,
             spp: Optional[int] = None, reference_spp: int = 256, kajiya_kay_colour: str = "scene") -> dict:
    """The colour-matched evaluation of ``fiberlab evaluate`` by the same library call
    (``fiberlab_compare::evaluation::evaluate``): each of ``models`` (names, or one
    comma-separated string) rendered in the scene (a path, a dict as for :func:`render`,
    ``text=``, or the default scene) with the scene's hair absorption, against the render of
    the ``measured`` model of ``table`` (a ``fiberlab measure`` CSV) or a ``reference`` image
    (``(H, W, 3)`` linear RGB). ``params`` maps a model name to its parameters (the command
    line's ``--param MODEL:KEY=VALUE``); ``spp``, ``reference_spp``, ``kajiya_kay_colour``
    (``"scene"`` or ``"fiber"``) as its flags.

    Returns ``{"metrics": [...], "images": {...}}``: ``metrics`` the rows of ``metrics.json``
    (``model``, ``given``, ``rmse``, ``rmse_noise``, ``rmse_excess``, ``relmse``,
    ``relmse_noise``, ``ssim``, ``flip``, ``image_noise``, ``reference_noise``,
    ``hair_colour``: per channel, the hair pixels' mean over the reference's), ``images``
    ``"reference"`` and each model → ``(H, W, 3)`` float32 linear RGB."""
    path = None
    if isinstance(scene, Mapping):
        if text is not None:
            raise ValueError("evaluate: give a scene dict or its text, not both")
        text = scene_toml(scene)
    elif scene is not None:
        path = str(scene)
    names = [n.strip() for n in models.split(",")] if isinstance(models, str) else [str(n) for n in models]
    names = [n for n in names if n]
    params = dict(params or {})
    unknown = sorted(set(params) - set(names))
    if unknown:
        raise ValueError(f"evaluate: params for {unknown}, which are not among the models {names}")
    ref = None if reference is None else _image("reference", reference)
    if int(reference_spp) < 1 or (spp is not None and int(spp) < 1):
        raise ValueError(f"evaluate: spp and reference_spp must be at least 1, got {spp}, {reference_spp}")
    rows, images = _native.evaluate(path, text, [(n, dict(params.get(n, {}))) for n in names],
                                    None if table is None else str(table), ref,
                                    None if spp is None else int(spp), int(reference_spp),
                                    str(kajiya_kay_colour))
    return {"metrics": _json.loads(rows), "images": images}


def check(model, chi2_samples: Optional[int] = None, samples: Optional[int] = None,
          pairs: Optional[int] = None) -> list:
    """Runs the validation harness of ``fiberlab check`` on one model, fiber or surface (χ² tests of sampling,
    pdf integrals, sample weights, white furnace, reciprocity, finiteness, … as the model's
    claims allow): a list of dicts ``{model, test, value, expected, tolerance, pass,
    report}``; ``report`` rows are measurements without a pass/fail claim. The effort
    (samples per χ² test, per Monte Carlo test, random direction pairs) defaults to the
    command line's; the rows are the command line's for the same configuration. ``model`` is a
    :class:`Model` or a model's name (with its default parameters)."""
    if isinstance(model, str):
        model = Model(model)
    elif not isinstance(model, Model):
        raise TypeError(f"check: expected a fiberlab.Model or a model name, got {type(model).__name__}")
    label = " ".join([model.name] + [f"{k}={_label_value(v)}" for k, v in model._given.items()])
    return _native.check(model._native, label, chi2_samples, samples, pairs)


def _label_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (list, tuple, np.ndarray)):
        return ",".join(_label_value(x) for x in v)
    return str(v)


def _constructor(name: str):
    spec = next(m for m in models() if m["name"] == name)

    def make(**params: Any) -> Model:
        return Model(name, **params)

    lines = [f"{spec['summary']} ({spec['citation']}).", "", "Parameters (keyword arguments):"]
    for p in spec["params"]:
        unit = f" [{p['unit']}]" if p["unit"] else ""
        default = f", default {p['default']}" if p["default"] else ""
        lines.append(f"    {p['key']}{unit}: {p['doc']} ({p['valid']}{default})")
    make.__doc__ = "\n".join(lines)
    make.__name__ = make.__qualname__ = "".join(part.capitalize() for part in name.split("-"))
    return make


for _spec in models():
    _make = _constructor(_spec["name"])
    globals()[_make.__name__] = _make
    __all__.append(_make.__name__)
del _spec, _make

# Submodules: fl.frames, fl.hair, fl.mitsuba (which imports Mitsuba only when registering).
from . import frames, hair, mitsuba  # noqa: E402
