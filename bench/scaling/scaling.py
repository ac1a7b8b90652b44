"""Scaling benchmark of fiberlab, measurement half: render cost against scene size and spp.

Renders bench/peers/scene.toml (512×512, Chiang hair on a diffuse unit-sphere head, constant sky
and a distant light, max depth 12) with generated hair of 16 control points per strand (15
segments, radius 0.002):

* strand sweep at SWEEP_SPP spp: scene load + BVH build, render time, rays, per-ray cost, peak RSS;
* spp sweep with 10,000 strands: render time against spp.

Writes OUT/scaling.json; bench/scaling/report.py turns it into the checks, tables and figure.

Peak RSS is each render's own ru_maxrss from os.wait4. On Linux a child's ru_maxrss starts at
its parent's peak RSS (exec records the RSS of the memory it replaces, which for a vfork child
is the parent's), so this process imports only the standard library and never holds large data;
a row whose RSS does not exceed this process's own peak is marked as not exact.

The binary is copied into OUT first so that rebuilds of target/release/fiberlab during a long
run do not mix two builds. Started by bench/scaling/run, which documents the environment.
"""

import datetime
import hashlib
import json
import os
import re
import resource
import shutil
import subprocess
import sys
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "bench" / "peers" / "scene.toml"
BUILT_BINARY = ROOT / "target" / "release" / "fiberlab"

SEGMENTS_PER_STRAND = 15
ROOT_DIAMETER = "0.004"
DEFAULT_STRANDS = [1_000, 3_000, 10_000, 30_000, 100_000, 300_000, 333_334, 1_000_000]
DEFAULT_SPPS = [1, 4, 16, 64, 256]
DEFAULT_SWEEP_SPP = 16
SPP_SWEEP_STRANDS = 10_000

STATS_RE = re.compile(
    r"scene (?P<scene>[\d.]+) s, render (?P<render>[\d.]+) s "
    r"\((?P<samples>[\d.]+) samples/s, (?P<rays>\d+) rays, (?P<mrays>[\d.]+) Mrays/s\)"
)


def progress(message):
    """Print a progress line on stderr (stdout carries only the Markdown report)."""
    print(message, file=sys.stderr, flush=True)


def env_ints(name, default):
    """The comma-separated integers of environment variable `name`, or `default`."""
    value = os.environ.get(name, "").strip()
    if not value:
        return list(default)
    return [int(item.replace("_", "")) for item in value.split(",") if item.strip()]


def machine():
    """CPU model and the number of cores this process may run on."""
    model = "unknown CPU"
    with open("/proc/cpuinfo") as f:
        for line in f:
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    return {"cpu": model, "cores": len(os.sched_getaffinity(0))}


def git_describe():
    """`git describe --always --dirty` of the repository, or None outside a work tree."""
    result = subprocess.run(
        ["git", "describe", "--always", "--dirty"], cwd=ROOT, capture_output=True, text=True
    )
    return result.stdout.strip() or None


def scene_meta():
    """Image size and max depth of the peer scene."""
    with open(SCENE, "rb") as f:
        doc = tomllib.load(f)
    return {
        "width": doc["camera"]["width"],
        "height": doc["camera"]["height"],
        "max_depth": doc["render"]["max_depth"],
    }


def snapshot_binary(out):
    """Copy the freshly built fiberlab into `out`; return the copy's path and SHA-256 prefix."""
    copy = out / "fiberlab"
    shutil.copy2(BUILT_BINARY, copy)
    with open(copy, "rb") as f:
        digest = hashlib.file_digest(f, "sha256").hexdigest()[:12]
    return copy, digest


def own_peak_kib():
    """This process's peak RSS in KiB, the floor of any child's ru_maxrss."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss


def run_measured(cmd):
    """Run `cmd`; return its stderr, its own peak RSS in KiB and the wall time in seconds."""
    start = time.perf_counter()
    proc = subprocess.Popen(
        cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, encoding="utf-8", errors="replace"
    )
    stderr = proc.stderr.read()
    proc.stderr.close()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, cmd))} exited with {proc.returncode}:\n{stderr}")
    return stderr, usage.ru_maxrss, wall


def parse_stats(stderr):
    """Scene seconds, render seconds, samples/s, rays and Mrays/s from a `render --quiet` line."""
    match = STATS_RE.search(stderr)
    if match is None:
        raise RuntimeError(f"no render statistics in fiberlab's output:\n{stderr}")
    return {
        "scene_s": float(match["scene"]),
        "render_s": float(match["render"]),
        "samples_per_s": float(match["samples"]),
        "rays": int(match["rays"]),
        "mrays_per_s": float(match["mrays"]),
    }


class Bench:
    """Generates (and caches) hair files and renders them, remembering each (strands, spp) run."""

    def __init__(self, binary, out, threads):
        """Render with `binary` and `threads` worker threads, keeping files under `out`."""
        self.binary = binary
        self.out = out
        self.threads = threads
        self.runs = {}
        (out / "hair").mkdir(exist_ok=True)
        (out / "renders").mkdir(exist_ok=True)

    def hair(self, strands):
        """The cached .hair file with `strands` strands, generated on first use."""
        path = self.out / "hair" / f"strands-{strands}-seg{SEGMENTS_PER_STRAND}.hair"
        if path.exists():
            return path
        progress(f"  generating {strands:,} strands → {path.relative_to(self.out)}")
        partial = path.with_suffix(".partial.hair")
        subprocess.run(
            [self.binary, "hair", "generate", "--strands", str(strands),
             "--segments", str(SEGMENTS_PER_STRAND), "--root-diameter", ROOT_DIAMETER,
             "--tip-ratio", "1", "--out", partial],
            check=True, capture_output=True,
        )
        partial.replace(path)
        return path

    def render(self, strands, spp):
        """Render the scene with `strands` strands at `spp`; the row of measurements."""
        key = (strands, spp)
        if key in self.runs:
            progress(f"  reusing the {strands:,}-strand render at {spp} spp")
            return self.runs[key]
        hair = self.hair(strands)
        segments = strands * SEGMENTS_PER_STRAND
        progress(f"  rendering {strands:,} strands ({segments:,} segments) at {spp} spp …")
        prefix = self.out / "renders" / f"strands-{strands}-spp-{spp}"
        floor_kib = own_peak_kib()
        stderr, rss_kib, wall = run_measured(
            [self.binary, "render", SCENE, "--hair", hair, "--spp", str(spp),
             "--threads", str(self.threads), "--out", prefix, "--quiet"]
        )
        row = {"strands": strands, "segments": segments, "spp": spp, **parse_stats(stderr)}
        row.update(
            wall_s=round(wall, 3),
            core_us_per_ray=row["render_s"] * self.threads / row["rays"] * 1e6,
            peak_rss_mib=rss_kib / 1024,
            peak_rss_exact=rss_kib > floor_kib,
            rss_bytes_per_segment=rss_kib * 1024 / segments,
        )
        progress(
            f"    scene {row['scene_s']:.2f} s, render {row['render_s']:.2f} s, "
            f"{row['mrays_per_s']:.3f} Mrays/s, {row['core_us_per_ray']:.2f} core-µs/ray, "
            f"peak RSS {row['peak_rss_mib']:.0f} MiB"
        )
        if not row["peak_rss_exact"]:
            progress(f"    WARN: peak RSS is only this process's own peak ({floor_kib} KiB); "
                     "the render's is lower")
        self.runs[key] = row
        return row


def main():
    """Run both sweeps and write OUT/scaling.json."""
    strands = sorted(set(env_ints("STRANDS", DEFAULT_STRANDS)))
    spps = sorted(set(env_ints("SPPS", DEFAULT_SPPS)))
    sweep_spp = env_ints("SWEEP_SPP", [DEFAULT_SWEEP_SPP])[0]
    if not strands or not spps:
        sys.exit("STRANDS and SPPS must each list at least one value")
    out = Path(os.environ.get("OUT") or ROOT / "bench" / "scaling" / "out").resolve()
    out.mkdir(parents=True, exist_ok=True)

    binary, digest = snapshot_binary(out)
    meta = {
        "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "git": git_describe(),
        "binary_sha256": digest,
        **machine(),
        **scene_meta(),
        "scene": str(SCENE.relative_to(ROOT)),
        "segments_per_strand": SEGMENTS_PER_STRAND,
        "radius": float(ROOT_DIAMETER) / 2,
        "sweep_spp": sweep_spp,
        "spp_sweep_strands": SPP_SWEEP_STRANDS,
        "loadavg_start": os.getloadavg()[0],
    }
    bench = Bench(binary, out, meta["cores"])
    start = time.perf_counter()

    strand_rows = []
    for i, n in enumerate(strands, 1):
        progress(f"[strands {i}/{len(strands)}, {time.perf_counter() - start:.0f} s elapsed]")
        strand_rows.append(bench.render(n, sweep_spp))
    spp_rows = []
    for i, spp in enumerate(spps, 1):
        progress(f"[spp {i}/{len(spps)}, {time.perf_counter() - start:.0f} s elapsed]")
        spp_rows.append(bench.render(SPP_SWEEP_STRANDS, spp))
    meta["total_wall_s"] = round(time.perf_counter() - start, 1)

    path = out / "scaling.json"
    result = {"meta": meta, "strand_sweep": strand_rows, "spp_sweep": spp_rows}
    path.write_text(json.dumps(result, indent=2, ensure_ascii=False) + "\n")
    progress(f"measured in {meta['total_wall_s']:.0f} s → {path}")


if __name__ == "__main__":
    main()
