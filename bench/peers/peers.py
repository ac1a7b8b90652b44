"""Peer comparison: the same hair scene in fiberlab, Mitsuba 3 (scalar_rgb, llvm_ad_rgb) and Blender
Cycles (CPU, PyPI bpy); timings, ratios, equal-time error, block-mean agreement, images and a
Chiang BSDF microbenchmark. Run it through bench/peers/run (which sets up the venv and libLLVM);
never part of `cargo test` or CI.

Every renderer runs in its own process (peer_mitsuba.py per variant, peer_cycles.py,
bsdf_bench.py); a peer that fails is reported as "not available: <reason>" with its log in
OUT/logs/. Environment: SPP (16), REF_SPP (512), STRANDS (10000), PEERS_OUT (bench/peers/out),
SKIP (comma list of mitsuba_llvm, mitsuba_scalar, mitsuba_cuda, cycles), CURVES (linear | bspline: the
strands' 16 points as polylines or as uniform cubic B-spline control points), WIDTHS (peer: constant
diameter 0.004 | generator: the generator's diameters, 0.002 at the root tapering to 0.001; the
thin-strand variant, e.g. with STRANDS=50000), FIBERLAB_DEVICE (cpu, gpu or auto: where fiberlab
renders). mitsuba_cuda (`cuda_ad_rgb`) runs only where a CUDA driver is found (`nvidia-smi` or
libcuda); bench/gpu/run uses it.

Equal error: every renderer also renders at SPP/4; with the SPP render that gives two points of
its RMSE-versus-time curve, fitted by RMSE = k t^(-1/2) (least squares in log-log with the slope
fixed at -1/2, as for an unbiased estimator). The time to reach a common RMSE e (fiberlab's at
SPP) is then (k / e)^2, and `ratio equal-error` is fiberlab's time over each peer's.

How fiberlab's scene conventions map onto the peers (the peer modules repeat each one where it is
applied):

  depth      fiberlab max_depth = scattering events (12). Mitsuba `path` max_depth counts vertices
             including the camera's: events + 1 (13). Cycles counts bounces after the first hit:
             events - 1 (11) for max/diffuse/glossy/transmission/transparent bounces.
  tilt       fiberlab alpha > 0 puts the R lobe toward the root (physical; checked with fiberlab's
             explicit-geometry goniophotometer). Mitsuba 3 (pbrt-v4: tilts the camera-side
             direction, lobes centred at theta_i + theta_o = +2 alpha along the root->tip tangent)
             needs scale_tilt = -alpha; Cycles (tilts the light-side direction, centred at -2 alpha)
             takes Offset = +alpha (radians in the socket). Curves are written root first in both.
  melanin    fiberlab and Mitsuba: d'Eon's sigma_a = eu (0.419, 0.697, 1.37) + pheo (0.187, 0.4,
             1.05) per unit radius. Cycles' melanin mode has another table ((0.506, 0.841, 1.653),
             (0.343, 0.733, 1.924)) behind a -ln(1 - m) slider mapping, so Cycles gets the
             absorption-coefficient parametrization with fiberlab's sigma_a. Cycles Coat = 0 (no
             extra R-lobe roughness), Random Color = Random Roughness = 0.
  ior        Mitsuba eta = int_ior / ext_ior with ext_ior defaulting to air (1.000277): ext_ior = 1.
  curves     CURVES=bspline: fiberlab `[[hair]] basis = "bspline"`, segments_per_curve = 8 (the
             B-spline subdivided into polylines); Mitsuba `bsplinecurve` (Embree's round B-spline
             curves, intersected as cubics); Cycles renders curve control points as Catmull-Rom
             or linear tubes whatever their type, so it gets the B-spline evaluated at the same 8
             steps per span as linear curves (peer_cycles.bspline_polylines).
  geometry   fiberlab tubes are polylines of mitered cylinders; Mitsuba `linearcurve` (Embree round
             linear curves) and Cycles "Linear 3D Curves" (THICK_LINEAR) are the same polylines
             through the same 16 points, with the same per-point radius. Cycles' default "3D
             Curves" (THICK) would interpolate Catmull-Rom through them instead. Cycles has no
             analytic sphere for the head: a smooth-shaded 512×256 UV sphere (chord sag 8e-5).
             Blender is Z up, fiberlab and Mitsuba Y up: (x, y, z) -> (x, -z, y).
  lights     constant environment = radiance in all three (Cycles: world background colour,
             strength 1). fiberlab's distant light `irradiance` = Mitsuba `directional`
             irradiance (its `direction` is the travel direction: minus fiberlab's, which points
             to the light) = Cycles SUN of angle 0, strength = max component in W/m^2, colour =
             irradiance / strength.
  film       box pixel filter of one pixel in all (Mitsuba rfilter box; Cycles BOX, width 1).
             Cycles: adaptive sampling off, denoising off, clamping 0, filter glossy 0, caustics
             on, light threshold default.
  threads    all cores for every renderer (os.cpu_count()).
  timing     fiberlab: the `scene` (load + BVH) and `render` seconds it prints. Mitsuba: load_dict
             (parse + BVH), then two renders in one process, cold (includes the LLVM variant's
             kernel compilation) and warm; the ratio uses the faster, which favours Mitsuba. Cycles:
             load = building the Blender data (its sync and BVH build happen inside the first
             render), then a second render with persistent data; the ratio uses the faster.
"""

import json
import math
import os
import re
import subprocess
import sys
import time
from pathlib import Path

from scene import load_scene

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
# bench/peers/run points FIBERLAB at a copy of the binary it has just built.
FIBERLAB = Path(os.environ.get("FIBERLAB", REPO / "target" / "release" / "fiberlab"))
SCENE = HERE / "scene.toml"
PEERS = ("mitsuba_llvm", "mitsuba_scalar", "mitsuba_cuda", "cycles")
MITSUBA_VARIANTS = {"mitsuba_llvm": "llvm_ad_rgb", "mitsuba_scalar": "scalar_rgb", "mitsuba_cuda": "cuda_ad_rgb"}
# fiberlab renders on this device (`fiberlab render --device`): cpu, gpu or auto.
FIBERLAB_DEVICE = os.environ.get("FIBERLAB_DEVICE", "cpu")
REFERENCE_SEED = 1000
PEER_TIMEOUT_S = 1800
# CURVES: fiberlab's [[hair]] keys and Mitsuba's shape type per variant.
CURVES = {"linear": ("", "linearcurve"),
          "bspline": ('basis = "bspline"\nsegments_per_curve = 8\n', "bsplinecurve")}
# WIDTHS: the generator's diameter arguments per variant (generator: its defaults).
WIDTHS = {"peer": ("--root-diameter", 0.004, "--tip-ratio", 1), "generator": ()}
RENDER_LINE = re.compile(r"scene ([0-9.]+) s, render ([0-9.]+) s")


def config():
    """Options from the environment, with paths made absolute."""
    skip = {p.strip() for p in os.environ.get("SKIP", "").split(",") if p.strip()}
    unknown = skip - set(PEERS)
    if unknown:
        sys.exit(f"SKIP: unknown peers {sorted(unknown)} (known: {', '.join(PEERS)})")
    curves = os.environ.get("CURVES", "linear")
    if curves not in CURVES:
        sys.exit(f"CURVES={curves}: must be one of {', '.join(CURVES)}")
    widths = os.environ.get("WIDTHS", "peer")
    if widths not in WIDTHS:
        sys.exit(f"WIDTHS={widths}: must be one of {', '.join(WIDTHS)}")
    out = Path(os.environ.get("PEERS_OUT", HERE / "out")).resolve()
    spp = int(os.environ.get("SPP", 16))
    return {"spp": spp, "ref_spp": int(os.environ.get("REF_SPP", 512)),
            "strands": int(os.environ.get("STRANDS", 10000)), "skip": skip, "out": out, "curves": curves,
            "widths": widths,
            "extra_spp": max(1, spp // 4)}


def fiberlab(*args):
    """Run fiberlab and return its captured output; any failure ends the benchmark."""
    cmd = [str(a) for a in (FIBERLAB, *args)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        sys.exit(f"failed: {' '.join(cmd)}\n{proc.stderr}")
    return proc


def run_logged(cmd, log, timeout):
    """Run a command in bench/peers with its output in `log`; returns the exit code."""
    with open(log, "w") as f:
        return subprocess.run([str(c) for c in cmd], stdout=f, stderr=subprocess.STDOUT, timeout=timeout,
                              cwd=HERE, env={**os.environ, "PYTHONPATH": str(HERE)}).returncode


def generate_hair(cfg):
    """The strands of the scene: STRANDS strands of 16 points, of constant radius 0.002
    (WIDTHS=peer) or of the generator's own widths (WIDTHS=generator: diameter 0.002 at the root
    tapering to 0.001 at the tip)."""
    path = cfg["out"] / "hair.hair"
    widths = WIDTHS[cfg["widths"]]
    fiberlab("hair", "generate", "--strands", cfg["strands"], "--segments", 15, *widths, "--out", path)
    return path


def scene_for(cfg):
    """scene.toml, or for CURVES=bspline a copy in OUT whose [[hair]] reads the points as
    B-spline control points (the hair file itself comes with --hair)."""
    keys = CURVES[cfg["curves"]][0]
    if not keys:
        return SCENE
    text = SCENE.read_text()
    entry = '[[hair]]\nmaterial = "hair"\nfile = "hair.hair"\n'
    if entry not in text:
        sys.exit(f"{SCENE}: expected the [[hair]] entry {entry!r}")
    path = cfg["out"] / f"scene_{cfg['curves']}.toml"
    path.write_text(text.replace(entry, entry + keys))
    return path


def render_fiberlab(hair, spp, seed, prefix, scene=SCENE):
    """Render with fiberlab; returns load (scene) and render seconds and the EXR path."""
    proc = fiberlab("render", scene, "--hair", hair, "--spp", spp, "--seed", seed,
                    "--out", prefix, "--quiet", "--device", FIBERLAB_DEVICE)
    match = RENDER_LINE.search(proc.stderr)
    if not match:
        raise RuntimeError(f"no timing line in fiberlab's output:\n{proc.stderr}")
    return {"load_s": float(match[1]), "render_s": float(match[2]), "exr": f"{prefix}.exr"}


def has_cuda():
    """True when a CUDA driver is present (for Mitsuba's cuda_ad_rgb)."""
    if subprocess.run(["sh", "-c", "command -v nvidia-smi"], capture_output=True).returncode == 0:
        return True
    libs = subprocess.run(["sh", "-c", "ldconfig -p 2>/dev/null"], capture_output=True, text=True).stdout
    return "libcuda.so" in libs


def failure_reason(log):
    """The last non-empty line of a failed peer's log (usually the exception)."""
    lines = [line.strip() for line in Path(log).read_text(errors="replace").splitlines() if line.strip()]
    return (lines[-1] if lines else "no output")[:300] + f" (log: {log})"


def run_python(script, args, name, out):
    """Run one of the peer scripts in its own process; returns its JSON result or {'error': why}."""
    result = out / f"{name}.json"
    result.unlink(missing_ok=True)
    log = out / "logs" / f"{name}.log"
    try:
        code = run_logged([sys.executable, HERE / script, *args, result], log, PEER_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        return {"error": f"timed out after {PEER_TIMEOUT_S} s (log: {log})"}
    if code != 0 or not result.exists():
        return {"error": failure_reason(log)}
    return json.loads(result.read_text())


def run_peer(name, hair, cfg):
    """Render the scene with one peer; adds `render_s`, the time the ratio uses."""
    prefix = cfg["out"] / name
    extra = str(cfg["extra_spp"])
    if name == "cycles":
        res = run_python("peer_cycles.py", [SCENE, hair, cfg["spp"], prefix, cfg["curves"], extra], name,
                         cfg["out"])
    else:
        args = [MITSUBA_VARIANTS[name], SCENE, hair, cfg["spp"], prefix, CURVES[cfg["curves"]][1], extra]
        res = run_python("peer_mitsuba.py", args, name, cfg["out"])
    if "error" not in res:
        res["render_s"] = res["renders_s"][res["used"]]
    return res


def compare(reference, test, figure=None):
    """`fiberlab compare --json` metrics (rmse, relmse, ssim, flip), optionally writing a figure."""
    extra = ["--out", figure] if figure else []
    return json.loads(fiberlab("compare", reference, test, "--json", *extra).stdout)


def equal_time_renders(hair, cfg, fl16, peers):
    """For each rendered peer, fiberlab at spp_eq = max(1, round(SPP * T_peer / T_fiberlab)) and its
    metrics against the reference; renders with the same spp are shared."""
    cache = {cfg["spp"]: fl16["exr"]}
    for res in peers.values():
        if "error" in res or "skipped" in res:
            continue
        spp_eq = max(1, round(cfg["spp"] * res["render_s"] / fl16["render_s"]))
        if spp_eq not in cache:
            print(f"  fiberlab at {spp_eq} spp (equal time)", flush=True)
            cache[spp_eq] = render_fiberlab(hair, spp_eq, 0, cfg["out"] / f"fiberlab_{spp_eq}spp",
                                            cfg["scene"])["exr"]
        res["equal_time"] = {"spp": spp_eq, **compare(cfg["out"] / "reference.exr", cache[spp_eq])}


def error_curve(res, reference):
    """The renderer's (spp, seconds, RMSE) points (its SPP render and the extra ones) and k of
    the fit RMSE = k t^(-1/2) (log k = mean of log RMSE + log t / 2); adds them to `res`."""
    points = [(res["spp"], res["render_s"], res["rmse"])]
    for e in res.get("extra", []):
        points.append((e["spp"], e["render_s"], compare(reference, e["exr"])["rmse"]))
    points.sort()
    # An unbiased renderer's error falls with its sample count: a render with more samples and no
    # lower RMSE means the sample count did not take (as Cycles' persistent data once did), and the
    # curve is refused rather than fitted.
    if any(b[2] >= a[2] for a, b in zip(points, points[1:])):
        print(f"warning: RMSE does not fall with spp ({points}): no equal-error figure", file=sys.stderr)
        res["error_curve"] = None
        return
    k = math.exp(sum(math.log(rmse) + 0.5 * math.log(t) for _, t, rmse in points) / len(points))
    res["error_curve"] = {"points": points, "k": k}


def time_to_error(res, rmse):
    """Seconds the fitted curve needs to reach `rmse`, or None."""
    curve = res.get("error_curve")
    return (curve["k"] / rmse) ** 2 if curve else None


def fiberlab_bsdf_bench(params):
    """eval and sample ns/call of fiberlab's chiang model with the scene's parameters (1 thread)."""
    args = [arg for key, value in params.items() for arg in ("--param", f"{key}={value}")]
    output = fiberlab("bench", "--model", "chiang", *args).stdout
    row = next(line for line in output.splitlines() if line.startswith("chiang"))
    fields = row.split()
    return {"eval_ns": float(fields[-4]), "sample_ns": float(fields[-2]), "table_row": row}


def bsdf_benchmarks(cfg, params):
    """The microbenchmark: fiberlab's own, Mitsuba scalar (Python loop) and llvm (vectorized)."""
    out = {"fiberlab": fiberlab_bsdf_bench(params)}
    for name, variant in (("mitsuba_scalar", "scalar_rgb"), ("mitsuba_llvm", "llvm_ad_rgb")):
        out[name] = run_python("bsdf_bench.py", [variant, SCENE], f"bsdf_{name}", cfg["out"])
    return out


def image_outputs(cfg, s, fl16, peers):
    """Block-mean agreement, PNGs, compare figures and side_by_side.png; needs Mitsuba's Bitmap."""
    try:
        import images
    except ImportError as e:
        return f"not available: {e}"
    out = cfg["out"]
    reference = images.read_exr(out / "reference.exr")
    mask = images.non_sky_blocks(reference, s["env_radiance"])
    rows = {"fiberlab": fl16, **peers}
    pictures = []
    for name, res in rows.items():
        if "exr" not in res:
            pictures.append(None)
            continue
        image = images.read_exr(res["exr"])
        images.write_png(out / f"{name}.png", image)
        res["block_ratio"], res["block_rel_rms"] = images.block_agreement(reference, image, mask)
        if name != "fiberlab":
            compare(out / "reference.exr", res["exr"], out / f"compare_{name}")
        pictures.append(image)
    labels = {"mitsuba_llvm": "Mitsuba llvm_ad_rgb", "mitsuba_scalar": "Mitsuba scalar_rgb",
              "mitsuba_cuda": "Mitsuba cuda_ad_rgb", "cycles": "Cycles"}
    images.side_by_side(out / "side_by_side.png", pictures, [labels.get(n, n) for n in rows], reference,
                        reference.shape, FIBERLAB, cfg["spp"], cfg["ref_spp"])
    return (f"{out / 'side_by_side.png'}: row 1 {' | '.join(rows)} at {cfg['spp']} spp; row 2 "
            f"|image - fiberlab {cfg['ref_spp']}-spp reference| x {images.DIFF_SCALE:g} (same scale); "
            f"grey = not available. {int(mask.sum())} non-sky {images.BLOCK}x{images.BLOCK} blocks.")


def load_average():
    """The 1-minute load average: anything else running skews every timing."""
    return f"load average {os.getloadavg()[0]:.2f}"


def fmt(value, spec):
    """Format a number, or n/a when missing."""
    return "n/a" if value is None else format(value, spec)


def ratio_of(fl16, res):
    """fiberlab render time / peer render time, or None."""
    return fl16["render_s"] / res["render_s"] if "render_s" in res else None


def print_details(fl16, ref, peers, cfg):
    """One line per renderer with every measured time, or why it is missing."""
    print(f"\nfiberlab: scene {fl16['load_s']:.2f} s, render {fl16['render_s']:.2f} s at {cfg['spp']} spp; "
          f"reference {cfg['ref_spp']} spp (seed {REFERENCE_SEED}): render {ref['render_s']:.1f} s")
    for name, res in peers.items():
        if "skipped" in res:
            print(f"{name}: skipped by request (SKIP)")
        elif "error" in res:
            print(f"{name}: not available: {res['error']}")
        else:
            times = ", ".join(f"{k} {v:.2f} s" for k, v in res["renders_s"].items())
            print(f"{name}: {res['version']}, {res['threads']} threads: load {res['load_s']:.2f} s, "
                  f"render {times} (ratio uses {res['used']})")


def print_summary(fl16, peers, cfg):
    """The final table: times, ratio, noise and equal-time error, block-mean ratio."""
    head = (f"{'renderer':<15} {'load s':>7} {'render s':>9} {'fiberlab/peer':>14} "
            f"{'RMSE@' + str(cfg['spp']) + 'spp':>11} {'fiberlab RMSE at equal time':>28}  block-mean ratio r/g/b")
    print("\n" + head + "\n" + "-" * len(head))
    for name, res in {"fiberlab": fl16, **peers}.items():
        if "render_s" not in res:
            state = "skipped by request" if "skipped" in res else "not available"
            print(f"{name:<15} {'n/a':>7} {'n/a':>9} {'n/a':>14} {'n/a':>11} {'n/a':>28}  {state}")
            continue
        eq = res.get("equal_time")
        eq_text = f"{eq['rmse']:.5f} ({eq['spp']} spp)" if eq else "-"
        blocks = "/".join(f"{r:.3f}" for r in res["block_ratio"]) if "block_ratio" in res else "n/a"
        print(f"{name:<15} {res['load_s']:>7.2f} {res['render_s']:>9.2f} {fmt(ratio_of(fl16, res), '.2f'):>14} "
              f"{fmt(res.get('rmse'), '.5f'):>11} {eq_text:>28}  {blocks}")
    print("RMSE against the fiberlab reference; the block-mean ratio (peer/reference, mean of the non-sky "
          "16x16 blocks) shows a systematic mismatch apart from noise.")


def print_bsdf_table(bench):
    """eval and sample ns per call of every implementation, in one table."""
    fl, scalar, llvm = bench["fiberlab"], bench["mitsuba_scalar"], bench["mitsuba_llvm"]
    print(f"\n{'BSDF microbenchmark (chiang, scene parameters)':<58} {'eval ns':>9} {'sample ns':>10}")
    print(f"{'fiberlab bench (Rust, 1 thread)':<58} {fl['eval_ns']:>9.1f} {fl['sample_ns']:>10.1f}")
    if "error" in scalar:
        print(f"mitsuba scalar_rgb: not available: {scalar['error']}")
    else:
        print(f"{'mitsuba scalar_rgb, Python loop, raw':<58} {scalar['eval_ns']:>9.1f} {scalar['sample_ns']:>10.1f}")
        print(f"{'mitsuba scalar_rgb, net of loop + call':<58} {scalar['eval_net_ns']:>9.1f} "
              f"{scalar['sample_net_ns']:>10.1f}   (baseline bsdf.flags() loop {scalar['baseline_ns']:.1f} ns)")
    if "error" in llvm:
        print(f"mitsuba llvm_ad_rgb: not available: {llvm['error']}")
    else:
        label = f"mitsuba llvm_ad_rgb, per lane ({llvm['lanes']} lanes, {llvm['threads']} threads)"
        print(f"{label:<58} {llvm['eval_ns']:>9.1f} {llvm['sample_ns']:>10.1f}")
    if "error" not in scalar:
        verdict = ", ".join(f"{k} {'yes' if fl[k + '_ns'] < scalar[k + '_net_ns'] else 'NO'} "
                            f"({fl[k + '_ns'] / scalar[k + '_net_ns']:.2f}x)" for k in ("eval", "sample"))
        print(f"fiberlab faster per call than mitsuba scalar_rgb (net): {verdict}")


def print_error_curves(fl16, peers):
    """Each renderer's RMSE-versus-time points, the fit and the time to fiberlab's RMSE."""
    target = fl16["rmse"]
    print(f"\nRMSE versus time (fit RMSE = k t^-1/2), time to reach RMSE {target:.5f} (fiberlab's at SPP):")
    for name, res in {"fiberlab": fl16, **peers}.items():
        curve = res.get("error_curve")
        if not curve:
            continue
        pts = ", ".join(f"{n} spp {t:.2f} s {e:.5f}" for n, t, e in curve["points"])
        print(f"  {name:<15} {pts}; k {curve['k']:.5f}; time to RMSE {time_to_error(res, target):.2f} s")


def equal_error_line(fl16, peers):
    """fiberlab's time to reach its own SPP RMSE over each peer's time to reach it."""
    t_fl = time_to_error(fl16, fl16["rmse"])
    parts = []
    for name in PEERS:
        t_peer = time_to_error(peers[name], fl16["rmse"])
        parts.append(f"fiberlab/{name}={fmt(t_fl / t_peer if t_peer else None, '.2f')}")
    return "ratio equal-error " + " ".join(parts) + f" (RMSE {fl16['rmse']:.5f})"


def ratio_line(fl16, peers):
    """The last line of the output: fiberlab render time / peer render time per peer."""
    return "ratio render " + " ".join(
        f"fiberlab/{name}={fmt(ratio_of(fl16, peers[name]), '.2f')}" for name in PEERS)


def main():
    """Render everything, compare, print the tables and write results.json."""
    cfg = config()
    (cfg["out"] / "logs").mkdir(parents=True, exist_ok=True)
    s = load_scene(SCENE)
    spp = cfg["spp"]
    cfg["scene"] = scene = scene_for(cfg)
    print(f"scene {scene} ({cfg['strands']} strands, curves {cfg['curves']}, widths {cfg['widths']}), {spp} spp, reference "
          f"{cfg['ref_spp']} spp, {os.cpu_count()} cores, output {cfg['out']}; {load_average()}", flush=True)
    hair = generate_hair(cfg)
    print(f"fiberlab at {spp} spp", flush=True)
    fl16 = render_fiberlab(hair, spp, 0, cfg["out"] / "fiberlab", scene)
    n = cfg["extra_spp"]
    print(f"fiberlab at {n} spp (RMSE-versus-time curve)", flush=True)
    fl16["extra"] = [{"spp": n, **render_fiberlab(hair, n, 2, cfg["out"] / f"fiberlab_{n}spp_curve", scene)}]
    print(f"fiberlab reference at {cfg['ref_spp']} spp", flush=True)
    ref = render_fiberlab(hair, cfg["ref_spp"], REFERENCE_SEED, cfg["out"] / "reference", scene)
    peers = {}
    for name in PEERS:
        print(f"{name}", flush=True)
        if name in cfg["skip"]:
            peers[name] = {"skipped": True}
        elif name == "mitsuba_cuda" and not has_cuda():
            peers[name] = {"error": "no CUDA driver on this machine (nvidia-smi, libcuda)"}
        else:
            peers[name] = run_peer(name, hair, cfg)
    print("equal-time renders", flush=True)
    equal_time_renders(hair, cfg, fl16, peers)
    for res in (fl16, *peers.values()):
        if "exr" in res:
            res.update(compare(ref["exr"], res["exr"]))
            res["spp"] = spp
            error_curve(res, ref["exr"])
    print("BSDF microbenchmark", flush=True)
    bench = bsdf_benchmarks(cfg, s["hair"])
    figure_note = image_outputs(cfg, s, fl16, peers)
    print_details(fl16, ref, peers, cfg)
    print_bsdf_table(bench)
    print(f"\nimages: {figure_note}")
    print_summary(fl16, peers, cfg)
    print_error_curves(fl16, peers)
    line = ratio_line(fl16, peers)
    error_line = equal_error_line(fl16, peers)
    results = {"config": {**cfg, "out": str(cfg["out"]), "skip": sorted(cfg["skip"]), "cores": os.cpu_count(),
                          "fiberlab": str(FIBERLAB)},
               "fiberlab": fl16, "reference": ref, "peers": peers, "bsdf_bench": bench, "ratio_line": line,
               "equal_error_line": error_line}
    (cfg["out"] / "results.json").write_text(json.dumps(results, indent=1, default=str))
    print(f"results: {cfg['out'] / 'results.json'}; at the end: {load_average()}")
    if "PEERS_T0" in os.environ:
        print(f"wall time of the whole run (setup included): {time.time() - float(os.environ['PEERS_T0']):.0f} s")
    print(f"curves {cfg['curves']}; {load_average()}")
    print(line)
    print(error_line)


if __name__ == "__main__":
    main()
