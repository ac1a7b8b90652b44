//! `fiberlab hair generate --style fur`: the fur defaults apply to the flags not given, and a
//! flag given overrides them.

use assert_cmd::Command;
use fiberlab_io::HairFile;

fn generate(dir: &std::path::Path, args: &[&str]) -> HairFile {
    let out = dir.join("fur.hair");
    let status = Command::cargo_bin("fiberlab")
        .expect("binary builds")
        .args(["hair", "generate", "--style", "fur", "--strands", "300", "--out"])
        .arg(&out)
        .args(args)
        .output()
        .expect("runs");
    assert!(status.status.success(), "{}", String::from_utf8_lossy(&status.stderr));
    HairFile::read(&out).expect("reads")
}

#[test]
fn fur_style_uses_the_fur_defaults_and_flags_override_them() {
    let dir = tempfile::tempdir().unwrap();
    let fur = fiberlab_procedural::generator::HairParams::fur();
    let hair = generate(dir.path(), &[]);
    assert_eq!(hair.strand_count(), 300);
    // The fur's 6 segments, not the hair's 24; its root diameter and tenfold taper.
    assert_eq!(hair.points.len(), 300 * (fur.segments + 1));
    let th = hair.thickness.as_ref().unwrap();
    assert!((f64::from(th[0]) - fur.root_diameter).abs() < 1e-8);
    assert!((f64::from(th[fur.segments]) - fur.root_diameter * fur.tip_ratio).abs() < 1e-8);
    // Strands are short: no point farther from the unit sphere than the longest strand.
    let far =
        hair.points.iter().map(|p| p.iter().map(|c| f64::from(*c).powi(2)).sum::<f64>().sqrt()).fold(0.0, f64::max);
    assert!(far > 1.0 && far < 1.0 + fur.length + 1e-3, "farthest point at radius {far}");
    let longer = generate(dir.path(), &["--segments", "3", "--tip-ratio", "1"]);
    assert_eq!(longer.points.len(), 300 * 4);
    assert!(longer.thickness.as_ref().unwrap().iter().all(|&t| (f64::from(t) - fur.root_diameter).abs() < 1e-8));
}

#[test]
fn fur_length_jitter_is_validated_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::cargo_bin("fiberlab")
        .unwrap()
        .args(["hair", "generate", "--style", "fur", "--length-jitter", "1.5", "--out"])
        .arg(dir.path().join("x.hair"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("`length_jitter` = 1.5 is invalid"), "{err}");
}
