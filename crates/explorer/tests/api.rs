//! The API, endpoint by endpoint and error by error, through the router (no socket): every
//! number is checked against the library call it must equal, or against an independent value
//! (closed forms, the model's own lobes, a table made from the model).

use axum::body::Body;
use axum::http::{Request, StatusCode};
use fiberlab_explorer::api::router;
use fiberlab_explorer::{AppState, Limits};
use fiberlab_math::DVec3;
use fiberlab_math::frame::direction;
use fiberlab_scatter::ScatteringFunction;
use http_body_util::BodyExt;
use serde_json::{Value, json};
use tower::ServiceExt;

fn app() -> axum::Router {
    router(AppState::new(Limits::default()))
}

async fn send(app: &axum::Router, method: &str, path: &str, body: Body, content_type: &str) -> (StatusCode, String) {
    let request = Request::builder()
        .method(method)
        .uri(path)
        .header("content-type", content_type)
        .header("x-fiberlab-page", "test")
        .body(body)
        .unwrap();
    let response = app.clone().oneshot(request).await.unwrap();
    let status = response.status();
    let bytes = response.into_body().collect().await.unwrap().to_bytes();
    (status, String::from_utf8_lossy(&bytes).into_owned())
}

async fn post(app: &axum::Router, path: &str, body: Value) -> (StatusCode, Value) {
    let (s, text) = send(app, "POST", path, Body::from(body.to_string()), "application/json").await;
    (s, serde_json::from_str(&text).unwrap_or(Value::String(text)))
}

async fn get(app: &axum::Router, path: &str) -> (StatusCode, Value) {
    let (s, text) = send(app, "GET", path, Body::empty(), "application/json").await;
    (s, serde_json::from_str(&text).unwrap_or(Value::String(text)))
}

/// The JSON data of each server-sent event of a streamed answer.
async fn events(app: &axum::Router, path: &str, body: Value) -> (StatusCode, Vec<Value>) {
    let (s, text) = send(app, "POST", path, Body::from(body.to_string()), "application/json").await;
    if s != StatusCode::OK {
        return (s, vec![serde_json::from_str(&text).unwrap()]);
    }
    let events = text
        .split("\n\n")
        .filter_map(|block| {
            let data: Vec<&str> = block.lines().filter_map(|l| l.strip_prefix("data: ")).collect();
            (!data.is_empty()).then(|| serde_json::from_str(&data.join("\n")).unwrap())
        })
        .collect();
    (s, events)
}

fn error(v: &Value) -> &str {
    v["error"].as_str().unwrap_or_else(|| panic!("no error in {v}"))
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap_or(f64::NAN)).collect()
}

#[tokio::test]
async fn models_lists_both_registries_with_their_parameter_tables() {
    let (s, v) = get(&app(), "/api/models").await;
    assert_eq!(s, StatusCode::OK);
    let list = v.as_array().unwrap();
    let names: Vec<&str> = list.iter().map(|m| m["name"].as_str().unwrap()).collect();
    let expected: Vec<&str> = fiberlab_scatter::registry().map(|e| e.info().name).collect();
    assert_eq!(names, expected);
    let chiang = list.iter().find(|m| m["name"] == "chiang").unwrap();
    assert_eq!(chiang["kind"], "fiber");
    assert_eq!(chiang["needs_data"], false);
    assert_eq!(chiang["properties"]["near_field"], true);
    let lobes: Vec<&str> = chiang["lobes"].as_array().unwrap().iter().map(|l| l["name"].as_str().unwrap()).collect();
    assert_eq!(lobes, ["R", "TT", "TRT", "TRRT+"]);
    let spec = fiberlab_scatter::find("chiang").unwrap();
    for (p, q) in spec.params.iter().zip(chiang["params"].as_array().unwrap()) {
        assert_eq!(q["key"], p.key);
        assert_eq!(q["unit"], p.unit);
        assert_eq!(q["default"], p.default);
    }
    let beta_m = chiang["params"].as_array().unwrap().iter().find(|p| p["key"] == "beta_m").unwrap();
    assert_eq!(beta_m["kind"], "number");
    assert!(beta_m["min"].is_number() && beta_m["max"].is_number(), "{beta_m}");
    let measured = list.iter().find(|m| m["name"] == "measured").unwrap();
    assert_eq!(measured["needs_data"], true);
    let marschner = list.iter().find(|m| m["name"] == "marschner").unwrap();
    assert_eq!(marschner["lobe_parameter"], "lobes");
    let wood = list.iter().find(|m| m["name"] == "wood").unwrap();
    assert_eq!(wood["kind"], "surface");
    let preset = wood["params"].as_array().unwrap().iter().find(|p| p["key"] == "preset").unwrap();
    assert_eq!(preset["kind"], "choice");
    assert!(preset["choices"].as_array().unwrap().contains(&json!("tigers-eye")));
}

#[tokio::test]
async fn eval_returns_the_library_values_bit_for_bit() {
    let app = app();
    let (wi, wo) = (direction(0.3, 0.2), direction(-0.4, 2.5));
    let m = fiberlab_scatter::build("chiang", &[("beta_m", "0.2"), ("sigma_a", "0.3,0.5,0.9")]).unwrap();
    let (s, v) = post(
        &app,
        "/api/eval",
        json!({ "model": "chiang", "params": { "beta_m": 0.2, "sigma_a": [0.3, 0.5, 0.9] },
                "wi": wi.to_array(), "wo": wo.to_array(), "h": 0.25 }),
    )
    .await;
    assert_eq!(s, StatusCode::OK, "{v}");
    // Directions are normalized as the command line normalizes them (w / |w|).
    let (wi, wo) = (wi / wi.length(), wo / wo.length());
    let f = m.eval(wi, wo, 0.25);
    assert_eq!(floats(&v["f"]), vec![f[0], f[1], f[2]]);
    assert_eq!(v["pdf"].as_f64().unwrap(), m.pdf(wi, wo, 0.25));
    // A surface model: local frame, no h.
    let l = fiberlab_scatter::build_surface("lambertian", &[("k_d", "0.5")]).unwrap();
    let (s, v) = post(
        &app,
        "/api/eval",
        json!({ "model": "lambertian", "params": { "k_d": 0.5 }, "wi": [0, 0, 1], "wo": [0.6, 0, 0.8] }),
    )
    .await;
    assert_eq!(s, StatusCode::OK);
    let (f, pdf) = fiberlab_scatter::SurfaceScattering::eval_and_pdf(
        &l,
        fiberlab_math::DVec3::Z,
        fiberlab_math::DVec3::new(0.6, 0.0, 0.8),
    );
    assert_eq!(floats(&v["f"])[0], f[0]);
    assert_eq!(v["pdf"].as_f64().unwrap(), pdf);
}

#[tokio::test]
async fn eval_errors_are_400_with_the_command_lines_messages() {
    let app = app();
    let ok = json!([0.0, 1.0, 0.0]);
    let cases = [
        (json!({ "model": "nope", "wi": ok, "wo": ok }), "unknown model"),
        (json!({ "model": "chiang", "params": { "nope": 1 }, "wi": ok, "wo": ok }), "model `chiang`: "),
        (json!({ "model": "chiang", "params": { "beta_m": 7 }, "wi": ok, "wo": ok }), "`beta_m` = 7 is out of range"),
        (json!({ "model": "chiang", "params": { "beta_m": "x" }, "wi": ok, "wo": ok }), "beta_m"),
        (
            json!({ "model": "chiang", "wi": [0, 2, 0], "wo": ok }),
            "wi: expected a unit vector, got (0, 2, 0) of length 2",
        ),
        (json!({ "model": "chiang", "wi": ok, "wo": ok, "h": 1.5 }), "h: expected a value in [-1, 1], got 1.5"),
        (json!({ "model": "lambertian", "wi": ok, "wo": ok, "h": 0.5 }), "surface model"),
        (json!({ "model": "measured", "wi": ok, "wo": ok }), "built from a measured table"),
        (json!({ "model": "irawan-2012", "params": { "pattern": "x.weave" }, "wi": ok, "wo": ok }), "names a file"),
        (json!({ "model": "chiang", "params": { "beta_m": { "a": 1 } }, "wi": ok, "wo": ok }), "got an object"),
        (json!({ "model": "chiang", "wi": ok }), "request body: missing field `wo`"),
    ];
    for (body, expected) in cases {
        let (s, v) = post(&app, "/api/eval", body.clone()).await;
        assert_eq!(s, StatusCode::BAD_REQUEST, "{body}: {v}");
        assert!(error(&v).contains(expected), "{body}: `{}` lacks `{expected}`", error(&v));
    }
    let (s, text) = send(&app, "POST", "/api/eval", Body::from("{not json"), "application/json").await;
    assert_eq!(s, StatusCode::BAD_REQUEST);
    assert!(text.contains("request body"), "{text}");
}

fn map_max(values: &[f64]) -> f64 {
    values.iter().copied().fold(0.0, f64::max)
}

#[tokio::test]
async fn map_is_the_width_averaged_model_over_the_grid_and_moves_with_the_light() {
    let app = app();
    let body = |theta: f64| json!({ "model": "chiang", "theta_i": theta, "rows": 30, "cols": 60 });
    let (s, a) = post(&app, "/api/map", body(30.0)).await;
    assert_eq!(s, StatusCode::OK, "{a}");
    let values = floats(&a["values"]);
    assert_eq!(values.len(), 30 * 60);
    assert_eq!(a["max"].as_f64().unwrap(), map_max(&values));
    // Cell (r, c) is the width-averaged f_s at (θ_r, φ) (ScatteringFunction::eval_far).
    let m = fiberlab_scatter::build::<&str, &str>("chiang", &[]).unwrap();
    let (r, c) = (11, 17);
    let tr = -std::f64::consts::FRAC_PI_2 + (r as f64 + 0.5) * std::f64::consts::PI / 30.0;
    let p = -std::f64::consts::PI + (c as f64 + 0.5) * std::f64::consts::TAU / 60.0;
    let expected = m.eval_far(direction(30f64.to_radians(), 0.0), direction(tr, p)).luminance();
    assert!((values[r * 60 + c] - expected).abs() <= 1e-6 * expected, "{} vs {expected}", values[r * 60 + c]);
    let (_, b) = post(&app, "/api/map", body(-20.0)).await;
    assert_ne!(floats(&b["values"]), values, "the map follows θ_i");
    // The brightest row sits near the specular cone θ_r = −θ_i (the R lobe, shifted by α).
    let row_of_max = values.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).unwrap().0 / 60;
    let theta_row = -90.0 + (row_of_max as f64 + 0.5) * 6.0;
    assert!((theta_row + 30.0).abs() < 15.0, "peak at θ_r = {theta_row}");
    // The ideal specular fiber: no density, its cone instead.
    let (_, d) = post(&app, "/api/map", json!({ "model": "specular", "theta_i": 20, "rows": 10, "cols": 36 })).await;
    assert_eq!(d["delta"], true);
    assert!(map_max(&floats(&d["values"])) == 0.0 && floats(&d["cone"]).iter().any(|&x| x > 0.0));
    // A surface: the hemisphere, θ from the normal.
    let (s, w) = post(&app, "/api/map", json!({ "model": "lambertian", "theta_i": 40, "rows": 9, "cols": 18 })).await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(floats(&w["theta"]), vec![0.0, 90.0]);
    let l = fiberlab_scatter::build_surface::<&str, &str>("lambertian", &[]).unwrap();
    let f = fiberlab_scatter::SurfaceScattering::eval(&l, fiberlab_math::DVec3::Z, fiberlab_math::DVec3::Z).luminance();
    assert!(floats(&w["values"]).iter().all(|&v| (v - f).abs() < 1e-6));
}

#[tokio::test]
async fn map_lobes_sum_to_the_whole_and_bad_views_are_refused() {
    let app = app();
    let base = json!({ "model": "chiang", "theta_i": 10, "rows": 12, "cols": 24, "h": 0.3 });
    let (_, whole) = post(&app, "/api/map", base.clone()).await;
    let mut sum = vec![0.0; 12 * 24];
    for lobe in ["R", "TT", "TRT", "TRRT+"] {
        let mut b = base.clone();
        b["lobes"] = json!([lobe]);
        let (s, v) = post(&app, "/api/map", b).await;
        assert_eq!(s, StatusCode::OK, "{v}");
        sum.iter_mut().zip(floats(&v["values"])).for_each(|(a, x)| *a += x);
    }
    for (a, b) in sum.iter().zip(floats(&whole["values"])) {
        assert!((a - b).abs() <= 1e-5 * b.max(1e-6), "{a} vs {b}");
    }
    let bad = [
        (json!({ "model": "chiang", "theta_i": 95 }), StatusCode::BAD_REQUEST, "theta_i"),
        (json!({ "model": "chiang", "theta_i": 0, "rows": 0 }), StatusCode::BAD_REQUEST, "rows = 0"),
        (
            json!({ "model": "chiang", "theta_i": 0, "rows": 1000, "cols": 1000 }),
            StatusCode::PAYLOAD_TOO_LARGE,
            "rows × cols",
        ),
        (json!({ "model": "chiang", "theta_i": 0, "lobes": ["X"] }), StatusCode::BAD_REQUEST, "`X` is not a lobe"),
        (json!({ "model": "lambertian", "theta_i": 90 }), StatusCode::BAD_REQUEST, "theta_i"),
        (json!({ "model": "chiang", "theta_i": 0, "h": -2 }), StatusCode::BAD_REQUEST, "h: expected"),
        (json!({ "model": "chiang", "theta_i": 0, "channel": "x" }), StatusCode::BAD_REQUEST, "request body"),
    ];
    for (body, status, text) in bad {
        let (s, v) = post(&app, "/api/map", body.clone()).await;
        assert_eq!(s, status, "{body}: {v}");
        assert!(error(&v).contains(text), "{body}: {}", error(&v));
    }
}

#[tokio::test]
async fn slices_per_lobe_add_up_and_integrate_like_the_map() {
    let app = app();
    let (s, v) = post(&app, "/api/slices", json!({ "model": "marschner", "theta_i": 25, "points": 61 })).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    let lobes: Vec<&str> = v["lobes"].as_array().unwrap().iter().map(|x| x.as_str().unwrap()).collect();
    assert_eq!(lobes, ["R", "TT", "TRT"]);
    for what in ["longitudinal", "azimuthal", "cone"] {
        for l in &lobes {
            let y = floats(&v[what][l]);
            assert_eq!(y.len(), 61);
            assert!(y.iter().all(|x| x.is_finite() && *x >= 0.0), "{what} {l}");
        }
    }
    // Energy: Σ_p ∫ N_p dφ ≈ ∫∫ f_s cos²θ dθ dφ = the light-side albedo (radiometry::albedo).
    let total: f64 =
        lobes.iter().map(|l| floats(&v["azimuthal"][l]).iter().sum::<f64>() * std::f64::consts::TAU / 61.0).sum();
    let m = fiberlab_scatter::build::<&str, &str>("marschner", &[]).unwrap();
    let rho =
        fiberlab_scatter::radiometry::albedo(&m, direction(25f64.to_radians(), 0.0), &Default::default()).luminance();
    assert!((total - rho).abs() < 0.02 * rho, "Σ∫N = {total} vs ρ = {rho}");
    // yan-fur separates its lobes through its `lobes` parameter.
    let (_, y) = post(
        &app,
        "/api/slices",
        json!({ "model": "yan-fur", "theta_i": 0, "points": 9, "params": { "lobes": ["r", "tt"] } }),
    )
    .await;
    assert_eq!(y["lobes"], json!(["r", "tt"]));
    let (s, w) = post(&app, "/api/slices", json!({ "model": "wood", "theta_i": 30, "points": 31 })).await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(floats(&w["incidence_plane"]).len(), 31);
    let (s, e) = post(&app, "/api/slices", json!({ "model": "chiang", "theta_i": 0, "points": 100000 })).await;
    assert_eq!(s, StatusCode::PAYLOAD_TOO_LARGE, "{e}");
}

#[tokio::test]
async fn numbers_are_the_harness_integrals() {
    let app = app();
    // Ideal diffuse fiber: ρ = albedo, exactly reciprocal, ∫pdf = 1 (closed forms).
    let (s, v) = post(
        &app,
        "/api/numbers",
        json!({ "model": "diffuse", "params": { "albedo": [0.2, 0.5, 0.9] }, "theta_i": 30 }),
    )
    .await;
    assert_eq!(s, StatusCode::OK, "{v}");
    for (got, want) in floats(&v["albedo_light"]).iter().zip([0.2, 0.5, 0.9]) {
        assert!((got - want).abs() < 2e-3, "{got} vs {want}");
    }
    assert_eq!(v["reciprocity"].as_f64().unwrap(), 0.0);
    assert!((v["pdf_integral"].as_f64().unwrap() - 1.0).abs() < 1e-3);
    // Chiang: the same library call at the live quadrature, and lobes that sum to it.
    let (_, c) = post(&app, "/api/numbers", json!({ "model": "chiang", "theta_i": 20, "phi_i": 10 })).await;
    let m = fiberlab_scatter::build::<&str, &str>("chiang", &[]).unwrap();
    let w = direction(20f64.to_radians(), 10f64.to_radians());
    let q = fiberlab_explorer::api::numbers::LIVE_QUADRATURE;
    let rho = fiberlab_scatter::radiometry::albedo(&m, w, &q);
    assert_eq!(floats(&c["albedo_light"]), vec![rho[0], rho[1], rho[2]]);
    let lobes = c["lobes"].as_array().unwrap();
    assert_eq!(lobes.len(), 4);
    let sum: f64 = lobes.iter().map(|l| floats(&l["albedo"])[1]).sum();
    assert!((sum - rho[1]).abs() < 1e-9 * rho[1]);
    assert_eq!(c["reciprocal"], m.properties().reciprocal);
    // A surface: the surface harness.
    let (s, l) =
        post(&app, "/api/numbers", json!({ "model": "lambertian", "params": { "k_d": 0.5 }, "theta_i": 30 })).await;
    assert_eq!(s, StatusCode::OK);
    assert!(floats(&l["albedo_light"]).iter().all(|x| (x - 0.5).abs() < 1e-3), "{l}");
    let (s, e) = post(&app, "/api/numbers", json!({ "model": "chiang", "theta_i": -100 })).await;
    assert_eq!(s, StatusCode::BAD_REQUEST);
    assert!(error(&e).contains("theta_i"));
}

/// A fiber table tabulating `model` (luminance-equal channels of the width-averaged f_s) at
/// its bin centres for each θ_i, std 1 % of the value plus a floor.
/// The width-averaged model averaged over the bin centred on (θ_r, φ) (degrees) of the given
/// widths by a 12 × 12 midpoint rule weighted by cos²θ_r (finer than any comparison's).
fn bin_average(model: &fiberlab_scatter::Model, wi: DVec3, tr: f64, p: f64, dt: f64, dp: f64) -> fiberlab_math::Rgb {
    let n = 12;
    let (mut sum, mut total) = (fiberlab_math::Rgb::ZERO, 0.0);
    for a in 0..n {
        let t = (tr + dt * ((a as f64 + 0.5) / n as f64 - 0.5)).to_radians();
        for b in 0..n {
            let q = (p + dp * ((b as f64 + 0.5) / n as f64 - 0.5)).to_radians();
            let w = t.cos().powi(2);
            sum += model.eval_far(wi, direction(t, q)) * w;
            total += w;
        }
    }
    sum / total
}

fn table_of(model: &fiberlab_scatter::Model, thetas: &[f64], nt: usize, np: usize) -> String {
    let mut out = String::from("lobe,theta_i,phi_i,theta_r,phi_r,f_r,f_g,f_b,std_r,std_g,std_b\n");
    for &t in thetas {
        let wi = direction(t.to_radians(), 0.0);
        for i in 0..nt {
            let tr = -90.0 + (i as f64 + 0.5) * 180.0 / nt as f64;
            for j in 0..np {
                let p = -180.0 + (j as f64 + 0.5) * 360.0 / np as f64;
                let f = bin_average(model, wi, tr, p, 180.0 / nt as f64, 360.0 / np as f64);
                out.push_str(&format!(
                    "all,{t},0,{tr},{p},{},{},{},{},{},{}\n",
                    f[0],
                    f[1],
                    f[2],
                    0.01 * f[0] + 1e-4,
                    0.01 * f[1] + 1e-4,
                    0.01 * f[2] + 1e-4
                ));
            }
        }
    }
    out
}

async fn upload(app: &axum::Router, name: &str, text: &str) -> (StatusCode, Value) {
    let (s, body) =
        send(app, "POST", &format!("/api/tables?name={name}"), Body::from(text.to_string()), "text/csv").await;
    (s, serde_json::from_str(&body).unwrap())
}

#[tokio::test]
async fn tables_load_summarise_and_report_bad_lines() {
    let app = app();
    let m = fiberlab_scatter::build::<&str, &str>("kajiya-kay", &[]).unwrap();
    let (s, v) = upload(&app, "kk.csv", &table_of(&m, &[0.0, 30.0], 6, 12)).await;
    assert_eq!(s, StatusCode::OK, "{v}");
    assert_eq!(v["kind"], "fiber");
    assert_eq!((v["bins_theta"].as_u64(), v["bins_phi"].as_u64()), (Some(6), Some(12)));
    assert_eq!(v["incidences"].as_array().unwrap().len(), 2);
    let id = v["id"].as_u64().unwrap();
    let (s, again) = get(&app, &format!("/api/tables/{id}")).await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(again, v);
    let (s, e) = get(&app, "/api/tables/999").await;
    assert_eq!(s, StatusCode::NOT_FOUND);
    assert!(error(&e).contains("no table 999"));
    let bad = "lobe,theta_i,phi_i,theta_r,phi_r,f_r,f_g,f_b,std_r,std_g,std_b\nall,0,0,1,2,x,0,0,0,0,0\n";
    let (s, e) = upload(&app, "bad.csv", bad).await;
    assert_eq!(s, StatusCode::BAD_REQUEST);
    assert!(error(&e).contains("bad.csv: line 2") && error(&e).contains("f_r"), "{}", error(&e));
    let (s, e) = get(&app, "/api/nope").await;
    assert_eq!(s, StatusCode::NOT_FOUND);
    assert!(error(&e).contains("no such API endpoint"));
}

#[tokio::test]
async fn compare_two_models_and_a_model_with_its_own_table() {
    let app = app();
    let (s, same) = post(
        &app,
        "/api/compare",
        json!({ "model": "chiang", "theta_i": 30, "rows": 18, "cols": 36, "b": { "model": "chiang" } }),
    )
    .await;
    assert_eq!(s, StatusCode::OK, "{same}");
    assert!(floats(&same["difference"]).iter().all(|&d| d == 0.0));
    assert!(same["lobes"].as_array().unwrap().iter().all(|l| l["rel_l2"].as_f64() == Some(0.0)));
    let (_, other) = post(
        &app,
        "/api/compare",
        json!({ "model": "chiang", "theta_i": 30, "rows": 18, "cols": 36, "b": { "model": "marschner" } }),
    )
    .await;
    let names: Vec<&str> = other["lobes"].as_array().unwrap().iter().map(|l| l["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["all", "R", "TT", "TRT"]);
    assert!(other["lobes"][0]["rel_l2"].as_f64().unwrap() > 0.01);
    // Against a table made from the model itself: rel. L2 is the f32 rounding of the table.
    let m = fiberlab_scatter::build::<&str, &str>("goldman", &[]).unwrap();
    let (_, t) = upload(&app, "g.csv", &table_of(&m, &[-20.0, 40.0], 10, 20)).await;
    let (s, c) = post(&app, "/api/compare", json!({ "model": "goldman", "theta_i": 35, "table": t["id"] })).await;
    assert_eq!(s, StatusCode::OK, "{c}");
    assert_eq!(c["incidence"]["index"], 1, "the incidence nearest θ_i");
    assert!(c["lobes"][0]["rel_l2"].as_f64().unwrap() < 1e-6, "{}", c["lobes"]);
    assert!(c["lobes"][0]["mc_rel_l2"].as_f64().unwrap() > 0.0);
    let errors = [
        (
            json!({ "model": "chiang", "theta_i": 0, "b": { "model": "lambertian" } }),
            StatusCode::BAD_REQUEST,
            "of one kind",
        ),
        (json!({ "model": "chiang", "theta_i": 0 }), StatusCode::BAD_REQUEST, "give one reference"),
        (json!({ "model": "chiang", "theta_i": 0, "table": 12345 }), StatusCode::NOT_FOUND, "no table"),
        (json!({ "model": "lambertian", "theta_i": 0, "table": t["id"] }), StatusCode::BAD_REQUEST, "fiber table"),
        (
            json!({ "model": "goldman", "theta_i": 0, "table": t["id"], "incidence": 5 }),
            StatusCode::BAD_REQUEST,
            "incidence 5",
        ),
    ];
    for (body, status, text) in errors {
        let (s, v) = post(&app, "/api/compare", body.clone()).await;
        assert_eq!(s, status, "{body}: {v}");
        assert!(error(&v).contains(text), "{body}: {}", error(&v));
    }
}

#[tokio::test]
async fn measure_streams_progress_and_keeps_the_table() {
    let app = app();
    let (s, ev) = events(
        &app,
        "/api/measure",
        json!({ "fiber": { "eta": 1.55, "sigma_a": 0.2 }, "theta_i": [30], "rays": 200000, "bins_theta": 18, "bins_phi": 36 }),
    )
    .await;
    assert_eq!(s, StatusCode::OK);
    assert!(ev.iter().any(|e| e["type"] == "progress"));
    let done = ev.last().unwrap();
    assert_eq!(done["type"], "done", "{ev:?}");
    assert_eq!(done["table"]["lobes"], json!(["all", "higher", "medulla", "r", "trt", "tt"]));
    let id = done["table"]["id"].as_u64().unwrap();
    // The measured table compares with a matching model: a smooth glass fiber's R lobe is
    // Fresnel-weighted specular, so against itself only the noise differs; here just shape.
    let (s, c) = post(&app, "/api/compare", json!({ "model": "marschner", "theta_i": 30, "table": id })).await;
    assert_eq!(s, StatusCode::OK, "{c}");
    let bad = [
        (json!({ "fiber": { "eta": 0.5 }, "theta_i": [0] }), StatusCode::BAD_REQUEST, "`eta`"),
        (json!({ "fiber": { "colour": 1 }, "theta_i": [0] }), StatusCode::BAD_REQUEST, "unknown fiber parameter"),
        (json!({ "theta_i": [0], "rays": 1_000_000_000u64 }), StatusCode::PAYLOAD_TOO_LARGE, "rays"),
        (json!({ "theta_i": [95] }), StatusCode::BAD_REQUEST, "theta_i"),
        (json!({ "theta_i": [] }), StatusCode::BAD_REQUEST, "theta_i (incidences) = 0"),
    ];
    for (body, status, text) in bad {
        let (s, v) = events(&app, "/api/measure", body.clone()).await;
        assert_eq!(s, status, "{body}: {v:?}");
        assert!(error(&v[0]).contains(text), "{body}: {}", error(&v[0]));
    }
}

#[tokio::test]
async fn fit_streams_steps_and_recovers_a_known_parameter() {
    let app = app();
    let truth = fiberlab_scatter::build("kajiya-kay", &[("p", "40")]).unwrap();
    let (_, t) = upload(&app, "kk40.csv", &table_of(&truth, &[0.0, 40.0], 18, 36)).await;
    let (s, ev) = events(
        &app,
        "/api/fit",
        json!({ "model": "kajiya-kay", "free": [{ "key": "p", "start": 15 }], "table": t["id"], "luminance": true }),
    )
    .await;
    assert_eq!(s, StatusCode::OK);
    assert!(ev.iter().any(|e| e["type"] == "step"), "{ev:?}");
    let done = ev.last().unwrap();
    assert_eq!(done["type"], "done", "{done}");
    let p = done["params"][0][1].as_f64().unwrap();
    assert!((p - 40.0).abs() < 0.5, "fitted p = {p}");
    let bad = [
        (
            json!({ "model": "kajiya-kay", "free": [{ "key": "p", "start": 15 }], "table": 999 }),
            StatusCode::NOT_FOUND,
            "no table",
        ),
        (
            json!({ "model": "lambertian", "free": [{ "key": "k_d", "start": 0.5 }], "table": t["id"] }),
            StatusCode::BAD_REQUEST,
            "fiber table",
        ),
        (
            json!({ "model": "kajiya-kay", "free": [{ "key": "p", "start": 15 }], "table": t["id"], "lobe": "tt" }),
            StatusCode::BAD_REQUEST,
            "no lobe `tt`",
        ),
        (
            json!({ "model": "kajiya-kay", "free": [{ "key": "p", "start": 15 }], "table": t["id"], "iterations": 0 }),
            StatusCode::BAD_REQUEST,
            "iterations = 0",
        ),
    ];
    for (body, status, text) in bad {
        let (s, v) = events(&app, "/api/fit", body.clone()).await;
        assert_eq!(s, status, "{body}: {v:?}");
        assert!(error(&v[0]).contains(text), "{body}: {}", error(&v[0]));
    }
    // A free key the model lacks fails inside the fit: an error event.
    let (s, v) = events(
        &app,
        "/api/fit",
        json!({ "model": "kajiya-kay", "free": [{ "key": "q", "start": 1 }], "table": t["id"] }),
    )
    .await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(v.last().unwrap()["type"], "error");
    assert!(v.last().unwrap()["error"].as_str().unwrap().contains("no parameter `q`"));
}

#[tokio::test]
async fn render_streams_frames_up_to_the_samples_asked_for() {
    let app = app();
    let (s, ev) =
        events(&app, "/api/render", json!({ "model": "kajiya-kay", "scene": "fiber", "size": 32, "spp": 4 })).await;
    assert_eq!(s, StatusCode::OK);
    let frames: Vec<&Value> = ev.iter().filter(|e| e["type"] == "frame").collect();
    let spp: Vec<u64> = frames.iter().map(|f| f["spp"].as_u64().unwrap()).collect();
    assert_eq!(spp, [1, 2, 4]);
    assert!(frames[0]["png"].as_str().unwrap().starts_with("data:image/png;base64,iVBOR"));
    assert_eq!(ev.last().unwrap()["type"], "done");
    let (s, ev) =
        events(&app, "/api/render", json!({ "model": "lambertian", "scene": "sphere", "size": 16, "spp": 1 })).await;
    assert_eq!(s, StatusCode::OK);
    assert_eq!(ev.iter().filter(|e| e["type"] == "frame").count(), 1);
    let bad = [
        (json!({ "model": "chiang", "scene": "sphere" }), StatusCode::BAD_REQUEST, "is a fiber model"),
        (json!({ "model": "lambertian", "scene": "fur" }), StatusCode::BAD_REQUEST, "is a surface model"),
        (json!({ "model": "chiang", "scene": "fiber", "size": 5000 }), StatusCode::PAYLOAD_TOO_LARGE, "size"),
        (json!({ "model": "chiang", "scene": "fiber", "spp": 0 }), StatusCode::BAD_REQUEST, "spp = 0"),
        (json!({ "model": "chiang", "scene": "fiber", "light": [0, 100] }), StatusCode::BAD_REQUEST, "light elevation"),
        (json!({ "model": "chiang", "scene": "moon" }), StatusCode::BAD_REQUEST, "request body"),
    ];
    for (body, status, text) in bad {
        let (s, v) = events(&app, "/api/render", body.clone()).await;
        assert_eq!(s, status, "{body}: {v:?}");
        assert!(error(&v[0]).contains(text), "{body}: {}", error(&v[0]));
    }
}

#[tokio::test]
async fn a_pages_newer_request_cancels_its_older_one() {
    let state = AppState::new(Limits::default());
    let mut headers = axum::http::HeaderMap::new();
    headers.insert("x-fiberlab-page", "p1".parse().unwrap());
    let (first, _g1) = state.supersede(&headers, "map");
    let (other_kind, _g2) = state.supersede(&headers, "slices");
    assert!(!first.is_cancelled());
    let (second, g3) = state.supersede(&headers, "map");
    assert!(first.is_cancelled() && !second.is_cancelled() && !other_kind.is_cancelled());
    drop(g3);
    assert!(second.is_cancelled(), "dropping the request cancels its work");
    // A cancelled token stops a map at its next row.
    let token = fiberlab_explorer::cancel::Token::new();
    token.cancel();
    let view: fiberlab_explorer::api::plots::View =
        serde_json::from_value(json!({ "model": "chiang", "theta_i": 0 })).unwrap();
    let e = fiberlab_explorer::api::plots::fiber_map(&view, &Limits::default(), &token).unwrap_err();
    assert_eq!(e.status, StatusCode::CONFLICT);
}

#[tokio::test]
async fn the_page_is_embedded() {
    let app = app();
    let (s, html) = send(&app, "GET", "/", Body::empty(), "text/html").await;
    assert_eq!(s, StatusCode::OK);
    assert!(html.contains("fiberlab explore") && html.contains("/assets/app.js"), "{html}");
    let (s, js) = send(&app, "GET", "/assets/app.js", Body::empty(), "").await;
    assert_eq!(s, StatusCode::OK);
    assert!(js.len() > 10_000);
    let (s, _) = send(&app, "GET", "/assets/nope.js", Body::empty(), "").await;
    assert_eq!(s, StatusCode::NOT_FOUND);
    let (s, again) = send(&app, "GET", "/some/view?m=chiang", Body::empty(), "").await;
    assert_eq!((s, again), (StatusCode::OK, html));
}
