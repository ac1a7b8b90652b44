#!/usr/bin/env python3
"""Writes a slab of parallel fibers (random positions, no overlaps, packing fraction PHI) as a
pbrt-v4 curve file and the fiberlab scene that lights it with a distant light at inclination
THETA to the fibers, seen from above. Units: millimetres; fiber radius 0.04 (40 µm).

usage: make_slab.py OUT_DIR PHI THETA_DEG EUMELANIN [WIDTH_PX]
"""
import math, os, random, sys

out, phi, theta, eu = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
px = int(sys.argv[5]) if len(sys.argv) > 5 else 64
r, length, width, depth = 0.04, 8.0, 6.0, 4.0
rng = random.Random(1)
target = int(phi * width * depth / (math.pi * r * r))
cell = 2 * r
grid = {}
points = []
tries = 0
while len(points) < target and tries < 200 * target:
    tries += 1
    y, z = -depth * rng.random(), width * (rng.random() - 0.5)
    gy, gz = int(y // cell), int(z // cell)
    ok = True
    for dy in (-1, 0, 1):
        for dz in (-1, 0, 1):
            for (qy, qz) in grid.get((gy + dy, gz + dz), ()):
                if (qy - y) ** 2 + (qz - z) ** 2 < (2 * r) ** 2:
                    ok = False
    if ok:
        grid.setdefault((gy, gz), []).append((y, z))
        points.append((y, z))
os.makedirs(out, exist_ok=True)
with open(os.path.join(out, "slab.pbrt"), "w") as f:
    for (y, z) in points:
        xs = [-length / 2 + length * k / 3 for k in range(4)]
        pts = " ".join(f"{x:.6f} {y:.6f} {z:.6f}" for x in xs)
        f.write(f'Shape "curve" "point3 P" [ {pts} ] "string type" "cylinder" "float width" [ {2 * r} ]\n')
t = math.radians(theta)
# Light in the plane of the fibers' axis (x) and the slab normal (y); camera above, in the
# plane normal to the fibers, 30° off the normal, far away (a narrow view of the centre).
dist = 40.0
eye = (0.0, dist * math.cos(math.radians(30)), dist * math.sin(math.radians(30)))
fov = 2 * math.degrees(math.atan(1.0 / dist))
with open(os.path.join(out, "slab.toml"), "w") as f:
    f.write(f"""# Slab of {len(points)} parallel fibers, packing fraction {len(points) * math.pi * r * r / (width * depth):.3f},
# distant light at θ = {theta}° to the fibers (bench/dual_scattering/make_slab.py).
[camera]
eye = [{eye[0]}, {eye[1]:.6f}, {eye[2]:.6f}]
target = [0.0, 0.0, 0.0]
up = [1.0, 0.0, 0.0]
fov = {fov:.6f}
width = {px}
height = {px}

[render]
spp = 16
max_depth = 64
seed = 0

[materials.hair]
model = "chiang"
params = {{ eumelanin = {eu}, pheomelanin = 0.0, beta_m = 0.3, beta_n = 0.3 }}

[[hair]]
material = "hair"
file = "slab.pbrt"

[[light]]
type = "distant"
direction = [{math.sin(t):.9f}, {math.cos(t):.9f}, 0.0]
irradiance = [1.0, 1.0, 1.0]
""")
print(len(points), "fibers")
