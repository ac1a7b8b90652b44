//! Fail fast: absurd sizes are refused before any work by the memory check, naming the
//! quantity and its estimate (never an allocation abort); counts beyond what the formats and
//! indices store are refused even with `--memory-limit`; bad output places are refused before
//! any work, naming the path; nothing is left behind. `sample` streams its rows.

use std::io::BufRead;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

fn fiberlab() -> Command {
    Command::new(env!("CARGO_BIN_EXE_fiberlab"))
}

/// Whether the machine's available memory can be read (Linux): the default budget. Elsewhere
/// there is no check without `--memory-limit`, so the tests give one.
fn machine_budget() -> bool {
    std::fs::read_to_string("/proc/meminfo").is_ok_and(|t| t.contains("MemAvailable:"))
}

/// How the message ends when the default budget is exceeded.
fn over_budget() -> &'static str {
    if machine_budget() { "available; --memory-limit SIZE to override" } else { "above --memory-limit 16.0 GiB" }
}

fn run(dir: &Path, args: &[&str]) -> Output {
    let mut cmd = fiberlab();
    cmd.current_dir(dir).args(args);
    if !machine_budget() && !args.iter().any(|a| a.starts_with("--memory-limit")) {
        cmd.args(["--memory-limit", "16G"]);
    }
    cmd.output().expect("runs")
}

/// The command failed with a message (not a panic, not an allocation abort) and its stderr.
fn refused(out: &Output) -> String {
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "expected a failure, stderr: {err}");
    assert_ne!(out.status.code(), Some(134), "aborted: {err}");
    assert!(out.status.code().is_some(), "killed by a signal: {err}");
    assert!(!err.contains("panicked") && !err.contains("memory allocation"), "{err}");
    err
}

/// Every file in `dir`, hidden ones included (a leftover temporary file counts).
fn files_in(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).collect();
    v.sort();
    v
}

/// A scene of one sphere and, optionally, a `[[hair]]` entry (`hair` is its source line).
fn scene(width: u32, height: u32, hair: Option<&str>) -> String {
    let mut s = format!(
        "[camera]\neye = [0, 0, 5]\ntarget = [0, 0, 0]\nfov = 30\nwidth = {width}\nheight = {height}\n\
         [render]\nspp = 1\n[materials.skin]\nlambert = [0.5, 0.5, 0.5]\n[materials.hair]\nmodel = \"diffuse\"\n\
         [[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"skin\"\n\
         [[light]]\ntype = \"environment\"\nradiance = [1, 1, 1]\n"
    );
    if let Some(h) = hair {
        s += &format!("[[hair]]\nmaterial = \"hair\"\n{h}\n");
    }
    s
}

#[test]
fn an_absurd_image_is_refused_naming_its_size_and_estimate() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.toml"), scene(100_000, 100_000, None)).unwrap();
    let before = files_in(dir.path());
    let err = refused(&run(dir.path(), &["render", "s.toml", "--out", "r", "--quiet"]));
    // 10¹⁰ pixels of 139 bytes (112 of the progressive state, 27 of the written image) ≈ 1.26 TiB.
    assert!(err.contains("image 100000×100000 needs ~ 1.26 TiB"), "{err}");
    assert!(err.contains(over_budget()), "{err}");
    assert_eq!(files_in(dir.path()), before, "a file was written");
    // Below a given limit the message names the limit instead.
    let err = refused(&run(dir.path(), &["render", "s.toml", "--out", "r", "--memory-limit", "64G"]));
    assert!(err.contains("image 100000×100000 needs ~ 1.26 TiB, above --memory-limit 64.0 GiB"), "{err}");
    // evaluate keeps the reference and three renders: 4 · 10¹⁰ pixels of 24 + 3 bytes ≈ 1006 GiB.
    let err = refused(&run(dir.path(), &["evaluate", "--scene", "s.toml", "--table", "t.csv", "--out", "ev"]));
    assert!(err.contains("image 100000×100000 needs ~ 1.26 TiB (~ 2.25 TiB in all"), "{err}");
    assert!(err.contains("4 images 100000×100000 compared and in the grid ~ 1006 GiB"), "{err}");
    assert_eq!(files_in(dir.path()), before);
}

#[test]
fn four_billion_strands_are_refused_by_the_memory_check_and_then_by_the_format() {
    let dir = tempfile::tempdir().unwrap();
    let hair = "generator = { strands = 4000000000, segments = 24 }";
    std::fs::write(dir.path().join("s.toml"), scene(16, 16, Some(hair))).unwrap();
    let before = files_in(dir.path());
    let err = refused(&run(dir.path(), &["render", "s.toml", "--out", "r", "--quiet"]));
    // 9.6e10 segments (more than 2^22: one BVH piece each) of 160 bytes of BVH ≈ 14.0 TiB, the
    // strands' own 4e9 · (25 · 40 + 50) B ≈ 3.82 TiB.
    assert!(err.contains("BVH of 96000000000 segments needs ~ 14.0 TiB"), "{err}");
    assert!(err.contains("hair 4000000000 strands × 96000000000 segments (generated) ~ 3.82 TiB"), "{err}");
    // With the check overridden, the count itself is refused: 1e11 points do not fit the
    // 32-bit point count, named at the generator in the scene.
    let err = refused(&run(dir.path(), &["render", "s.toml", "--out", "r", "--memory-limit", "1000T"]));
    assert!(err.contains("s.toml:") && err.contains("100000000000 points") && err.contains("32-bit"), "{err}");
    // The same from `hair generate`.
    let err = refused(&run(dir.path(), &["hair", "generate", "--strands", "4000000000", "--out", "h.hair"]));
    assert!(err.contains("hair 4000000000 strands × 24 segments needs ~ 3.82 TiB"), "{err}");
    let err = refused(&run(
        dir.path(),
        &["hair", "generate", "--strands", "4000000000", "--out", "h.hair", "--memory-limit", "1000T"],
    ));
    assert!(err.contains("32-bit point count"), "{err}");
    assert_eq!(files_in(dir.path()), before, "a file was written");
}

#[test]
fn a_hair_file_is_estimated_from_its_header_alone() {
    let dir = tempfile::tempdir().unwrap();
    // A 128-byte header claiming 10⁸ strands and 2³² − 1 points, and no arrays: the estimate
    // reads only the header (the full read would find the file truncated).
    let mut bytes = b"HAIR".to_vec();
    for v in [100_000_000u32, u32::MAX, 2, 0] {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    bytes.resize(128, 0);
    std::fs::write(dir.path().join("h.hair"), &bytes).unwrap();
    std::fs::write(dir.path().join("s.toml"), scene(16, 16, Some("file = \"h.hair\""))).unwrap();
    std::fs::write(dir.path().join("t.toml"), scene(16, 16, Some("generator = { strands = 10 }"))).unwrap();
    let before = files_in(dir.path());
    let err = refused(&run(dir.path(), &["render", "s.toml", "--out", "r", "--quiet"]));
    // 2³² − 1 − 10⁸ = 4194967295 segments (more than 2^22: 160 bytes each).
    assert!(err.contains("BVH of 4194967295 segments needs ~ 625 GiB"), "{err}");
    assert!(err.contains("hair 100000000 strands × 4194967295 segments"), "{err}");
    // The same file given with --hair to a scene with small hair.
    let err = refused(&run(dir.path(), &["render", "t.toml", "--hair", "h.hair", "--out", "r"]));
    assert!(err.contains("BVH of 4194967295 segments"), "{err}");
    assert_eq!(files_in(dir.path()), before);
}

#[test]
fn absurd_goniophotometer_bins_are_refused_before_tracing() {
    let dir = tempfile::tempdir().unwrap();
    let args = ["measure", "--theta-i", "30", "--rays", "1000", "--bins", "100000,100000", "--out", "m"];
    let err = refused(&run(dir.path(), &args));
    // 10¹⁰ bins of 576 bytes (sums and tables of 6 lobes) ≈ 5.24 TiB.
    assert!(err.contains("goniophotometer bins 100000×100000 needs ~ 5.24 TiB"), "{err}");
    assert!(err.contains(over_budget()), "{err}");
    // Overridden, the bin count is refused by the 32-bit bin indices.
    let err = refused(&run(dir.path(), &[&args[..], &["--memory-limit", "10000T"]].concat()));
    assert!(err.contains("100000 × 100000 = 10000000000 bins") && err.contains("32-bit"), "{err}");
    assert!(files_in(dir.path()).is_empty(), "a file was written");
}

#[test]
fn memory_limit_forms_and_errors() {
    let dir = tempfile::tempdir().unwrap();
    let measure = ["measure", "--theta-i", "30", "--rays", "2000", "--bins", "18,36", "--out", "m"];
    for form in ["8G", "8g", "512M", "1.5G", "8GiB", "1000000000"] {
        let out = run(dir.path(), &[&measure[..], &["--memory-limit", form]].concat());
        assert!(out.status.success(), "{form}: {}", String::from_utf8_lossy(&out.stderr));
    }
    assert!(dir.path().join("m.csv").exists());
    for bad in ["0", "8X", "-1G", "nan", "G", ""] {
        let flag = format!("--memory-limit={bad}");
        let err = refused(&run(dir.path(), &[&measure[..], &[flag.as_str()]].concat()));
        assert!(err.contains("--memory-limit"), "{bad}: {err}");
    }
    // A limit below the estimate refuses: 180 × 360 bins of 576 bytes and the ray records of
    // one batch are more than 1 MiB.
    let empty = tempfile::tempdir().unwrap();
    let args = ["measure", "--theta-i", "30", "--rays", "10", "--out", "m", "--memory-limit", "1M"];
    let err = refused(&run(empty.path(), &args));
    assert!(err.contains("goniophotometer bins 180×360 needs ~") && err.contains("above --memory-limit 1.00 MiB"));
    let err = refused(&run(empty.path(), &["hair", "generate", "--out", "h.hair", "--memory-limit", "1K"]));
    assert!(err.contains("hair 20000 strands × 24 segments needs ~ 20.0 MiB, above --memory-limit 1.00 KiB"), "{err}");
    assert!(files_in(empty.path()).is_empty());
}

/// A directory that cannot be written: a read-only one, or `/sys` where even the superuser
/// (who ignores permission bits) cannot create files.
#[cfg(unix)]
fn read_only_dir(parent: &Path) -> PathBuf {
    use std::os::unix::fs::PermissionsExt;
    let dir = parent.join("read-only");
    std::fs::create_dir(&dir).unwrap();
    std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o555)).unwrap();
    if std::fs::File::create(dir.join("probe")).is_ok() {
        std::fs::remove_file(dir.join("probe")).unwrap();
        return PathBuf::from("/sys");
    }
    dir
}

#[test]
fn bad_output_places_are_refused_before_any_work_naming_the_path() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("a-file"), "x").unwrap();
    std::fs::create_dir(d.join("a-dir")).unwrap();
    let missing = d.join("missing/dir").display().to_string();
    let not_dir = d.join("a-file").display().to_string();
    let mut places = vec![(format!("{missing}/out"), missing.clone()), (format!("{not_dir}/out"), not_dir.clone())];
    #[cfg(unix)]
    {
        let ro = read_only_dir(d).display().to_string();
        places.push((format!("{ro}/out"), ro));
    }
    // Every verb that writes files, with inputs that need not exist: the output is checked
    // while the command line is read, before any input is opened.
    let verbs: Vec<Vec<&str>> = vec![
        vec!["render", "--quiet", "--out"],
        vec!["merge", "a.exr", "b.exr", "--out"],
        vec!["measure", "--theta-i", "30", "--rays", "1000", "--out"],
        vec!["fit", "--model", "kajiya-kay", "--table", "t.csv", "--init", "p=10", "--out"],
        vec!["compare", "a.png", "b.png", "--out"],
        vec!["compare-model", "--table", "t.csv", "--model", "marschner", "--out"],
        vec!["plot", "--model", "diffuse", "--theta-i", "30", "--out"],
        vec!["sample", "--model", "diffuse", "--wo", "0,1,0", "--count", "10", "--output"],
        vec!["eval", "--model", "diffuse", "--output"],
        vec!["hair", "generate", "--strands", "10", "--out"],
        vec!["evaluate", "--table", "t.csv", "--out"],
    ];
    for (out, place) in &places {
        for verb in &verbs {
            // evaluate creates its output directory with its parents: a missing one is fine
            // (`evaluate_output_directories_are_created_only_in_writable_places`).
            if verb[0] == "evaluate" && place == &missing {
                continue;
            }
            // plot needs its extension; evaluate's --out is a directory.
            let out = if verb[0] == "plot" { format!("{out}.png") } else { out.clone() };
            let out = if verb[0] == "evaluate" { format!("{place}/evaluation") } else { out };
            let args: Vec<&str> = verb.iter().copied().chain([out.as_str()]).collect();
            let res = fiberlab().current_dir(d).args(&args).stdin(Stdio::null()).output().unwrap();
            let err = refused(&res);
            assert!(err.contains(place.as_str()), "{args:?}: {err}");
        }
    }
    // An existing directory given as an output file is refused, for every kind of output.
    let a_dir = d.join("a-dir").display().to_string();
    for args in [
        vec!["render", "--out", &a_dir],
        vec!["plot", "--model", "diffuse", "--theta-i", "30", "--out", &a_dir],
        vec!["sample", "--model", "diffuse", "--wo", "0,1,0", "--count", "1", "--output", &a_dir],
        vec!["eval", "--model", "diffuse", "--output", &a_dir],
        vec!["hair", "generate", "--strands", "10", "--out", &a_dir],
        vec!["evaluate", "--table", "t.csv", "--out", &not_dir],
    ] {
        let err = refused(&fiberlab().current_dir(d).args(&args).stdin(Stdio::null()).output().unwrap());
        assert!(err.contains("a-dir") || err.contains("a-file"), "{args:?}: {err}");
        assert!(err.contains("directory"), "{args:?}: {err}");
    }
    // Nothing was written anywhere: only the two fixtures (and the read-only directory).
    let left: Vec<String> = files_in(d).iter().map(|p| p.file_name().unwrap().to_string_lossy().into_owned()).collect();
    assert!(left.iter().all(|n| ["a-file", "a-dir", "read-only"].contains(&n.as_str())), "{left:?}");
    assert!(files_in(&d.join("a-dir")).is_empty());
}

#[test]
fn evaluate_output_directories_are_created_only_in_writable_places() {
    // The nearest existing place of a missing `--out DIR` must be a writable directory; here
    // it is a file, refused before the scene is built.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("f"), "x").unwrap();
    let err = refused(&run(dir.path(), &["evaluate", "--table", "t.csv", "--out", "f/sub/evaluation"]));
    assert!(err.contains("--out f/sub/evaluation: `f` is not a directory"), "{err}");
    assert_eq!(files_in(dir.path()), [dir.path().join("f")]);
}

#[test]
fn sample_streams_rows_as_they_are_drawn() {
    // 10⁸ samples take minutes to write; the first rows arrive while the command is still
    // running, so they were not collected in memory first.
    let mut child = fiberlab()
        .args(["sample", "--model", "diffuse", "--wo", "0,0.6,0.8", "--count", "100000000"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut lines = std::io::BufReader::new(child.stdout.take().unwrap()).lines();
    assert_eq!(lines.next().unwrap().unwrap(), "wi_x,wi_y,wi_z,weight_r,weight_g,weight_b,pdf");
    for _ in 0..1000 {
        let row = lines.next().unwrap().unwrap();
        assert_eq!(row.split(',').count(), 7, "{row}");
    }
    assert!(child.try_wait().unwrap().is_none(), "sample finished before its first rows were read");
    child.kill().unwrap();
    child.wait().unwrap();
}

#[test]
fn streamed_outputs_equal_standard_output_and_leave_nothing_on_error() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let sample = ["sample", "--model", "chiang", "--wo", "0,0.6,0.8", "--count", "5000", "--seed", "4"];
    let to_stdout = run(d, &sample);
    assert!(to_stdout.status.success());
    assert!(run(d, &[&sample[..], &["--output", "s.csv"]].concat()).status.success());
    assert_eq!(std::fs::read(d.join("s.csv")).unwrap(), to_stdout.stdout);
    // 5000 rows and the header, each as written by the CSV writer.
    let text = String::from_utf8(to_stdout.stdout).unwrap();
    assert_eq!(text.lines().count(), 5001);
    assert!(text.ends_with('\n'));
    // eval on standard output writes nothing when a row is bad, even after good rows.
    let input = format!("wi_x,wi_y,wi_z,wo_x,wo_y,wo_z\n{}0,1,0,0,0,x\n", "0,1,0,0,0,1\n".repeat(10_000));
    let mut child = fiberlab()
        .args(["eval", "--model", "diffuse"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    {
        use std::io::Write;
        child.stdin.take().unwrap().write_all(input.as_bytes()).unwrap();
    }
    let out = child.wait_with_output().unwrap();
    let err = refused(&out);
    assert!(err.contains("line 10002, column 6 (`wo_z`)"), "{err}");
    assert!(out.stdout.is_empty(), "{} bytes written", out.stdout.len());
}
