//! `fiberlab measure --surface` and `compare-model --model wood` on its table: the highlight's
//! locus passes with the slab's dip and fails with a wrong one; surface flags need `--surface`.

mod fiberlab_process;
use fiberlab_process::{fiberlab, stdout_of};

fn compare(table: &str, dip: &str) -> serde_json::Value {
    let out = stdout_of(fiberlab().args([
        "compare-model",
        "--table",
        table,
        "--model",
        "wood",
        "--json",
        "--param",
        "eta=1.5",
        "--param",
        "beta=0.5",
        "--param",
        &format!("fiber_dip={dip}"),
        "--param",
        "fiber_angle=20",
        "--param",
        "k_f=0.005",
    ]));
    serde_json::from_str(&out).unwrap_or_else(|e| panic!("not JSON ({e}): {out}"))
}

#[test]
fn the_locus_of_a_dipped_slab_matches_wood_at_its_dip_only() {
    let dir = tempfile::tempdir().unwrap();
    let prefix = dir.path().join("slab");
    let prefix = prefix.to_str().unwrap();
    stdout_of(fiberlab().args([
        "measure",
        "--surface",
        "--eta",
        "1.5",
        "--fiber-angle",
        "20",
        "--fiber-dip",
        "15",
        "--fiber-eta",
        "2.3",
        "--sigma-a",
        "5",
        "--theta-i",
        "45",
        "--bins",
        "45,90",
        "--rays",
        "600000",
        "--out",
        prefix,
    ]));
    let table = format!("{prefix}.csv");
    let text = std::fs::read_to_string(&table).unwrap();
    assert!(text.starts_with("# fiberlab surface table"), "{}", &text[..80]);
    let right = compare(&table, "15");
    let entry = &right["fiber"][0];
    assert_eq!(entry["locus_pass"], true, "{right}");
    assert_eq!(entry["width_pass"], true, "{right}");
    let wrong = compare(&table, "0");
    assert_eq!(wrong["fiber"][0]["locus_pass"], false, "{wrong}");
}

#[test]
fn surface_flags_need_surface() {
    let out =
        fiberlab().args(["measure", "--eta", "1.4", "--theta-i", "30", "--rays", "10", "--out", "x"]).output().unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--surface"), "{}", String::from_utf8_lossy(&out.stderr));
}
