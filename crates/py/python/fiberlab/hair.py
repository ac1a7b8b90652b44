"""Hair strands as arrays: hair files (cyHair ``.hair`` read and written; pbrt-v4 curves and
USD ``.usda`` read — what ``fiberlab hair`` and scene files read) and the procedural generator
of ``fiberlab hair generate``.

A hair is a list of strands, each an ``(n_i, 3)`` float32 array of points from root to tip
(scene units), with an optional diameter per point.
"""

from __future__ import annotations

from typing import Any, List, NamedTuple, Optional, Sequence

import numpy as np

from . import _native

__all__ = ["Strands", "read", "write", "generate"]


class Strands(NamedTuple):
    """Strands of a hair file."""

    strands: List[np.ndarray]
    """One ``(n_i, 3)`` float32 array per strand (views into one array), root first."""
    thickness: Optional[List[np.ndarray]]
    """Diameter per point, one ``(n_i,)`` float32 array per strand; ``None`` when the file has
    no thickness array (every point then has :attr:`default_thickness`)."""
    default_thickness: float
    """The file's diameter for points without a thickness array."""


def _split(points, counts, thickness, has_thickness, default_thickness) -> Strands:
    ends = np.cumsum(counts)[:-1]
    strands = np.split(points, ends) if len(counts) else []
    per_point = np.split(thickness, ends) if len(counts) else []
    return Strands(strands, per_point if has_thickness else None, float(default_thickness))


def read(path, segments_per_curve: int = 8) -> Strands:
    """Reads a hair file by its extension — ``.hair``, pbrt-v4 curves (``.pbrt``, ``.pbrt.gz``)
    or USD ``BasisCurves`` (``.usda``), as scenes and ``fiberlab hair info`` do. Cubic curves are
    returned as polylines, each span evaluated at ``segments_per_curve`` uniform steps (as
    ``fiberlab hair convert`` writes them to ``.hair``). Every malformed file raises
    ``ValueError`` naming the file and the line or byte."""
    return _split(*_native.hair_read(str(path), int(segments_per_curve)))


def write(path, strands: Sequence[Any], thickness: Optional[Sequence[Any]] = None,
          default_thickness: float = 1.0) -> None:
    """Writes ``strands`` (a list of ``(n_i, 3)`` arrays, each with 1 to 65,536 points) as a
    ``.hair`` file — or as USD ``BasisCurves`` when ``path`` ends in ``.usda`` (the format follows
    the name; a ``.pbrt`` name or an unknown extension raises ``ValueError``) — with a thickness
    array when ``thickness`` (one ``(n_i,)`` array per strand, or one number per strand) is
    given, else ``default_thickness`` for every point. Values are stored as float32. The file is
    written to a temporary file and renamed into place; a symbolic link, a FIFO or a device at
    ``path`` is refused."""
    arrays = [np.asarray(s, dtype=np.float32) for s in strands]
    for i, a in enumerate(arrays):
        if a.ndim != 2 or a.shape[1] != 3:
            raise ValueError(f"strand {i}: expected an array of shape (n, 3), got shape {a.shape}")
    counts = np.array([len(a) for a in arrays], dtype=np.int64)
    points = np.ascontiguousarray(np.concatenate(arrays) if arrays else np.zeros((0, 3), np.float32))
    t = None
    if thickness is not None:
        if len(thickness) != len(arrays):
            raise ValueError(f"thickness: expected {len(arrays)} entries (one per strand), got {len(thickness)}")
        parts = []
        for i, (a, ti) in enumerate(zip(arrays, thickness)):
            ti = np.broadcast_to(np.asarray(ti, dtype=np.float32), (len(a),)) if np.ndim(ti) == 0 else \
                np.asarray(ti, dtype=np.float32)
            if ti.shape != (len(a),):
                raise ValueError(f"thickness of strand {i}: expected shape ({len(a)},), got {ti.shape}")
            parts.append(ti)
        t = np.ascontiguousarray(np.concatenate(parts) if parts else np.zeros(0, np.float32))
    _native.hair_write(str(path), points, counts, t, float(default_thickness))


def generate(**params: Any) -> Strands:
    """Grows procedural hair on a unit head sphere like ``fiberlab hair generate`` (the same
    strands for the same parameters): keyword arguments are the generator's keys of a scene
    file's ``[hair.generator]`` table — ``strands``, ``segments``, ``length``, ``style``
    (``"straight"``, ``"wavy"``, ``"curly"``, ``"fur"``), ``amplitude``, ``wavelength``,
    ``clumps``, ``clumping``, ``gravity``, ``noise``, ``root_diameter``, ``tip_ratio``,
    ``length_jitter``, ``seed``, … (lengths in head radii). As in a scene file, keys not given take
    the hair defaults, also for ``style="fur"`` (give the fur values, as ``scenes/fur.toml`` does)."""
    from . import _toml_value

    text = "\n".join(f"{k} = {_toml_value(v)}" for k, v in params.items()) + "\n"
    return _split(*_native.hair_generate(text))
