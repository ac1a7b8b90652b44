"""Runs the example notebook `crates/py/examples/fibers.ipynb`: every code cell, in order, in
one namespace (figures saved when matplotlib is installed)."""

import json
import pathlib

import numpy as np

NOTEBOOK = pathlib.Path(__file__).resolve().parents[1] / "examples" / "fibers.ipynb"


def test_the_example_notebook_runs(tmp_path, monkeypatch):
    cells = json.loads(NOTEBOOK.read_text())["cells"]
    code = [("".join(c["source"]), i) for i, c in enumerate(cells) if c["cell_type"] == "code"]
    assert len(code) >= 6
    monkeypatch.chdir(tmp_path)
    ns = {"__name__": "fibers_notebook", "FIGURES": str(tmp_path)}
    for source, i in code:
        exec(compile(source, f"{NOTEBOOK.name} cell {i}", "exec"), ns)
    # What the notebook computes holds up: the albedo by quadrature and by sampling agree,
    # the lobes of the measurement add up, the render is an image.
    np.testing.assert_allclose(ns["albedo_sampled"], ns["albedo_quadrature"], rtol=0.02)
    lobes = ns["lobes"]
    parts = sum(lobes[n]["f"] for n in ("r", "tt", "trt", "higher", "medulla"))
    np.testing.assert_allclose(parts, lobes["all"]["f"], rtol=1e-12)
    assert ns["image"].shape == (32, 48, 3) and ns["image"].max() > 0
    assert 0 < ns["metrics"]["rmse"] < 1
    if ns["plt"] is not None:
        assert {p.name for p in tmp_path.glob("*.png")} == {
            "fs_azimuth.png", "fs_grid.png", "measured.png", "render.png"
        }
