//! `fiberlab devices` and `fiberlab render --device`: a render begun on the GPU is continued on
//! the CPU through `--resume`; the other fiber models and the shipped wood scene render on the GPU; no adapter gives an error naming what was looked for, and `auto`
//! falls back to the CPU with a note. Runs on Mesa's lavapipe in CI (`FIBERLAB_GPU_TESTS=skip`
//! skips the GPU renders on a machine without any Vulkan driver).

mod fiberlab_process;
use fiberlab_process::{fiberlab_in, refused, stderr_of, stdout_of};

const SCENE: &str = r#"
[camera]
eye = [0.0, 0.5, 4.0]
target = [0.0, 0.0, 0.0]
fov = 40
width = 20
height = 14

[render]
spp = 2
seed = 3

[materials.hair]
model = "chiang"

[materials.skin]
lambert = [0.5, 0.4, 0.3]

[[hair]]
material = "hair"
generator = { strands = 200, segments = 8, style = "curly", seed = 2 }

[[sphere]]
center = [0, 0, 0]
radius = 1
material = "skin"

[[light]]
type = "environment"
radiance = [1, 1, 1]

[[light]]
type = "sun"
direction = [1, 1, 1]
angular_radius_deg = 1
irradiance = [2, 2, 2]
"#;

fn skip() -> bool {
    let skip = std::env::var("FIBERLAB_GPU_TESTS").as_deref() == Ok("skip");
    if skip {
        eprintln!("skipping the GPU renders (FIBERLAB_GPU_TESTS=skip)");
    }
    skip
}

#[test]
fn a_gpu_render_resumes_on_the_cpu_and_devices_lists_the_adapter() {
    if skip() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), SCENE).unwrap();
    let listed = stdout_of(fiberlab_in(d).arg("devices"));
    assert!(listed.contains("Vulkan") || listed.contains("Metal") || listed.contains("Dx12"), "{listed}");
    let gpu = stderr_of(fiberlab_in(d).args(["render", "s.toml", "--device", "gpu", "--quiet", "--out", "g"]));
    assert!(gpu.contains("rendering 20×14 to 2 spp on ") && !gpu.contains("on the CPU"), "{gpu}");
    let more = stderr_of(fiberlab_in(d).args(["render", "s.toml", "--resume", "g.exr", "--spp", "5", "--quiet"]));
    assert!(more.contains("at 5 spp") && more.contains("on the CPU"), "{more}");
    let image = fiberlab_io::LinearImage::read_exr(&d.join("g.exr")).unwrap();
    assert_eq!(image.attribute("spp"), Some("5"));
    // The other supported fiber models render on the GPU too.
    for model in ["marschner", "deon", "kajiya-kay", "yan-fur", "huang-2022"] {
        std::fs::write(d.join("m.toml"), SCENE.replace("\"chiang\"", &format!("\"{model}\""))).unwrap();
        let log = stderr_of(fiberlab_in(d).args(["render", "m.toml", "--device", "gpu", "--quiet", "--out", "m"]));
        assert!(log.contains("rendering 20×14 to 2 spp on ") && !log.contains("on the CPU"), "{model}: {log}");
    }
    // The shipped figured-maple scene (the wood surface model with textured fiber angle, dip and
    // k_d), small.
    let wood = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/wood.toml");
    let wood = wood.to_str().unwrap();
    let args = ["render", wood, "--device", "gpu", "--size", "24x24", "--spp", "2", "--quiet", "--out", "w"];
    let log = stderr_of(fiberlab_in(d).args(args));
    assert!(log.contains("rendering 24×24 to 2 spp on ") && !log.contains("on the CPU"), "wood: {log}");
    assert!(d.join("w.exr").exists(), "wood: {log}");
    // An unsupported model is refused before rendering, with the way out.
    std::fs::write(d.join("k.toml"), SCENE.replace("\"chiang\"", "\"sadeghi-thread\"")).unwrap();
    let err = refused(fiberlab_in(d).args(["render", "k.toml", "--device", "gpu", "--quiet"]));
    assert!(err.contains("`sadeghi-thread`") && err.contains("huang-2022") && err.contains("--device cpu"), "{err}");
}

#[test]
fn without_an_adapter_gpu_is_an_error_and_auto_renders_on_the_cpu() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("s.toml"), SCENE).unwrap();
    // The Vulkan loader finds no driver.
    let none = |c: &mut assert_cmd::Command| {
        c.env("VK_DRIVER_FILES", "/nonexistent.json").env("VK_ICD_FILENAMES", "/nonexistent.json");
    };
    let mut cmd = fiberlab_in(d);
    cmd.args(["render", "s.toml", "--device", "gpu", "--quiet"]);
    none(&mut cmd);
    let err = refused(&mut cmd);
    assert!(err.contains("no GPU adapter found") && err.contains("Vulkan"), "{err}");
    let mut cmd = fiberlab_in(d);
    cmd.args(["render", "s.toml", "--device", "auto", "--quiet", "--out", "a"]);
    none(&mut cmd);
    let auto = stderr_of(&mut cmd);
    assert!(auto.contains("--device auto: ") && auto.contains("rendering on the CPU"), "{auto}");
    let mut cmd = fiberlab_in(d);
    cmd.arg("devices");
    none(&mut cmd);
    assert!(stdout_of(&mut cmd).contains("no GPU adapter found"));
}
