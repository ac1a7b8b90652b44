"""What the Python package does with hostile input (issue 36): the command line's memory check
and message as `MemoryError`, never a panic or a dead interpreter; FIFOs refused at once;
deep nesting an error; outputs by their extension, never over a link; the calls that raised
the wrong error (`check("chiang")`, `render(progress=True)`).

Each case that could hang or kill the interpreter runs in a child interpreter with a
generous timeout that kills it (a hang or a crash fails the test; no timed assertion)."""

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import fiberlab as fl

# How long a child interpreter may run before it is killed.
TIMEOUT = 300


def run_python(code: str) -> subprocess.CompletedProcess:
    """Runs `code` in a child interpreter; the test fails if it is killed by a signal."""
    out = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                         timeout=TIMEOUT)
    assert out.returncode >= 0, f"killed by signal {-out.returncode}: {out.stderr}"
    assert "PanicException" not in out.stderr and "panicked" not in out.stderr, out.stderr
    return out


TINY = {
    "camera": {"eye": [0.0, 0.0, 4.0], "target": [0.0, 0.0, 0.0], "fov": 40, "width": 8, "height": 8},
    "render": {"spp": 1, "seed": 1},
    "materials": {"skin": {"lambert": [0.5, 0.4, 0.3]}},
    "sphere": [{"center": [0, 0, 0], "radius": 1, "material": "skin"}],
    "light": [{"type": "environment", "radiance": [1, 1, 1]}],
}


def test_a_render_larger_than_memory_raises_memory_error_before_any_work():
    huge = dict(TINY, camera=dict(TINY["camera"], width=100000, height=100000))
    with pytest.raises(MemoryError, match=r"render: image 100000×100000 needs ~ [0-9.]+ [KMGTPE]iB"):
        fl.render(huge)


def test_evaluations_under_a_memory_limit_raise_memory_error_not_a_panic():
    # Under an address-space limit the inputs fit and the output does not: the command line's
    # check refuses it (MemoryError naming the array), where NumPy's failed allocation
    # panicked inside the extension.
    out = run_python("""
        import resource
        import numpy as np
        import fiberlab as fl
        m = fl.Model("chiang")
        n = 20_000_000
        wi = np.zeros((n, 3)); wi[:, 2] = 1.0
        wo = wi.copy()
        h = np.zeros(n)
        size = int(open("/proc/self/status").read().split("VmSize:")[1].split()[0]) * 1024
        resource.setrlimit(resource.RLIMIT_AS, (size + 300 * 2**20, resource.RLIM_INFINITY))
        try:
            m._native.evaluate(wi, wo, h, "fs")
            print("no error")
        except MemoryError as e:
            print("MemoryError:", e)
    """)
    assert out.returncode == 0, out.stderr
    assert "MemoryError: f_s array [20000000, 3] needs ~ 458 MiB" in out.stdout, out.stdout + out.stderr


def test_a_fifo_is_refused_at_once(tmp_path):
    fifo = tmp_path / "f.exr"
    os.mkfifo(fifo)
    link = tmp_path / "f.hair"
    link.symlink_to(fifo)
    out = run_python(f"""
        import fiberlab as fl
        for call in (lambda: fl.read_exr({str(fifo)!r}), lambda: fl.hair.read({str(link)!r})):
            try:
                call()
                print("read")
            except ValueError as e:
                print("ValueError:", e)
    """)
    assert out.returncode == 0, out.stderr
    assert out.stdout.count("a FIFO (named pipe), not a regular file") == 2, out.stdout


def test_deeply_nested_usd_is_an_error_not_a_crash(tmp_path):
    deep = tmp_path / "deep.usda"
    depth = 8000
    deep.write_text("#usda 1.0\n" + "".join(f'def Xform "p{i}" {{\n' for i in range(depth)) + "}\n" * depth)
    out = run_python(f"""
        import fiberlab as fl
        try:
            fl.hair.read({str(deep)!r})
        except ValueError as e:
            print("ValueError:", e)
    """)
    assert out.returncode == 0, out.stderr
    assert "deep.usda:258:1: prims nest more than 256 deep" in out.stdout, out.stdout


def test_hair_write_follows_the_extension_and_never_replaces_a_link(tmp_path):
    strands = [np.array([[0, 0, 0], [0, 1, 0], [0, 2, 0.5]], dtype=np.float32)]
    with pytest.raises(ValueError, match="writing pbrt files is not supported"):
        fl.hair.write(tmp_path / "x.pbrt", strands)
    with pytest.raises(ValueError, match="unknown hair file format"):
        fl.hair.write(tmp_path / "x.txt", strands)
    assert not (tmp_path / "x.pbrt").exists() and not (tmp_path / "x.txt").exists()
    fl.hair.write(tmp_path / "x.usda", strands, default_thickness=0.1)
    assert (tmp_path / "x.usda").read_text().startswith("#usda 1.0")
    back = fl.hair.read(tmp_path / "x.usda")
    np.testing.assert_array_equal(back.strands[0], strands[0])
    precious = tmp_path / "elsewhere"
    precious.write_text("not ours")
    link = tmp_path / "link.hair"
    link.symlink_to(precious)
    with pytest.raises(ValueError, match="a symbolic link to"):
        fl.hair.write(link, strands)
    assert link.is_symlink() and precious.read_text() == "not ours"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["elsewhere", "link.hair", "x.usda"]


def test_check_takes_a_model_or_its_name():
    rows = fl.check("kajiya-kay", chi2_samples=2000, samples=2000, pairs=20)
    assert rows and all(r["model"].startswith("kajiya-kay") for r in rows)
    with pytest.raises(TypeError, match="expected a fiberlab.Model or a model name, got int"):
        fl.check(3)


def test_render_progress_true_prints_and_a_non_callable_is_a_type_error(capfd):
    image = fl.render(TINY, progress=True)
    assert image.shape == (8, 8, 3)
    assert "rendering: 100.0%" in capfd.readouterr().err
    with pytest.raises(TypeError, match="progress must be a callable"):
        fl.render(TINY, progress="yes")
