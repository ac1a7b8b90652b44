"""Conversions between fiberlab's fiber frame and the local frame of Mitsuba 3's hair BSDF.

fiberlab (``docs/theory/conventions.md``, "Fiber frame"): local ``x`` is the fiber tangent u
(root → tip), ``y`` = v and ``z`` = w span the normal plane, θ is the inclination from the
normal plane (sin θ = ω.x) and φ = atan2(ω.z, ω.y).

Mitsuba 3 (``src/bsdfs/hair.cpp`` of mitsuba-renderer/mitsuba3, the ``hair`` plugin, Chiang
et al. 2016): the shading frame of a hit on a curve has the tangent on local ``+y``
(``sincos_theta`` reads sin θ = ω.y), ``x`` and ``z`` span the normal plane with ``z`` the
surface normal at the hit, and the azimuth is φ = atan2(ω.z, ω.x) (``azimuthal_angle``). The
offset is not an argument: ``gamma`` is the angle between the normal ``z`` and the viewer
direction ``si.wi`` projected onto the normal plane, negative when ``si.wi.x > 0``, and
h = sin γ = −wi.x / sqrt(wi.x² + wi.z²). Mitsuba names the viewer direction ``si.wi`` and the
light direction ``wo`` (the reverse of fiberlab's ``wi`` → light, ``wo`` → viewer).

The map used here is the right-handed one that puts fiberlab's w on Mitsuba's normal::

    fiberlab (x, y, z) = (u, v, w)  ←→  Mitsuba (x, y, z) = (−v, u, w)

so θ is unchanged, φ_fiberlab = π − φ_mitsuba (azimuth differences change sign), and the
offset Mitsuba derives from a viewer direction is the negative of fiberlab's offset of the
same ray (fiberlab's h grows toward +v for a ray arriving from +w): h_mitsuba = −h_fiberlab.
Every fiberlab model is unchanged under the mirror (φ, h) → (−φ, −h), so for circular fibers
the two conventions describe the same scattering.
"""

from __future__ import annotations

import numpy as np

__all__ = ["to_mitsuba", "from_mitsuba", "mitsuba_offset", "offset_to_mitsuba", "offset_from_mitsuba"]


def _directions(name: str, w) -> np.ndarray:
    a = np.asarray(w, dtype=np.float64)
    if a.ndim == 0 or a.shape[-1] != 3:
        raise ValueError(f"{name}: expected an array of shape (..., 3), got shape {a.shape}")
    return a


def to_mitsuba(w) -> np.ndarray:
    """Directions ``(..., 3)`` in fiberlab's fiber frame → Mitsuba 3's hair shading frame:
    ``(−w.y, w.x, w.z)``."""
    a = _directions("w", w)
    return np.stack([-a[..., 1], a[..., 0], a[..., 2]], axis=-1)


def from_mitsuba(w) -> np.ndarray:
    """Directions ``(..., 3)`` in Mitsuba 3's hair shading frame → fiberlab's fiber frame:
    ``(w.y, −w.x, w.z)`` (the inverse of :func:`to_mitsuba`)."""
    a = _directions("w", w)
    return np.stack([a[..., 1], -a[..., 0], a[..., 2]], axis=-1)


def mitsuba_offset(wi_mitsuba) -> np.ndarray:
    """The offset h that Mitsuba 3's hair BSDF derives from its viewer direction ``si.wi``
    (Mitsuba's frame): sin γ with γ the signed angle from the normal ``z``,
    ``−wi.x / sqrt(wi.x² + wi.z²)`` (0 for a direction along the tangent)."""
    a = _directions("wi_mitsuba", wi_mitsuba)
    p = np.hypot(a[..., 0], a[..., 2])
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(p > 0, -a[..., 0] / np.where(p > 0, p, 1.0), 0.0)


def offset_to_mitsuba(h) -> np.ndarray:
    """fiberlab's offset h → Mitsuba's for the same ray: −h."""
    return -np.asarray(h, dtype=np.float64)


def offset_from_mitsuba(h) -> np.ndarray:
    """Mitsuba's offset → fiberlab's: −h."""
    return -np.asarray(h, dtype=np.float64)
