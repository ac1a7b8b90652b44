"""Render the peer scene with Blender Cycles on the CPU through PyPI `bpy` (run by peers.py in its
own process).

usage: peer_cycles.py SCENE.toml HAIR SPP OUT_PREFIX [CURVES [EXTRA_SPP]] RESULT.json

Writes OUT_PREFIX.exr (linear RGB) and RESULT.json with the load time (building the Blender data;
Cycles syncs the scene and builds its BVH inside the first render) and both render times (the
second render reuses the synced scene and BVH: persistent data). CURVES is `linear` (default:
the points as polylines) or `bspline` (the points as uniform cubic B-spline control points; see
`bspline_polylines`). EXTRA_SPP, a comma list, adds one render per sample count (persistent
data), OUT_PREFIX_<n>spp.exr, for the RMSE-versus-time curve.
"""

import json
import math
import os
import sys
import time

import bpy
import numpy as np
from mathutils import Matrix, Vector

from scene import load_scene, read_hair, y_up_to_z_up

# The head is a smooth-shaded UV sphere (Cycles has no analytic sphere primitive for meshes); at
# 512×256 segments the chord sag is 8e-5 of the radius, far below a pixel.
SPHERE_SEGMENTS, SPHERE_RINGS = 512, 256


def uv_sphere_mesh(name, center, radius, segments, rings):
    """A UV sphere built with foreach_set from numpy arrays (bmesh.ops.create_uvsphere takes
    17 s at 512×256; this takes milliseconds). Faces wind counter-clockwise seen from outside."""
    theta = np.pi * np.arange(1, rings) / rings
    phi = 2 * np.pi * np.arange(segments) / segments
    ring = np.stack([np.outer(np.sin(theta), np.cos(phi)), np.outer(np.sin(theta), np.sin(phi)),
                     np.repeat(np.cos(theta)[:, None], segments, 1)], -1).reshape(-1, 3)
    verts = np.concatenate([[[0, 0, 1]], ring, [[0, 0, -1]]]) * radius + np.asarray(center)
    south = len(verts) - 1
    i = np.arange(segments)
    j = (i + 1) % segments
    k = np.arange(rings - 2)[:, None]
    top = np.stack([np.zeros(segments, int), 1 + i, 1 + j], -1)
    quads = np.stack([1 + k * segments + i, 1 + (k + 1) * segments + i,
                      1 + (k + 1) * segments + j, 1 + k * segments + j], -1).reshape(-1, 4)
    last = 1 + (rings - 2) * segments
    bottom = np.stack([np.full(segments, south), last + j, last + i], -1)
    loops = np.concatenate([top.ravel(), quads.ravel(), bottom.ravel()])
    sizes = np.concatenate([np.full(segments, 3), np.full(len(quads), 4), np.full(segments, 3)])
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(verts))
    mesh.vertices.foreach_set("co", verts.astype(np.float32).ravel())
    mesh.loops.add(len(loops))
    mesh.loops.foreach_set("vertex_index", loops.astype(np.int32))
    mesh.polygons.add(len(sizes))
    mesh.polygons.foreach_set("loop_start", (np.cumsum(sizes) - sizes).astype(np.int32))
    mesh.update(calc_edges=True)
    mesh.shade_smooth()
    return mesh


# New materials and worlds come with node trees in Blender 5 (`use_nodes` is deprecated).


def node_input(node, name):
    """The input socket called `name` (looked up by name, not identifier, as in the UI)."""
    return next(socket for socket in node.inputs if socket.name == name)


def hair_material(params):
    """Principled Hair BSDF, Chiang model, with fiberlab's parameters mapped."""
    material = bpy.data.materials.new("hair")
    nodes = material.node_tree.nodes
    nodes.clear()
    bsdf = nodes.new("ShaderNodeBsdfHairPrincipled")
    bsdf.model = "CHIANG"
    # Cycles' melanin mode uses another table and a -ln(1 - m) slider mapping, so give it
    # fiberlab's absorption directly: sigma_a per unit radius from d'Eon's table.
    bsdf.parametrization = "ABSORPTION"
    sigma_a = [params["eumelanin"] * e + params["pheomelanin"] * p
               for e, p in zip((0.419, 0.697, 1.37), (0.187, 0.4, 1.05))]
    node_input(bsdf, "Absorption Coefficient").default_value = sigma_a
    node_input(bsdf, "Roughness").default_value = params["beta_m"]
    node_input(bsdf, "Radial Roughness").default_value = params["beta_n"]
    node_input(bsdf, "Coat").default_value = 0.0  # no extra R-lobe roughness
    node_input(bsdf, "IOR").default_value = params["eta"]
    # Cycles tilts the light-side direction (lobes centred at -2*Offset), fiberlab's sign: +alpha.
    node_input(bsdf, "Offset").default_value = math.radians(params["alpha"])
    node_input(bsdf, "Random Color").default_value = 0.0
    node_input(bsdf, "Random Roughness").default_value = 0.0
    output = nodes.new("ShaderNodeOutputMaterial")
    material.node_tree.links.new(bsdf.outputs[0], output.inputs["Surface"])
    return material


def diffuse_material(albedo):
    """Lambertian surface (Diffuse BSDF with roughness 0)."""
    material = bpy.data.materials.new("skin")
    nodes = material.node_tree.nodes
    nodes.clear()
    bsdf = nodes.new("ShaderNodeBsdfDiffuse")
    bsdf.inputs["Color"].default_value = (*albedo, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.0
    output = nodes.new("ShaderNodeOutputMaterial")
    material.node_tree.links.new(bsdf.outputs[0], output.inputs["Surface"])
    return material


def add_object(name, data):
    """Link a new object holding `data` into the scene."""
    obj = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(obj)
    return obj


# Segments per B-spline span, as fiberlab's `segments_per_curve` in the B-spline variant.
BSPLINE_SEGMENTS = 8


def bspline_polylines(points, radii, counts, steps=BSPLINE_SEGMENTS):
    """The uniform cubic B-splines of the strands' control points (and radii) evaluated at
    `steps` uniform parameter steps per span, consecutive spans sharing their end point.

    Cycles renders a Curves object's control points as Catmull-Rom ("3D Curves") or linear
    tubes, whatever the curves' type, and has no B-spline primitive to give them to; so the
    B-spline variant hands it the B-spline as polylines, the way fiberlab subdivides it."""
    t = np.arange(steps + 1) / steps
    s = 1 - t
    weights = np.stack([s ** 3, 3 * t ** 3 - 6 * t ** 2 + 4, -3 * t ** 3 + 3 * t ** 2 + 3 * t + 1, t ** 3], 1) / 6
    out_p, out_r, out_n, start = [], [], [], 0
    for n in counts:
        c, r = points[start:start + n], radii[start:start + n]
        start += n
        for i in range(n - 3):
            w = weights if i == 0 else weights[1:]
            out_p.append(w @ c[i:i + 4])
            out_r.append(w @ r[i:i + 4])
        out_n.append((n - 3) * steps + 1)
    return np.concatenate(out_p), np.concatenate(out_r), np.array(out_n)


def add_hair(hair_path, params, curves_basis="linear"):
    """The strands as a Curves object: polylines (root first) with per-point radius."""
    points, radii, counts = read_hair(hair_path)
    if curves_basis == "bspline":
        points, radii, counts = bspline_polylines(points, radii, counts)
    curves = bpy.data.hair_curves.new("hair")
    curves.add_curves(counts.tolist())
    curves.set_types(type="POLY")
    curves.position_data.foreach_set("vector", y_up_to_z_up(points).astype(np.float32).ravel())
    radius = curves.attributes.get("radius") or curves.attributes.new("radius", "FLOAT", "POINT")
    radius.data.foreach_set("value", radii.astype(np.float32))
    curves.materials.append(hair_material(params))
    add_object("hair", curves)


def add_lights(s):
    """Constant world background (radiance, strength 1) and a sun of angle 0 (a delta light)."""
    world = bpy.data.worlds.new("world")
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (*s["env_radiance"], 1.0)
    background.inputs["Strength"].default_value = 1.0
    bpy.context.scene.world = world
    # Sun strength is irradiance in W/m^2: strength = max component, colour = irradiance / strength.
    sun = bpy.data.lights.new("sun", "SUN")
    sun.energy = max(s["sun_irradiance"])
    sun.color = [c / sun.energy for c in s["sun_irradiance"]]
    sun.angle = 0.0
    obj = add_object("sun", sun)
    # A sun shines along its local -Z: point local +Z toward the light.
    toward_light = Vector(y_up_to_z_up(s["sun_direction"])).normalized()
    obj.rotation_mode = "QUATERNION"
    obj.rotation_quaternion = toward_light.to_track_quat("Z", "Y")


def add_camera(cam):
    """Perspective camera with a vertical field of view, looking from eye to target."""
    eye, target, up = (Vector(y_up_to_z_up(cam[k])) for k in ("eye", "target", "up"))
    forward = (target - eye).normalized()
    right = forward.cross(up).normalized()
    rotation = Matrix((right, right.cross(forward), -forward)).transposed()  # columns: x, y, z
    data = bpy.data.cameras.new("camera")
    data.sensor_fit = "VERTICAL"
    data.angle_y = math.radians(cam["fov"])
    obj = add_object("camera", data)
    obj.matrix_world = Matrix.Translation(eye) @ rotation.to_4x4()
    bpy.context.scene.camera = obj


def configure_cycles(cam, max_depth, spp):
    """Render settings that match fiberlab's estimator: no adaptive sampling, denoising or clamping."""
    scene = bpy.context.scene
    render = scene.render
    render.engine = "CYCLES"
    render.resolution_x, render.resolution_y = cam["width"], cam["height"]
    render.resolution_percentage = 100
    render.threads_mode = "FIXED"
    render.threads = os.cpu_count()
    render.use_persistent_data = True
    render.image_settings.file_format = "OPEN_EXR"
    render.image_settings.color_depth = "32"
    scene.view_settings.view_transform = "Standard"
    c = scene.cycles
    c.device = "CPU"
    c.samples = spp
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.seed = 0
    c.use_animated_seed = False
    # Cycles counts bounces after the first hit: bounces = scattering events - 1.
    bounces = max_depth - 1
    c.max_bounces = c.diffuse_bounces = c.glossy_bounces = bounces
    c.transmission_bounces = c.transparent_max_bounces = bounces
    c.sample_clamp_direct = c.sample_clamp_indirect = 0.0
    c.blur_glossy = 0.0
    c.caustics_reflective = c.caustics_refractive = True
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0
    # Linear 3D curves: round tubes with linear interpolation between the control points, the
    # same polyline as fiberlab's mitered cylinders ("THICK" would be Catmull-Rom through them).
    scene.cycles_curves.shape = "THICK_LINEAR"


def build_scene(scene_toml, hair_path, spp, curves_basis="linear"):
    """Build the whole Blender scene from the TOML and the .hair file."""
    s = load_scene(scene_toml)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    add_hair(hair_path, s["hair"], curves_basis)
    head = uv_sphere_mesh("head", y_up_to_z_up(s["sphere_center"]), s["sphere_radius"],
                          SPHERE_SEGMENTS, SPHERE_RINGS)
    head.materials.append(diffuse_material(s["skin_albedo"]))
    add_object("head", head)
    add_lights(s)
    add_camera(s["camera"])
    configure_cycles(s["camera"], s["max_depth"], spp)


def timed_render():
    """One Cycles render; returns its wall time in seconds."""
    start = time.perf_counter()
    bpy.ops.render.render(write_still=False)
    return time.perf_counter() - start


def main():
    """Build, render twice (first, persistent), write the image and the timings."""
    scene_toml, hair_path, spp, prefix = sys.argv[1:5]
    options, result_path = sys.argv[5:-1], sys.argv[-1]
    curves_basis = options[0] if options else "linear"
    extra_spp = [int(n) for n in options[1].split(",") if n] if len(options) > 1 else []
    start = time.perf_counter()
    build_scene(scene_toml, hair_path, int(spp), curves_basis)
    load = time.perf_counter() - start
    first = timed_render()
    persistent = timed_render()
    bpy.data.images["Render Result"].save_render(filepath=f"{prefix}.exr")
    extra = []
    for n in extra_spp:
        # With persistent data Cycles keeps the synced sample count: a new `scene.cycles.samples`
        # alone does not take (the 4-spp render came out as the 16-spp one). The view layer's
        # sample override is read at every render.
        bpy.context.scene.cycles.samples = n
        bpy.context.view_layer.samples = n
        seconds = timed_render()
        bpy.data.images["Render Result"].save_render(filepath=f"{prefix}_{n}spp.exr")
        extra.append({"spp": n, "render_s": seconds, "exr": f"{prefix}_{n}spp.exr"})
    renders = {"first": first, "persistent": persistent}
    result = {"load_s": load, "renders_s": renders, "used": min(renders, key=renders.get), "extra": extra,
              "exr": f"{prefix}.exr", "version": f"bpy {bpy.app.version_string} cycles",
              "threads": bpy.context.scene.render.threads}
    with open(result_path, "w") as f:
        json.dump(result, f, indent=1)


if __name__ == "__main__":
    main()
