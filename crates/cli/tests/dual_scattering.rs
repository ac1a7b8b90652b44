//! `fiberlab render --integrator dual-scattering`: renders a small hair scene (summary line
//! kept), and refuses a scene without fibers and a delta fiber model with clear messages.

mod fiberlab_process;
use fiberlab_process::fiberlab;

const SCENE: &str = r#"
[camera]
eye = [0.0, 0.0, -4.0]
target = [0.0, 0.0, 0.0]
up = [0.0, 1.0, 0.0]
fov = 40.0
width = 16
height = 16

[render]
spp = 2
integrator = "dual-scattering"

[materials.hair]
model = "MODEL"

[[hair]]
material = "hair"
generator = { strands = 200, segments = 6, style = "straight", length = 1.0, seed = 1 }

[[light]]
type = "environment"
radiance = [1.0, 1.0, 1.0]
"#;

#[test]
fn renders_hair_and_refuses_what_it_cannot_render() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.toml"), SCENE.replace("MODEL", "chiang")).unwrap();
    for count in ["exact", "grid"] {
        let out = fiberlab()
            .current_dir(dir.path())
            .args(["render", "s.toml", "--fiber-count", count, "--out", count, "--quiet"])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{err}");
        assert!(
            err.contains("dual scattering: tables") && err.contains(": scene ") && err.contains(", render "),
            "{err}"
        );
        assert!(dir.path().join(format!("{count}.exr")).exists());
    }
    // surface_bounce takes off/on/through and nothing else; the message names the key and the choices.
    for (value, ok) in [("off", true), ("on", true), ("maybe", false)] {
        let out = fiberlab()
            .current_dir(dir.path())
            .args(["render", "s.toml", "--dual", &format!("surface_bounce={value}"), "--out", "sb", "--quiet"])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.success(), ok, "{err}");
        assert!(ok || (err.contains("surface_bounce") && err.contains("off, on, through")), "{err}");
    }
    // A delta model has no far-field density for the tables.
    std::fs::write(dir.path().join("d.toml"), SCENE.replace("MODEL", "specular")).unwrap();
    let out = fiberlab().current_dir(dir.path()).args(["render", "d.toml", "--quiet"]).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("delta lobes"), "{err}");
    // No fibers at all: refused, and the path tracer still renders the scene.
    let empty: String = SCENE
        .replace("[[hair]]\nmaterial = \"hair\"\n", "")
        .lines()
        .filter(|l| !l.starts_with("generator"))
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(dir.path().join("e.toml"), empty.replace("MODEL", "chiang")).unwrap();
    let out = fiberlab().current_dir(dir.path()).args(["render", "e.toml", "--quiet"]).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("needs fibers"), "{err}");
    let out = fiberlab()
        .current_dir(dir.path())
        .args(["render", "e.toml", "--integrator", "path", "--out", "p", "--quiet"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}
