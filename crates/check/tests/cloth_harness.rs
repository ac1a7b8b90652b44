//! The cloth configurations of `fiberlab check` (Sadeghi et al. 2013's thread and cloth,
//! Irawan & Marschner 2012) pass the harness; the rows are printed. The surface cases also run
//! in `surface_harness.rs`, so this one is ignored by default (14 min on a shared machine):
//! `cargo test --release -p fiberlab-check --test cloth_harness -- --ignored --nocapture`.

use fiberlab_check::{Effort, check_cases, default_cases};

#[test]
#[ignore = "duplicates surface_harness for the cloth cases; run on demand"]
fn every_cloth_case_passes() {
    let cloth = ["sadeghi-thread", "sadeghi-2013", "irawan-2012"];
    let cases: Vec<_> = default_cases().into_iter().filter(|c| cloth.contains(&c.model.as_str())).collect();
    assert!(cloth.iter().all(|m| cases.iter().any(|c| c.model == *m)));
    let rows = check_cases(&cases, &Effort::default());
    for r in &rows {
        eprintln!(
            "{} {} | {} | value {} expected {} tol {}",
            if r.pass { "ok  " } else { "FAIL" },
            r.model,
            r.test,
            r.value,
            r.expected,
            r.tolerance
        );
    }
    let failed = rows.iter().filter(|r| !r.pass).count();
    assert_eq!(failed, 0, "{failed} failing rows");
}
