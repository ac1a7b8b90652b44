//! `fiberlab hair info`/`convert` and scenes on pbrt and USD curve files, written here by
//! string formatting (not by fiberlab's writers), against the same strands as `.hair`.

mod fiberlab_process;
use fiberlab_process::{fiberlab_in, refused, stdout_of};

const SCENE: &str = r#"
[camera]
eye = [0.0, 0.3, 3.5]
target = [0.0, 0.0, 0.0]
fov = 40
width = 24
height = 16

[render]
spp = 2
seed = 5

[materials.hair]
model = "kajiya-kay"

[[hair]]
material = "hair"
file = "FILE"
segments_per_curve = 1

[[light]]
type = "environment"
radiance = [1, 1, 1]
"#;

/// Each strand of the `.hair` file as one pbrt Bézier curve whose span ends are the strand's
/// points (the inner control points at the thirds of each chord), one constant width.
fn pbrt_text(hair: &fiberlab_io::HairFile) -> String {
    let mut s = String::from(
        "# written by the test\nLookAt 0 0 5 0 0 0 0 1 0\nCamera \"perspective\"\nWorldBegin\nAttributeBegin\n",
    );
    for r in hair.strand_ranges() {
        let p = &hair.points[r];
        let mut cps = vec![format!("{} {} {}", p[0][0], p[0][1], p[0][2])];
        for w in p.windows(2) {
            for t in [1.0f32 / 3.0, 2.0 / 3.0] {
                let q: Vec<String> = (0..3).map(|k| format!("{}", w[0][k] + (w[1][k] - w[0][k]) * t)).collect();
                cps.push(q.join(" "));
            }
            cps.push(format!("{} {} {}", w[1][0], w[1][1], w[1][2]));
        }
        s += &format!(
            "Shape \"curve\" \"string type\" [ \"cylinder\" ] \"point3 P\" [ {} ] \"float width\" [ {} ]\n",
            cps.join("  "),
            hair.thickness_at(0)
        );
    }
    s + "AttributeEnd\n"
}

#[test]
fn pbrt_and_usda_curves_render_like_the_same_strands_as_hair() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    stdout_of(fiberlab_in(d).args([
        "hair",
        "generate",
        "--strands",
        "150",
        "--segments",
        "6",
        "--tip-ratio",
        "1",
        "--seed",
        "2",
        "--out",
        "h.hair",
    ]));
    let hair = fiberlab_io::HairFile::read(&d.join("h.hair")).unwrap();
    std::fs::write(d.join("h.pbrt"), pbrt_text(&hair)).unwrap();
    stdout_of(fiberlab_in(d).args(["hair", "convert", "h.hair", "h.usda"]));
    let mut images = Vec::new();
    for file in ["h.hair", "h.pbrt", "h.usda"] {
        let scene = format!("{file}.toml");
        std::fs::write(d.join(&scene), SCENE.replace("FILE", file)).unwrap();
        let out = format!("out-{file}");
        stdout_of(fiberlab_in(d).args(["render", &scene, "--quiet", "--threads", "2", "--out", &out]));
        images.push(fiberlab_io::LinearImage::read_exr(&d.join(format!("{out}.exr"))).unwrap());
    }
    // The pixels (the attributes hold the scene's hash, which differs with the file name).
    let differ = |a: &fiberlab_io::LinearImage, b: &fiberlab_io::LinearImage| {
        assert_eq!(a.pixels().len(), b.pixels().len());
        a.pixels().iter().zip(b.pixels()).filter(|(x, y)| x != y).count()
    };
    assert!(images[0].pixels().iter().filter(|p| p[0] != 1.0).count() > 20, "the hair is in view");
    assert_eq!(differ(&images[0], &images[1]), 0, "pbrt");
    assert_eq!(differ(&images[0], &images[2]), 0, "usda");
    // The same scene through --hair.
    stdout_of(fiberlab_in(d).args(["render", "h.hair.toml", "--hair", "h.pbrt", "--quiet", "--out", "flag"]));
    assert_eq!(differ(&fiberlab_io::LinearImage::read_exr(&d.join("flag.exr")).unwrap(), &images[0]), 0);
    // With the default subdivision the curves are cubic and differ from the polylines.
    std::fs::write(d.join("cubic.toml"), SCENE.replace("FILE", "h.pbrt").replace("segments_per_curve = 1\n", ""))
        .unwrap();
    stdout_of(fiberlab_in(d).args(["render", "cubic.toml", "--quiet", "--out", "cubic"]));
    assert!(differ(&fiberlab_io::LinearImage::read_exr(&d.join("cubic.exr")).unwrap(), &images[0]) > 0);
}

#[test]
fn info_and_convert_work_for_every_format() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("c.pbrt"),
        "WorldBegin\nShape \"curve\" \"string type\" \"cylinder\" \"string basis\" \"bspline\" \"point3 P\" [0 0 0 1 1 0 2 0 0 3 1 0 4 0 0] \"float width0\" 0.2 \"float width1\" 0.1\n",
    )
    .unwrap();
    let info = stdout_of(fiberlab_in(d).args(["hair", "info", "c.pbrt"]));
    for line in [
        "strands     1\n",
        "points      7\n",
        "segments    2\n",
        "basis       bezier\n",
        "type        cylinder\n",
        "widths      0.1 – 0.2\n",
    ] {
        assert!(info.contains(line), "{info}");
    }
    stdout_of(fiberlab_in(d).args(["hair", "convert", "c.pbrt", "c.usda"]));
    let usd = std::fs::read_to_string(d.join("c.usda")).unwrap();
    assert!(usd.starts_with("#usda 1.0\n") && usd.contains("uniform token basis = \"bezier\""), "{usd}");
    stdout_of(fiberlab_in(d).args(["hair", "convert", "c.usda", "c.hair", "--segments-per-curve", "5"]));
    let info = stdout_of(fiberlab_in(d).args(["hair", "info", "c.hair"]));
    // 2 spans × 5 segments: 11 points on one strand.
    assert!(
        info.contains("strands     1\n") && info.contains("points      11\n") && info.contains("basis       linear"),
        "{info}"
    );
    let err = refused(fiberlab_in(d).args(["hair", "convert", "c.hair", "c.pbrt"]));
    assert!(err.contains("c.pbrt") && err.contains("not supported"), "{err}");
    let err = refused(fiberlab_in(d).args(["hair", "info", "c.txt"]));
    assert!(err.contains("c.txt: unknown hair file format"), "{err}");
}

#[test]
fn hostile_curve_files_are_errors_naming_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cases: [(&str, &str, &str); 6] = [
        ("a.pbrt", "WorldBegin\nShape \"curve\" \"point3 P\" [ 0 0 0 1 0", "a.pbrt:2:26: this `[` is never closed"),
        ("b.pbrt", "WorldBegin\n  Include \"b.pbrt\"\n", "b.pbrt:2:11: include cycle"),
        ("c.pbrt", "Include \"gone.pbrt.gz\"\n", "c.pbrt:1:9: cannot read the included file"),
        (
            "d.usda",
            "#usda 1.0\ndef BasisCurves \"c\" { int[] curveVertexCounts = [4000000000]\n point3f[] points = [(0, 0, 0)] }\n",
            "d.usda:3:21: 1 points, but curveVertexCounts add up to 4000000000",
        ),
        ("e.usda", "def BasisCurves \"c\" {}\n", "e.usda:1:1: expected the header line"),
        (
            "f.usda",
            "#usda 1.0\ndef BasisCurves \"c\" { uniform token type = \"linear\"\n int[] curveVertexCounts = [2]\n point3f[] points = [(0, 0, 0), (0, nan, 0)] }",
            "f.usda:4:37: point 1: coordinate nan",
        ),
    ];
    for (name, text, want) in cases {
        std::fs::write(d.join(name), text).unwrap();
        let err = refused(fiberlab_in(d).args(["hair", "info", name]));
        assert!(err.contains(want), "{name}: {err}");
        // In a scene: the scene's location and the file's.
        std::fs::write(d.join("s.toml"), SCENE.replace("FILE", name)).unwrap();
        let err = refused(fiberlab_in(d).args(["render", "s.toml", "--quiet", "--out", "x"]));
        assert!(err.contains("s.toml:") && err.contains(want), "{name}: {err}");
    }
}

#[test]
fn the_memory_budget_counts_the_points_of_text_files_before_loading() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut s = String::from(
        "#usda 1.0\ndef BasisCurves \"c\"\n{\n    uniform token basis = \"bspline\"\n    int[] curveVertexCounts = [",
    );
    let strands = 2000;
    s += &vec!["10"; strands].join(", ");
    s += "]\n    point3f[] points = [";
    let pts: Vec<String> = (0..strands * 10).map(|i| format!("({}, {}, 0)", i % 10, i / 10)).collect();
    s += &pts.join(", ");
    s += "]\n    float[] widths = [0.01]\n}\n";
    std::fs::write(d.join("big.usda"), s).unwrap();
    std::fs::write(
        d.join("s.toml"),
        SCENE.replace("FILE", "big.usda").replace("segments_per_curve = 1", "segments_per_curve = 4"),
    )
    .unwrap();
    let err = refused(fiberlab_in(d).args(["render", "s.toml", "--quiet", "--memory-limit", "1M", "--out", "x"]));
    // 2000 strands × 7 spans × 4 segments.
    assert!(err.contains("hair 2000 strands × 56000 segments") && err.contains("big.usda"), "{err}");
}

/// `hair generate --style grass` writes the grass generator's blades as ribbon curves with
/// normals (the same strands as the library's, flags mapped to its parameters); rendered
/// with a leaf material from that file, the patch looks like the same patch generated in the
/// scene (`[[mesh]] grass`): the ribbons differ only at the blades' roots and tips (module docs
/// of `fiberlab_procedural::grass`), so the images agree to a few percent. Wrong output
/// formats and flags of the other generator are refused by name.
#[test]
fn grass_generated_to_usda_renders_like_the_scene_generated_patch() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let flags = ["--strands", "400", "--segments", "6", "--size", "0.6,0.4", "--width", "0.02", "--bend-deg", "70"];
    stdout_of(
        fiberlab_in(d).args(["hair", "generate", "--style", "grass", "--seed", "3", "--out", "g.usda"]).args(flags),
    );
    let read = fiberlab_io::strand_files::read(&d.join("g.usda")).unwrap();
    let params = fiberlab_procedural::grass::GrassParams {
        blades: 400,
        segments: 6,
        size: [0.6, 0.4],
        width: 0.02,
        bend_deg: 70.0,
        seed: 3,
        ..Default::default()
    };
    assert_eq!(read, params.strands().unwrap());
    assert_eq!(read.kind, fiberlab_io::CurveKind::Ribbon);
    let scene = |geometry: &str| {
        format!(
            "[camera]\neye = [0.0, 0.25, -1.0]\ntarget = [0.0, 0.08, 0.0]\nfov = 35\nwidth = 40\nheight = 28\n\
             [render]\nspp = 8\nseed = 1\n[materials.blade]\nmodel = \"leaf\"\n{geometry}\n\
             [[light]]\ntype = \"environment\"\nradiance = [0.2, 0.25, 0.3]\n\
             [[light]]\ntype = \"sun\"\ndirection = [0.1, 0.3, 1.0]\nangular_radius_deg = 2.0\nirradiance = [5, 5, 5]\n"
        )
    };
    std::fs::write(d.join("file.toml"), scene("[[hair]]\nmaterial = \"blade\"\nfile = \"g.usda\"")).unwrap();
    std::fs::write(
        d.join("gen.toml"),
        scene("[[mesh]]\nmaterial = \"blade\"\ngrass = { blades = 400, segments = 6, size = [0.6, 0.4], width = 0.02, bend_deg = 70.0, seed = 3 }"),
    )
    .unwrap();
    let mut images = Vec::new();
    for s in ["file", "gen"] {
        stdout_of(fiberlab_in(d).args(["render", &format!("{s}.toml"), "--quiet", "--threads", "2", "--out", s]));
        images.push(fiberlab_io::LinearImage::read_exr(&d.join(format!("{s}.exr"))).unwrap());
    }
    let sum = |img: &fiberlab_io::LinearImage| img.pixels().iter().flatten().map(|&v| f64::from(v)).sum::<f64>();
    let diff: f64 = images[0]
        .pixels()
        .iter()
        .flatten()
        .zip(images[1].pixels().iter().flatten())
        .map(|(a, b)| (f64::from(*a) - f64::from(*b)).abs())
        .sum();
    let sky_only = 40.0 * 28.0 * 3.0 * 0.2;
    assert!(sum(&images[1]) > 0.5 * sky_only, "the patch is lit");
    assert!(diff < 0.05 * sum(&images[1]), "mean |Δ| {diff} of {}", sum(&images[1]));
    let e = refused(fiberlab_in(d).args(["hair", "generate", "--style", "grass", "--out", "g.hair"]));
    assert!(e.contains("g.hair: grass blades are ribbon curves with normals, which only .usda holds"), "{e}");
    let e = refused(fiberlab_in(d).args(["hair", "generate", "--style", "grass", "--gravity", "2", "--out", "g.usda"]));
    assert!(e.contains("--gravity is a hair flag"), "{e}");
    let e = refused(fiberlab_in(d).args(["hair", "generate", "--twist-deg", "2", "--out", "h.hair"]));
    assert!(e.contains("--twist-deg is a grass flag"), "{e}");
    let e =
        refused(fiberlab_in(d).args(["hair", "generate", "--style", "grass", "--bend-deg", "nan", "--out", "g.usda"]));
    assert!(e.contains("bend_deg"), "{e}");
}
