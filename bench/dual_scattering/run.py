#!/usr/bin/env python3
"""Settles the dual-scattering constants against the path tracer on slabs of parallel fibers
(make_slab.py): for each light inclination and hair colour, a path-traced reference (depth 64)
and dual scattering with each alternative; prints the table of result.md.

usage: run.py [--spp-ref 256] [--spp 16] [--px 64] [--work DIR]
Needs `cargo build --release -p fiberlab-cli` and `cargo build --release -p fiberlab-io --example exr_stats`.
"""
import argparse, itertools, json, os, subprocess, sys, time

here = os.path.dirname(os.path.abspath(__file__))
root = os.path.abspath(os.path.join(here, "..", ".."))
fiberlab = os.path.join(root, "target", "release", "fiberlab")
stats = os.path.join(root, "target", "release", "examples", "exr_stats")
ap = argparse.ArgumentParser()
ap.add_argument("--spp-ref", type=int, default=256)
ap.add_argument("--spp", type=int, default=16)
ap.add_argument("--px", type=int, default=64)
ap.add_argument("--phi", type=float, default=0.2)
ap.add_argument("--work", default="/tmp/dual_bench")
ap.add_argument("--thetas", default="0,30,60")
ap.add_argument("--colours", default="blond:0.15,brown:0.8")
ap.add_argument("--fit", action="store_true", help="also sweep d_f, d_b (with pi off and on)")
ap.add_argument("--only-fit", action="store_true", help="the sweep of d_f, d_b alone")
a = ap.parse_args()


def render(scene, out, extra):
    t = time.time()
    r = subprocess.run([fiberlab, "render", scene, "--quiet", "--out", out] + extra, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"render failed: {r.stderr}")
    line = [l for l in r.stderr.splitlines() if "render " in l and "scene " in l][-1]
    render_s = float(line.split("render ")[1].split(" s")[0])
    return render_s


def compare(img, ref):
    return json.loads(subprocess.run([stats, img, ref], capture_output=True, text=True, check=True).stdout)


variants = {
    "default": [],
    "global=forward-mean": ["--dual", "global=forward-mean"],
    "k_back=1": ["--dual", "k_back=1"],
    "pi=on": ["--dual", "pi=on"],
    "spread=literal": ["--dual", "spread=literal"],
    "count=grid": ["--fiber-count", "grid"],
    "global=forward-mean,pi=on": ["--dual", "global=forward-mean", "--dual", "pi=on"],
}
if a.only_fit:
    variants = {}
if a.fit or a.only_fit:
    for pi, df, db in itertools.product(["off", "on"], [0.5, 0.6, 0.7, 0.85, 1.0], [0.35, 0.5, 0.7, 1.0, 1.3]):
        variants[f"pi={pi},d_f={df},d_b={db}"] = ["--dual", f"pi={pi}", "--dual", f"d_f={df}", "--dual", f"d_b={db}"]
rows = []
for colour, theta in itertools.product(a.colours.split(","), a.thetas.split(",")):
    name, eu = colour.split(":")
    d = os.path.join(a.work, f"{name}_{theta}")
    subprocess.run([sys.executable, os.path.join(here, "make_slab.py"), d, str(a.phi), theta, eu, str(a.px)],
                   check=True, capture_output=True)
    scene = os.path.join(d, "slab.toml")
    ref = os.path.join(d, "reference")
    if not os.path.exists(ref + ".exr"):
        render(scene, ref, ["--spp", str(a.spp_ref), "--max-depth", "64", "--seed", "1"])
    t_path = render(scene, os.path.join(d, "path"), ["--spp", str(a.spp), "--max-depth", "64"])
    s = compare(os.path.join(d, "path.exr"), ref + ".exr")
    rows.append((name, theta, "path tracing (depth 64)", s, t_path))
    t1 = render(scene, os.path.join(d, "single"), ["--spp", str(a.spp), "--max-depth", "1"])
    rows.append((name, theta, "single scattering (depth 1)", compare(os.path.join(d, "single.exr"), ref + ".exr"), t1))
    for v, extra in variants.items():
        out = os.path.join(d, "dual_" + v.replace("=", "_").replace(",", "_"))
        t = render(scene, out, ["--spp", str(a.spp), "--integrator", "dual-scattering"] + extra)
        rows.append((name, theta, "dual " + v, compare(out + ".exr", ref + ".exr"), t))
    for r in rows[-(2 + len(variants)):]:
        print(f"{r[0]:6} θ={r[1]:>2}°  {r[2]:32} mean {r[3]['mean_rel_diff']:+.3f}  block rel RMSE {r[3]['block_rel_rmse']:.3f}  render {r[4]:.2f} s", flush=True)
with open(os.path.join(a.work, "rows.json"), "w") as f:
    json.dump(rows, f)
# Summary over configurations: mean |mean error| and mean block RMSE per method.
methods = {}
for r in rows:
    methods.setdefault(r[2], []).append(r)
print("\n| method | mean abs. error of image mean | mean block rel. RMSE | render time / path |")
print("|---|---|---|---|")
path_t = {(r[0], r[1]): r[4] for r in rows if r[2].startswith("path")}
for m, rs in methods.items():
    e = sum(abs(r[3]["mean_rel_diff"]) for r in rs) / len(rs)
    b = sum(r[3]["block_rel_rmse"] for r in rs) / len(rs)
    tr = sum(r[4] / path_t[(r[0], r[1])] for r in rs) / len(rs)
    print(f"| {m} | {e:.3f} | {b:.3f} | {tr:.2f} |")
