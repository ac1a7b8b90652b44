//! Every surface configuration of `fiberlab check` passes the surface harness, and the
//! surface harness can fail.

use fiberlab_check::surface::check_surface_model;
use fiberlab_check::{Effort, check_cases, default_cases};
use fiberlab_scatter::{ModelKind, build_surface, lookup};

#[test]
fn every_surface_case_passes() {
    let cases: Vec<_> =
        default_cases().into_iter().filter(|c| lookup(&c.model).unwrap().kind() == ModelKind::Surface).collect();
    assert!(cases.iter().any(|c| c.model == "wood") && cases.iter().any(|c| c.model == "lambertian"));
    let rows = check_cases(&cases, &Effort::default());
    let failed: Vec<_> = rows.iter().filter(|r| !r.pass).collect();
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
    assert!(failed.is_empty(), "{} failing rows", failed.len());
    assert!(rows.len() > 20 * cases.len());
}
