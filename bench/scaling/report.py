"""Scaling benchmark of fiberlab, report half: checks, Markdown tables and figure.

Usage: report.py OUT/scaling.json

Reads the measurements written by bench/scaling/scaling.py, adds the checks and the memory fit to
the JSON, writes OUT/scaling.md, OUT/scaling.png and OUT/scaling.svg and prints the Markdown.
Checks are flagged PASS, WARN or SKIP (too few points) and never fail the run:

* per-ray cost grows no worse than log n: the log–log slope of core-µs/ray against segments is
  below LOGLOG_SLOPE_MAX, and the largest scene is within HOLDOUT_RATIO_MAX of the
  a + b·log10(segments) fit of the other scenes;
* render time is linear in spp: its log–log slope over spp ≥ SPP_FIT_MIN is within SPP_SLOPE_RANGE.
"""

import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (after selecting the backend)
import numpy as np  # noqa: E402
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter  # noqa: E402

LOGLOG_SLOPE_MAX = 0.25
HOLDOUT_RATIO_MAX = 1.25
SPP_SLOPE_RANGE = (0.9, 1.1)
SPP_FIT_MIN = 4


def loglog_slope(x, y):
    """Least-squares slope of log y against log x."""
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


def check(name, status, detail):
    """One check result."""
    return {"check": name, "status": status, "detail": detail}


def check_loglog(rows):
    """Per-ray cost against segments: PASS if the log–log slope is below LOGLOG_SLOPE_MAX."""
    name = "core-µs/ray log–log slope vs segments"
    if len(rows) < 2:
        return check(name, "SKIP", "needs ≥ 2 strand counts")
    slope = loglog_slope([r["segments"] for r in rows], [r["core_us_per_ray"] for r in rows])
    status = "PASS" if slope < LOGLOG_SLOPE_MAX else "WARN"
    return check(name, status, f"slope {slope:.3f} (want < {LOGLOG_SLOPE_MAX}; 1 = linear in n)")


def check_log_fit(rows):
    """core-µs/ray = a + b·log10(segments / smallest); PASS if the largest scene fits the others.

    The fit over all rows is reported; the pass criterion extrapolates the fit of all but the
    largest scene to it, which exposes growth faster than log n (for instance cache misses).
    """
    name = "core-µs/ray ≈ a + b·log10(segments / smallest)"
    if len(rows) < 3:
        return check(name, "SKIP", "needs ≥ 3 strand counts")
    smallest = rows[0]["segments"]
    x = np.log10([r["segments"] / smallest for r in rows])
    y = np.array([r["core_us_per_ray"] for r in rows])
    b, a = np.polyfit(x, y, 1)
    r2 = 1 - (y - (a + b * x)).var() / y.var() if y.var() > 0 else 1.0
    b_head, a_head = np.polyfit(x[:-1], y[:-1], 1)
    predicted = a_head + b_head * x[-1]
    ratio = y[-1] / predicted
    status = "PASS" if ratio <= HOLDOUT_RATIO_MAX else "WARN"
    detail = (
        f"a = {a:.2f} µs at {smallest:,} segments, b = {b:.2f} µs per decade, R² = {r2:.3f}; "
        f"largest scene {y[-1]:.2f} µs vs {predicted:.2f} µs extrapolated from the others "
        f"(×{ratio:.2f}, want ≤ ×{HOLDOUT_RATIO_MAX})"
    )
    return check(name, status, detail)


def check_spp(rows):
    """Render time against spp (spp ≥ SPP_FIT_MIN): PASS if the log–log slope is in range."""
    name = f"render s log–log slope vs spp (spp ≥ {SPP_FIT_MIN})"
    fit = [r for r in rows if r["spp"] >= SPP_FIT_MIN]
    if len(fit) < 2:
        return check(name, "SKIP", f"needs ≥ 2 spp values ≥ {SPP_FIT_MIN}")
    slope = loglog_slope([r["spp"] for r in fit], [r["render_s"] for r in fit])
    low, high = SPP_SLOPE_RANGE
    status = "PASS" if low <= slope <= high else "WARN"
    return check(name, status, f"slope {slope:.3f} (want {low}–{high})")


def memory_fit(rows):
    """Peak RSS = fixed + bytes per segment × segments over the exact rows; None below 2 rows."""
    exact = [r for r in rows if r["peak_rss_exact"]]
    if len(exact) < 2:
        return None
    per_segment, fixed = np.polyfit(
        [r["segments"] for r in exact], [r["peak_rss_mib"] * 2**20 for r in exact], 1
    )
    return {"bytes_per_segment": float(per_segment), "fixed_mib": float(fixed / 2**20)}


def markdown_table(header, rows):
    """A Markdown table with right-aligned columns."""
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---:" for _ in header) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)


def rss_cells(row):
    """Peak RSS (MiB) and RSS per segment (B), prefixed with ≤ when only an upper bound."""
    bound = "" if row["peak_rss_exact"] else "≤ "
    return [f"{bound}{row['peak_rss_mib']:.0f}", f"{bound}{row['rss_bytes_per_segment']:.0f}"]


def markdown(result):
    """The Markdown report: setup, both tables, memory fit and checks."""
    meta = result["meta"]
    setup = (
        f"fiberlab {meta['git']} (binary sha256 {meta['binary_sha256']}) on {meta['cpu']}, "
        f"{meta['cores']} cores; {meta['scene']} at {meta['width']}×{meta['height']}, "
        f"max depth {meta['max_depth']}; {meta['segments_per_strand']} segments per strand, "
        f"radius {meta['radius']}; load average {meta['loadavg_start']:.2f} at the start."
    )
    strand_table = markdown_table(
        ["strands", "segments", "scene/BVH s", "render s", "rays", "Mrays/s", "core-µs/ray",
         "peak RSS MiB", "RSS B/segment"],
        [[f"{r['strands']:,}", f"{r['segments']:,}", f"{r['scene_s']:.2f}", f"{r['render_s']:.2f}",
          f"{r['rays']:,}", f"{r['mrays_per_s']:.3f}", f"{r['core_us_per_ray']:.2f}",
          *rss_cells(r)] for r in result["strand_sweep"]],
    )
    spp_table = markdown_table(
        ["spp", "render s", "s per spp", "rays", "Mrays/s"],
        [[str(r["spp"]), f"{r['render_s']:.2f}", f"{r['render_s'] / r['spp']:.3f}",
          f"{r['rays']:,}", f"{r['mrays_per_s']:.3f}"] for r in result["spp_sweep"]],
    )
    notes = (
        "scene/BVH s = hair load + BVH build. core-µs/ray = render s × cores / rays (shading "
        "included). RSS B/segment = peak RSS / segments, an upper bound (it includes the "
        "framebuffer, the head and the binary)."
    )
    memory = result["memory_fit"]
    if memory is not None:
        notes += (
            f" Linear fit of peak RSS: {memory['fixed_mib']:.0f} MiB + "
            f"{memory['bytes_per_segment']:.0f} B per segment."
        )
    checks = "\n".join(f"- {c['status']}: {c['check']}: {c['detail']}" for c in result["checks"])
    parts = [
        setup,
        f"**Strand sweep** at {meta['sweep_spp']} spp:", strand_table, notes,
        f"**spp sweep** with {meta['spp_sweep_strands']:,} strands:", spp_table,
        "**Checks:**", checks,
    ]
    return "\n\n".join(parts) + "\n"


def short_count(value):
    """1000 → 1k, 333334 → 333k, 1000000 → 1M."""
    for scale, suffix in ((1e6, "M"), (1e3, "k")):
        if value >= scale:
            return f"{value / scale:.3g}{suffix}"
    return f"{value:g}"


def thinned_labels(values, min_ratio=1.5):
    """Short labels for ascending `values`; of two within `min_ratio`, only the later is labelled."""
    labels, last = [], None
    for value in values:
        if last is not None and value / values[last] < min_ratio:
            labels[last] = ""
        labels.append(short_count(value))
        last = len(labels) - 1
    return labels


def log_ticks(axis, values=None):
    """Plain-number labels on a log axis: at `values` when given, else at 1, 2, 5 × 10^k."""
    if values is None:
        axis.set_major_locator(LogLocator(subs=(1, 2, 5)))
        axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    else:
        axis.set_ticks(values, thinned_labels(values))
    axis.set_minor_formatter(NullFormatter())


def plot_strands(ax, rows, segments_per_strand):
    """Panel (a): times and per-ray cost (left axis) and peak RSS (right axis) against strands."""
    strands = [r["strands"] for r in rows]
    lines = [
        ax.plot(strands, [r["render_s"] for r in rows], "o-", label="render (s)")[0],
        ax.plot(strands, [r["scene_s"] for r in rows], "s-", label="scene load + BVH (s)")[0],
        ax.plot(strands, [r["core_us_per_ray"] for r in rows], "^-", label="core-µs per ray")[0],
    ]
    ax.set_xscale("log")
    ax.set_yscale("log")
    log_ticks(ax.xaxis, strands)
    log_ticks(ax.yaxis)
    ax.set_xlabel("strands")
    ax.set_ylabel("time (s) · per-ray cost (core-µs)")
    top = ax.secondary_xaxis(
        "top", functions=(lambda s: s * segments_per_strand, lambda g: g / segments_per_strand)
    )
    log_ticks(top.xaxis, [s * segments_per_strand for s in strands])
    top.set_xlabel("segments")
    rss = ax.twinx()
    lines.append(
        rss.plot(strands, [r["peak_rss_mib"] for r in rows], "D--", color="tab:red",
                 label="peak RSS (MiB, right axis)")[0]
    )
    rss.set_yscale("log")
    log_ticks(rss.yaxis)
    rss.set_ylabel("peak RSS (MiB)")
    ax.legend(handles=lines, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2,
              fontsize="small")
    ax.set_title(f"(a) scene size at {rows[0]['spp']} spp", fontsize="medium")
    ax.grid(True, which="both", alpha=0.3)


def plot_spp(ax, rows):
    """Panel (b): render time against spp with a dashed c·spp line fitted over spp ≥ SPP_FIT_MIN."""
    spp = np.array([r["spp"] for r in rows], dtype=float)
    render = np.array([r["render_s"] for r in rows])
    fit = spp >= SPP_FIT_MIN
    if not fit.any():
        fit[:] = True
    scale = np.exp(np.mean(np.log(render[fit] / spp[fit])))
    ax.plot(spp, render, "o-", label="render (s)")
    ax.plot(spp, scale * spp, "k--", lw=1, label=f"linear reference: {scale:.3f} s × spp")
    ax.set_xscale("log")
    ax.set_yscale("log")
    log_ticks(ax.xaxis, [r["spp"] for r in rows])
    log_ticks(ax.yaxis)
    ax.set_xlabel("samples per pixel")
    ax.set_ylabel("render time (s)")
    ax.legend(loc="upper left", fontsize="small")
    ax.set_title(f"(b) samples per pixel with {rows[0]['strands']:,} strands", fontsize="medium")
    ax.grid(True, which="both", alpha=0.3)


def plot(result, out):
    """Write out/scaling.png and out/scaling.svg with the two log–log panels."""
    meta = result["meta"]
    fig, (left, right) = plt.subplots(1, 2, figsize=(13, 5.2), layout="constrained")
    plot_strands(left, result["strand_sweep"], meta["segments_per_strand"])
    plot_spp(right, result["spp_sweep"])
    fig.suptitle(
        f"fiberlab scaling: {meta['scene']} at {meta['width']}×{meta['height']}, "
        f"max depth {meta['max_depth']} — {meta['cpu']}, {meta['cores']} cores"
    )
    for suffix in ("png", "svg"):
        fig.savefig(out / f"scaling.{suffix}", dpi=130)
    plt.close(fig)


def main():
    """Add checks to the JSON given as the argument, write the Markdown and figure, print it."""
    path = Path(sys.argv[1])
    result = json.loads(path.read_text())
    strand_rows, spp_rows = result["strand_sweep"], result["spp_sweep"]
    result["checks"] = [check_loglog(strand_rows), check_log_fit(strand_rows), check_spp(spp_rows)]
    result["memory_fit"] = memory_fit(strand_rows)
    path.write_text(json.dumps(result, indent=2, ensure_ascii=False) + "\n")
    text = markdown(result)
    (path.parent / "scaling.md").write_text(text)
    plot(result, path.parent)
    print(text, end="")


if __name__ == "__main__":
    main()
