//! Server time of the map a slider drag re-plots: `POST /api/map` for `chiang` at 90 × 180,
//! width-averaged (the page's default), measured in-process around the handler's work
//! (`fiber_map`: building the model, the grid, the JSON value), median of 21 runs after 3
//! warm-ups, on rayon's default pool.
//!
//! Also prints the process's CPU time per map (user + system, from `/proc/self/stat`), which
//! a loaded machine inflates far less than the wall-clock time: on an idle machine of `n`
//! cores, the wall-clock time is about the CPU time over `n`.
//!
//! `cargo run --release -p fiberlab-explorer --example map_timing [MODEL] [h]`

use fiberlab_explorer::Limits;
use fiberlab_explorer::api::plots::{View, fiber_map};
use fiberlab_explorer::cancel::Token;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let model = args.get(1).map_or("chiang", String::as_str);
    let mut body = serde_json::json!({ "model": model, "theta_i": 30, "rows": 90, "cols": 180 });
    if let Some(h) = args.get(2) {
        body["h"] = serde_json::json!(h.parse::<f64>().expect("h is a number"));
    }
    let limits = Limits::default();
    let token = Token::new();
    let mut times = Vec::new();
    let mut cpu_start = 0.0;
    for k in 0..24 {
        if k == 3 {
            cpu_start = cpu_seconds();
        }
        let mut view: View = serde_json::from_value(body.clone()).expect("a valid view");
        view.theta_i = 30.0 + k as f64 * 0.5;
        let t = Instant::now();
        let answer = fiber_map(&view, &limits, &token).expect("the map");
        let text = answer.to_string();
        let ms = t.elapsed().as_secs_f64() * 1e3;
        std::hint::black_box(text);
        if k >= 3 {
            times.push(ms);
        }
    }
    let cpu_ms = (cpu_seconds() - cpu_start) * 1e3 / times.len() as f64;
    times.sort_by(f64::total_cmp);
    println!(
        "{model} 90 × 180{}: wall median {:.1} ms, min {:.1} ms, max {:.1} ms over {} runs ({} threads); CPU {cpu_ms:.1} ms per map",
        args.get(2).map_or(" width-averaged (8 offsets)".to_string(), |h| format!(" at h = {h}")),
        times[times.len() / 2],
        times[0],
        times[times.len() - 1],
        times.len(),
        rayon::current_num_threads()
    );
}

/// User + system CPU seconds of this process so far (Linux; 0 elsewhere).
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else { return 0.0 };
    // Fields after the command name (which is in parentheses): utime and stime are 14 and 15.
    let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = fields.get(11).and_then(|u| u.parse().ok()).unwrap_or(0.0)
        + fields.get(12).and_then(|s| s.parse().ok()).unwrap_or(0.0);
    ticks / 100.0
}
