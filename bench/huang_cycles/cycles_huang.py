"""Render the cases of cases.py with Blender Cycles' Principled Hair BSDF, model 'HUANG', on the CPU
through PyPI `bpy` (4.2), one EXR per seed.

usage: cycles_huang.py OUT_DIR SPP SEEDS CASE_INDEX...

Writes OUT_DIR/<slug>_cycles_s<seed>.exr (linear RGBA, the film transparent: alpha is the fiber's
coverage). How fiberlab's parameters map onto Blender's (checked against Cycles' source,
`bsdf_principled_hair_huang.h` and `svm/closure.h`, and in bpy 4.2):

  roughness   Blender's Roughness is the GGX α itself (clamped to [0.001, 1]): same number.
  sigma_a     parametrization ABSORPTION, Absorption Coefficient = fiberlab's sigma_a: Cycles
              multiplies it by chord lengths in units of the major semi-axis (its ellipse is
              (sin γ, b cos γ) with major semi-axis 1), as fiberlab does. Blender's melanin
              mode (-ln(1 - m) slider, its own eu/pheo table) is not used.
  aspect      Aspect Ratio = fiberlab's aspect (minor/major, < 1); major axis along the curve
              normal (cases.py says which way that is for each fiber).
  tilt        Offset = +alpha in radians: Cycles negates it internally and tilts the
              mesonormal toward the root for Offset > 0, as fiberlab's alpha > 0.
  eta         IOR = eta.
  multipliers Reflection, Transmission, Secondary Reflection ("R/TT/TRT lobe") = the case's
              lobes (1 unless said; Cycles gates TRRT+ with TRT, see cases.py's LOBES).
  random      Random Roughness = Random Color = 0 (every strand the same).
  depth       Cycles counts bounces after the first hit: bounces = max_depth - 1.
  film        box filter of one pixel, no adaptive sampling, denoising, clamping or
              Filter Glossy (which would raise Huang's roughness on later bounces).
  curves      Blender 4.2 renders curves as Catmull-Rom tubes ("THICK"); every strand here is
              a straight two-point polyline, which Catmull-Rom leaves straight, with the
              same radius at both ends.
  light       SUN of angle 0 (a delta light), strength = irradiance (W/m²), pointing its local
              +Z toward the light; the world is black, so nothing else lights the fibers.
"""

import math
import os
import sys
from pathlib import Path

import bpy
import numpy as np
from mathutils import Matrix, Vector

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "peers"))
from scene import y_up_to_z_up  # noqa: E402  (bench/peers' axis convention)

from cases import EYE, FOV, IRRADIANCE, SIZE, cases, slug  # noqa: E402


def node_input(node, name):
    """The input socket called `name` (by name, as in the UI)."""
    return next(socket for socket in node.inputs if socket.name == name)


def huang_material(c):
    """Principled Hair BSDF, model HUANG, with fiberlab's parameters mapped (module docs)."""
    material = bpy.data.materials.new("hair")
    material.use_nodes = True
    nodes = material.node_tree.nodes
    nodes.clear()
    bsdf = nodes.new("ShaderNodeBsdfHairPrincipled")
    bsdf.model = "HUANG"
    bsdf.parametrization = "ABSORPTION"
    node_input(bsdf, "Absorption Coefficient").default_value = c["sigma_a"]
    node_input(bsdf, "Roughness").default_value = c["roughness"]
    node_input(bsdf, "Aspect Ratio").default_value = c["aspect"]
    node_input(bsdf, "IOR").default_value = c["eta"]
    node_input(bsdf, "Offset").default_value = math.radians(c["tilt"])
    lobes = ("Reflection", "Transmission", "Secondary Reflection")
    for lobe, multiplier in zip(lobes, c["cycles_lobes"]):
        node_input(bsdf, lobe).default_value = multiplier
    node_input(bsdf, "Random Color").default_value = 0.0
    node_input(bsdf, "Random Roughness").default_value = 0.0
    output = nodes.new("ShaderNodeOutputMaterial")
    material.node_tree.links.new(bsdf.outputs[0], output.inputs["Surface"])
    return material


def add_object(name, data):
    obj = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def add_strands(c):
    """The strands as a Curves object (root first), per-point radius."""
    counts = [len(p) for p in c["polylines"]]
    points = np.concatenate(c["polylines"])
    radii = np.concatenate([np.full(n, r) for n, r in zip(counts, c["radii"])])
    curves = bpy.data.hair_curves.new("hair")
    curves.add_curves(counts)
    curves.position_data.foreach_set("vector", y_up_to_z_up(points).astype(np.float32).ravel())
    radius = curves.attributes.get("radius") or curves.attributes.new("radius", "FLOAT", "POINT")
    radius.data.foreach_set("value", radii.astype(np.float32))
    curves.materials.append(huang_material(c))
    add_object("hair", curves)
    return curves


def add_light(c):
    """A black world and a sun of angle 0 shining from `c['light']`."""
    world = bpy.data.worlds.new("world")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0, 0, 0, 1)
    bpy.context.scene.world = world
    sun = bpy.data.lights.new("sun", "SUN")
    sun.energy = max(IRRADIANCE)
    sun.color = [e / sun.energy for e in IRRADIANCE]
    sun.angle = 0.0
    obj = add_object("sun", sun)
    toward_light = Vector(y_up_to_z_up(c["light"])).normalized()
    obj.rotation_mode = "QUATERNION"
    obj.rotation_quaternion = toward_light.to_track_quat("Z", "Y")


def add_camera():
    """Pinhole camera at EYE looking at the origin, Y (fiberlab) up, vertical field of view."""
    eye = Vector(y_up_to_z_up(EYE))
    target = Vector((0.0, 0.0, 0.0))
    up = Vector(y_up_to_z_up([0.0, 1.0, 0.0]))
    forward = (target - eye).normalized()
    right = forward.cross(up).normalized()
    rotation = Matrix((right, right.cross(forward), -forward)).transposed()
    data = bpy.data.cameras.new("camera")
    data.sensor_fit = "VERTICAL"
    data.angle_y = math.radians(FOV)
    obj = add_object("camera", data)
    obj.matrix_world = Matrix.Translation(eye) @ rotation.to_4x4()
    bpy.context.scene.camera = obj


def configure(c, spp):
    scene = bpy.context.scene
    render = scene.render
    render.engine = "CYCLES"
    render.resolution_x = render.resolution_y = SIZE
    render.resolution_percentage = 100
    render.film_transparent = True
    render.threads_mode = "FIXED"
    render.threads = int(os.environ.get("HUANG_CYCLES_THREADS", os.cpu_count()))
    render.image_settings.file_format = "OPEN_EXR"
    render.image_settings.color_mode = "RGBA"
    render.image_settings.color_depth = "32"
    scene.view_settings.view_transform = "Standard"
    cy = scene.cycles
    cy.device = "CPU"
    cy.samples = spp
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    cy.use_animated_seed = False
    bounces = c["max_depth"] - 1
    cy.max_bounces = cy.diffuse_bounces = cy.glossy_bounces = bounces
    cy.transmission_bounces = cy.transparent_max_bounces = bounces
    cy.sample_clamp_direct = cy.sample_clamp_indirect = 0.0
    cy.blur_glossy = 0.0
    cy.caustics_reflective = cy.caustics_refractive = True
    cy.pixel_filter_type = "BOX"
    cy.filter_width = 1.0
    scene.cycles_curves.shape = "THICK"


def main():
    out, spp, seeds = Path(sys.argv[1]), int(sys.argv[2]), [int(s) for s in sys.argv[3].split(",")]
    all_cases = cases()
    for index in sys.argv[4:]:
        c = all_cases[int(index)]
        bpy.ops.wm.read_factory_settings(use_empty=True)
        add_strands(c)
        add_light(c)
        add_camera()
        configure(c, spp)
        for seed in seeds:
            bpy.context.scene.cycles.seed = seed
            path = out / f"{slug(c['name'])}_cycles_s{seed}.exr"
            bpy.context.scene.render.filepath = str(path)
            bpy.ops.render.render(write_still=True)
            print(f"cycles: wrote {path}", flush=True)


if __name__ == "__main__":
    main()
