"""The peer-comparison scene as plain numbers, read from bench/peers/scene.toml and a .hair file.

Every peer (peer_mitsuba.py, peer_cycles.py) builds its scene from `load_scene`, so the TOML is the
single source of the parameters; the per-renderer conventions are documented next to the code that
maps them (see the table at the top of peers.py).
"""

import struct
import tomllib

import numpy as np

HAIR_MAGIC = b"HAIR"
HAIR_HEADER_BYTES = 128
HAIR_SEGMENTS_BIT, HAIR_POINTS_BIT, HAIR_THICKNESS_BIT = 1, 2, 4


def only(items, what):
    """The single element of `items`; the comparison scene has exactly one of each thing."""
    if len(items) != 1:
        raise ValueError(f"the peer scene must have exactly one {what}, found {len(items)}")
    return items[0]


def light_of_type(lights, kind):
    """The single [[light]] whose type is `kind`."""
    return only([light for light in lights if light["type"] == kind], f'[[light]] type = "{kind}"')


def load_scene(toml_path):
    """The scene parameters as a flat dict (fiberlab's conventions: Y up, directions toward the light)."""
    with open(toml_path, "rb") as f:
        doc = tomllib.load(f)
    hair = only(doc["hair"], "[[hair]]")
    sphere = only(doc["sphere"], "[[sphere]]")
    hair_material = doc["materials"][hair["material"]]
    if hair_material.get("model") != "chiang":
        raise ValueError("the peers implement only the chiang hair model")
    skin = doc["materials"][sphere["material"]]
    env = light_of_type(doc["light"], "environment")
    distant = light_of_type(doc["light"], "distant")
    return {
        "camera": doc["camera"],
        "max_depth": doc["render"]["max_depth"],
        "hair": hair_material["params"],
        "sphere_center": sphere["center"],
        "sphere_radius": sphere["radius"],
        "skin_albedo": skin["lambert"],
        "env_radiance": env["radiance"],
        "sun_direction": distant["direction"],
        "sun_irradiance": distant["irradiance"],
    }


def read_hair(path):
    """Points (N×3), radii (N) and points per strand (S) of a cyHair .hair file (root first)."""
    data = open(path, "rb").read()
    if data[:4] != HAIR_MAGIC:
        raise ValueError(f"{path}: not a .hair file")
    strands, npoints, flags, default_segments = struct.unpack_from("<IIII", data, 4)
    (default_thickness,) = struct.unpack_from("<f", data, 20)
    if not flags & HAIR_POINTS_BIT:
        raise ValueError(f"{path}: no points array")
    offset = HAIR_HEADER_BYTES
    if flags & HAIR_SEGMENTS_BIT:
        segments = np.frombuffer(data, "<u2", strands, offset).astype(np.int64)
        offset += 2 * strands
    else:
        segments = np.full(strands, default_segments, np.int64)
    points = np.frombuffer(data, "<f4", 3 * npoints, offset).reshape(-1, 3).astype(np.float64)
    offset += 12 * npoints
    if flags & HAIR_THICKNESS_BIT:
        diameters = np.frombuffer(data, "<f4", npoints, offset).astype(np.float64)
    else:
        diameters = np.full(npoints, default_thickness)
    return points, diameters / 2, segments + 1


def y_up_to_z_up(v):
    """fiberlab/Mitsuba (Y up) to Blender (Z up): (x, y, z) -> (x, -z, y), a proper rotation."""
    v = np.asarray(v, dtype=np.float64)
    return np.stack([v[..., 0], -v[..., 2], v[..., 1]], axis=-1)
