"""`fiberlab.render` against the command line, and scene dicts."""

import subprocess

import numpy as np
import pytest

import fiberlab as fl
from test_models import cli_binary

SCENE = {
    "camera": {"eye": [0.0, 0.5, 4.0], "target": [0.0, 0.0, 0.0], "fov": 40, "width": 24, "height": 16},
    "render": {"spp": 3, "seed": 5},
    "materials": {
        "hair": {"model": "chiang", "params": {"eumelanin": 0.6, "beta_m": 0.3}},
        "skin": {"lambert": [0.5, 0.4, 0.3]},
    },
    "hair": [{"material": "hair", "generator": {"strands": 300, "segments": 8, "style": "curly", "seed": 2}}],
    "sphere": [{"center": [0, 0, 0], "radius": 1, "material": "skin"}],
    "light": [
        {"type": "environment", "radiance": [1, 1, 1]},
        {"type": "sun", "direction": [1, 1, 1], "angular_radius_deg": 1, "irradiance": [2, 2, 2]},
    ],
}


def test_a_render_equals_the_command_line_render_bit_for_bit(tmp_path):
    scene = tmp_path / "s.toml"
    scene.write_text(fl.scene_toml(SCENE))
    out = subprocess.run([str(cli_binary()), "render", str(scene), "--quiet", "--out", str(tmp_path / "r")],
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    cli = fl.read_exr(tmp_path / "r.exr")
    calls = []
    image = fl.render(SCENE, progress=lambda done, total: calls.append((done, total)))
    assert image.shape == (16, 24, 3) and image.dtype == np.float32
    np.testing.assert_array_equal(image, cli)
    np.testing.assert_array_equal(fl.render(scene, threads=1), cli)
    assert image.max() > 0.01
    assert calls and calls[-1][0] == calls[-1][1] == 24 * 16 * 3
    # Overrides change the image; the same seed gives the same image again.
    other = fl.render(SCENE, seed=6)
    assert not np.array_equal(other, image)
    np.testing.assert_array_equal(fl.render(text=fl.scene_toml(SCENE)), image)


def test_scene_errors_raise_value_error():
    bad = {**SCENE, "camera": {**SCENE["camera"], "fov": float("nan")}}
    with pytest.raises(ValueError, match="fov"):
        fl.render(bad)
    with pytest.raises(ValueError, match="missing.toml"):
        fl.render("missing.toml")
    with pytest.raises(ValueError, match="spp must be at least 1"):
        fl.render(SCENE, spp=0)
    with pytest.raises(ValueError, match="not both"):
        fl.render(SCENE, text="x")
    with pytest.raises(ValueError, match="<text>"):
        fl.render(text="[camera]\nfov = 'wide'\n")


def test_dual_scattering_from_python_equals_the_command_line(tmp_path):
    # A scene whose [render] asks for dual scattering renders with it, as on the command line.
    dual_scene = {**SCENE, "render": {**SCENE["render"], "integrator": "dual-scattering", "fiber_count": "grid"}}
    scene = tmp_path / "d.toml"
    scene.write_text(fl.scene_toml(dual_scene))
    out = subprocess.run([str(cli_binary()), "render", str(scene), "--quiet", "--dual", "surface_bounce=on",
                          "--out", str(tmp_path / "d")], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    cli = fl.read_exr(tmp_path / "d.exr")
    image = fl.render(dual_scene, dual={"surface_bounce": "on"})
    np.testing.assert_array_equal(image, cli)
    assert image.max() > 0.01
    # The keywords override the scene's entries: the path scene with integrator="dual-scattering"
    # is the dual scene; the path tracer and other options give other images.
    np.testing.assert_array_equal(
        fl.render(SCENE, integrator="dual-scattering", fiber_count="grid", dual={"surface_bounce": "on"}), image)
    assert not np.array_equal(fl.render(dual_scene, integrator="path"), image)
    assert not np.array_equal(fl.render(dual_scene), image)
    assert not np.array_equal(fl.render(dual_scene, fiber_count="exact", dual={"surface_bounce": "on"}), image)
    np.testing.assert_array_equal(fl.render(dual_scene, dual={"surface_bounce": "on", "pi": True}), image)


def test_dual_scattering_errors_raise_value_error():
    with pytest.raises(ValueError, match="surface_bounce.*off, on, through"):
        fl.render(SCENE, integrator="dual-scattering", dual={"surface_bounce": "maybe"})
    with pytest.raises(ValueError, match="d_g: unknown"):
        fl.render(SCENE, integrator="dual-scattering", dual={"d_g": 1})
    with pytest.raises(ValueError, match="must be finite"):
        fl.render(SCENE, integrator="dual-scattering", dual={"d_f": float("nan")})
    with pytest.raises(ValueError, match="integrator `bdpt`"):
        fl.render(SCENE, integrator="bdpt")
    with pytest.raises(ValueError, match="exact, grid"):
        fl.render(SCENE, integrator="dual-scattering", fiber_count="guess")
    no_fibers = {k: v for k, v in SCENE.items() if k != "hair"}
    with pytest.raises(ValueError, match="needs fibers"):
        fl.render(no_fibers, integrator="dual-scattering")


def test_a_gpu_render_equals_the_command_line_gpu_render_bit_for_bit(tmp_path):
    """`device="gpu"` runs the GPU path tracer (software Vulkan in CI): the same image as
    `fiberlab render --device gpu`, close to the CPU's."""
    import os
    if os.environ.get("FIBERLAB_GPU_TESTS") == "skip":
        pytest.skip("FIBERLAB_GPU_TESTS=skip")
    scene = tmp_path / "s.toml"
    scene.write_text(fl.scene_toml(SCENE))
    out = subprocess.run([str(cli_binary()), "render", str(scene), "--quiet", "--device", "gpu", "--out",
                          str(tmp_path / "g")], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    image = fl.render(SCENE, device="gpu")
    np.testing.assert_array_equal(image, fl.read_exr(tmp_path / "g.exr"))
    cpu = fl.render(SCENE)
    assert abs(image.mean() / cpu.mean() - 1) < 0.05
    with pytest.raises(ValueError, match="expected cpu, gpu or auto"):
        fl.render(SCENE, device="tpu")
