"""A fiberlab model as a Mitsuba 3 BSDF: ``fl.mitsuba.register()`` and then
``mi.load_dict({"type": "fiberlab", "model": "chiang", "eumelanin": 1.3})``.

Needs the ``mitsuba`` package (``pip install mitsuba``); importing this module does not import
it, :func:`register` does. Every key of the dict other than ``type`` and ``model`` is a
parameter of the fiberlab model (``fl.models()``, the keys of ``fiberlab models``; degrees for
angles, as on the command line); colours may be given as ``[r, g, b]`` lists.

Conventions (Mitsuba 3's ``hair`` plugin, ``src/bsdfs/hair.cpp`` of mitsuba-renderer/mitsuba3):

* Directions are in Mitsuba's hair shading frame (tangent on local +y, normal plane x–z, the
  surface normal on +z) and are mapped to fiberlab's fiber frame by :mod:`fiberlab.frames`.
  ``si.wi`` is the viewer side (fiberlab's ``wo``), the BSDF's ``wo`` the light side (fiberlab's
  ``wi``).
* The offset across the fiber is derived from ``si.wi`` as the hair plugin derives it: h = sin γ
  with γ the angle between the normal +z and ``si.wi`` projected onto the normal plane
  (:func:`fiberlab.frames.mitsuba_offset`), mapped to fiberlab's sign of h. ``si.uv`` is not
  read (the hair plugin does not read it either).
* ``eval`` is fiberlab's ``Model.eval``: f_s · |cos θ| of the light direction (Mitsuba's ``wo``),
  θ from the normal plane — Mitsuba's convention of a BSDF value times the foreshortening of the
  outgoing/sampled direction. ``pdf`` is the density of ``sample`` per steradian, and ``sample``
  returns the weight f_s · cos θ / pdf of the fiberlab sampler.
* ``sample`` gets three uniforms (``sample1`` and ``sample2``); fiberlab's samplers take four:
  they are ``(s1, s2.x, s2.y, v)`` with ``v`` a hash of the three (their bits through the
  SplitMix64 finalizer, 53 bits): statistically independent of them and uniform, though not
  stratified with them. (Taking ``v`` from the low bits of ``s1`` instead fails Mitsuba's χ² test:
  its float32 uniforms have 23 bits, too few to split.) The chosen lobe index is in
  ``bs.sampled_component``.
* Vectorized variants (``llvm_ad_rgb``, …) convert the Dr.Jit arrays of a call to NumPy and
  evaluate them in one call of the vectorized model (no loop in Python); scalar variants call it
  with one element. A Python BSDF cannot be traced into a Dr.Jit kernel: to render with it in a
  vectorized variant, turn off symbolic loops and calls first
  (``dr.set_flag(dr.JitFlag.SymbolicLoops, False)``, ``dr.set_flag(dr.JitFlag.SymbolicCalls,
  False)``), as for any Python plugin evaluated with NumPy. Gradients do not flow through it.
* Directions that are not unit vectors (e.g. the zero vectors of inactive lanes) and inactive
  lanes give zero values and densities.

Matching Mitsuba's built-in ``hair`` (Chiang et al. 2016) with fiberlab's ``chiang``:
``longitudinal_roughness`` → ``beta_m``, ``azimuthal_roughness`` → ``beta_n`` (the same
roughness maps), ``scale_tilt`` → ``alpha = −scale_tilt`` (Mitsuba and pbrt-v4 rotate the lobes
with the opposite sign of the tilt), ``int_ior / ext_ior`` → ``eta`` (Mitsuba's default is
1.55/1.000277), ``eumelanin``/``pheomelanin`` → the same keys (the same d'Eon 2011 table; Mitsuba's
default pheomelanin is 0.2, fiberlab's 0), an RGB ``sigma_a`` (per unit radius in both) →
``sigma_a``. ``crates/py/tests/test_mitsuba.py`` compares the two.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import Model, frames

__all__ = ["register"]

#: Keys of the Mitsuba dict that are not parameters of the fiberlab model.
_NOT_PARAMETERS = ("type", "model", "id")

_UNIT_TOLERANCE = 1e-3


def _prop_value(value: Any) -> Any:
    """A Mitsuba property value as a fiberlab parameter value (numbers, strings, booleans, lists)."""
    if isinstance(value, (bool, int, float, str)):
        return value
    try:
        arr = np.array(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"fiberlab BSDF: cannot use property value {value!r} ({type(value).__name__})") from None
    return float(arr[0]) if arr.size == 1 else [float(x) for x in arr]


def _columns(x: Any, n: int) -> np.ndarray:
    """A Dr.Jit 3-vector (scalar or of arrays) as an ``(n, 3)`` float64 array."""
    a = np.array(x, dtype=np.float64)
    a = a.reshape(3, -1)
    return np.ascontiguousarray(np.broadcast_to(a, (3, n)).T)


def _values(x: Any, n: int, dtype=np.float64) -> np.ndarray:
    """A Dr.Jit scalar or 1D array as an ``(n,)`` array."""
    return np.ascontiguousarray(np.broadcast_to(np.array(x, dtype=dtype).reshape(-1), (n,)))


def _hash_uniform(*xs: np.ndarray) -> np.ndarray:
    """A uniform in [0, 1) per element from the float32 bit patterns of ``xs`` (SplitMix64's
    finalizer, Steele, Lea & Flood 2014, applied after folding each input in)."""
    state = np.zeros(xs[0].shape, dtype=np.uint64)
    with np.errstate(over="ignore"):
        for x in xs:
            bits = np.ascontiguousarray(x, dtype=np.float32).view(np.uint32).astype(np.uint64)
            z = state + bits + np.uint64(0x9E3779B97F4A7C15)
            z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
            z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
            state = z ^ (z >> np.uint64(31))
    return (state >> np.uint64(11)).astype(np.float64) * 2.0**-53


def _width(*xs: Any) -> int:
    import drjit as dr

    return max(int(dr.width(x)) for x in xs)


def _valid_directions(w: np.ndarray) -> np.ndarray:
    length = np.linalg.norm(w, axis=-1)
    return np.isfinite(length) & (np.abs(length - 1.0) <= _UNIT_TOLERANCE)


def register(name: str = "fiberlab") -> None:
    """Registers the BSDF plugin ``name`` with Mitsuba 3 for the current variant (call
    ``mi.set_variant`` first; call again after changing the variant)."""
    import drjit as dr
    import mitsuba as mi

    scalar = mi.variant().startswith("scalar")

    def to_float(x: np.ndarray):
        return float(x[0]) if scalar else mi.Float(x.astype(np.float32))

    def to_vector(v: np.ndarray):
        if scalar:
            return mi.Vector3f(float(v[0, 0]), float(v[0, 1]), float(v[0, 2]))
        f = v.astype(np.float32)
        return mi.Vector3f(mi.Float(f[:, 0]), mi.Float(f[:, 1]), mi.Float(f[:, 2]))

    def to_spectrum(c: np.ndarray):
        if scalar:
            return mi.Spectrum(float(c[0, 0]), float(c[0, 1]), float(c[0, 2]))
        f = c.astype(np.float32)
        return mi.Spectrum(mi.Float(f[:, 0]), mi.Float(f[:, 1]), mi.Float(f[:, 2]))

    class FiberlabBSDF(mi.BSDF):
        """A fiberlab model as a Mitsuba BSDF (see the module :mod:`fiberlab.mitsuba`)."""

        def __init__(self, props: "mi.Properties") -> None:
            mi.BSDF.__init__(self, props)
            if "model" not in props:
                raise ValueError(f"{name} BSDF: the dict needs a 'model' key naming the fiberlab model")
            params = {k: _prop_value(props[k]) for k in props.keys() if k not in _NOT_PARAMETERS}
            self.model = Model(str(props["model"]), **params)
            if self.model.flags["kind"] != "fiber":
                raise ValueError(f"{name} BSDF: `{props['model']}` is a surface model; the adapter maps the hair frame "
                                 "of fiber models (use Mitsuba's own surface BSDFs)")
            self.delta = self.model.flags["lobes"] == "delta"
            lobe = mi.BSDFFlags.DeltaReflection if self.delta else mi.BSDFFlags.Glossy
            flags = lobe | mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide | mi.BSDFFlags.NonSymmetric
            if not self.delta:
                flags = flags | mi.BSDFFlags.Anisotropic
            self.m_components = [flags]
            self.m_flags = flags

        # -- the fiberlab side of a call -------------------------------------------------------
        def _viewer(self, si, n: int):
            wv = frames.from_mitsuba(_columns(si.wi, n))
            ok = _valid_directions(wv)
            wv[~ok] = (0.0, 0.0, 1.0)
            h = np.clip(frames.offset_from_mitsuba(frames.mitsuba_offset(frames.to_mitsuba(wv))), -1.0, 1.0)
            return wv, h, ok

        def _pairs(self, si, wo, active):
            n = _width(si.wi, wo, active)
            wv, h, ok = self._viewer(si, n)
            wl = frames.from_mitsuba(_columns(wo, n))
            ok &= _valid_directions(wl) & _values(active, n, bool)
            wl[~ok] = (0.0, 0.0, 1.0)
            return wl, wv, h, ok

        def eval(self, ctx, si, wo, active=True):
            wl, wv, h, ok = self._pairs(si, wo, active)
            value = self.model.eval(wl, wv, h)
            value[~ok] = 0.0
            return to_spectrum(value)

        def pdf(self, ctx, si, wo, active=True):
            wl, wv, h, ok = self._pairs(si, wo, active)
            pdf = self.model.pdf(wl, wv, h)
            pdf[~ok] = 0.0
            return to_float(pdf)

        def eval_pdf(self, ctx, si, wo, active=True):
            wl, wv, h, ok = self._pairs(si, wo, active)
            value, pdf = self.model.eval_pdf(wl, wv, h)
            value[~ok] = 0.0
            pdf[~ok] = 0.0
            return to_spectrum(value), to_float(pdf)

        def sample(self, ctx, si, sample1, sample2, active=True):
            n = _width(si.wi, sample1, sample2, active)
            wv, h, ok = self._viewer(si, n)
            ok &= _values(active, n, bool)
            s1 = _values(sample1, n)
            s2 = np.broadcast_to(np.array(sample2, dtype=np.float64).reshape(2, -1), (2, n)).T
            u = np.stack([s1, s2[:, 0], s2[:, 1], _hash_uniform(s1, s2[:, 0], s2[:, 1])], axis=-1)
            u = np.clip(np.nan_to_num(u), 0.0, np.nextafter(1.0, 0.0))
            s = self.model.sample(wv, u, h)
            ok &= s.lobe >= 0
            weight = np.where(ok[:, None], s.weight, 0.0)
            wi = np.where(ok[:, None], s.wi, (0.0, 0.0, 1.0))
            bs = dr.zeros(mi.BSDFSample3f, 1 if scalar else n)
            bs.wo = to_vector(frames.to_mitsuba(wi))
            bs.pdf = to_float(np.where(ok, s.pdf, 0.0))
            bs.eta = 1.0
            sampled = mi.BSDFFlags.DeltaReflection if self.delta else mi.BSDFFlags.Glossy
            bs.sampled_type = int(sampled)
            lobe = np.maximum(s.lobe, 0).astype(np.uint32)
            bs.sampled_component = int(lobe[0]) if scalar else mi.UInt32(lobe)
            return bs, to_spectrum(weight)

        def to_string(self) -> str:
            return f"FiberlabBSDF[{self.model!r}]"

    mi.register_bsdf(name, lambda props: FiberlabBSDF(props))
