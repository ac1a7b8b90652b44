//! `fiberlab explore` against the rest of the command line: `POST /api/eval` answers what
//! `fiberlab eval` prints for the same row (bit for bit) and refuses what it refuses with its
//! message; the verb serves the page and the API on the address it prints.

use assert_cmd::Command;
use fiberlab_explorer::api::eval::{EvalRequest, evaluate};
use serde_json::json;
use std::io::{BufRead, BufReader, Read, Write};

/// `fiberlab eval` of one row: (f_r, f_g, f_b, pdf) as printed.
fn cli_eval(model: &str, params: &[&str], row: [f64; 7]) -> Result<[f64; 4], String> {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_fiberlab"));
    cmd.args(["eval", "--model", model]);
    for p in params {
        cmd.args(["--param", p]);
    }
    let input = format!("wi_x,wi_y,wi_z,wo_x,wo_y,wo_z,h\n{}\n", row.map(|x| format!("{x:?}")).join(","));
    let out = cmd.write_stdin(input).output().unwrap();
    if !out.status.success() {
        let err = String::from_utf8(out.stderr).unwrap();
        return Err(err.trim().strip_prefix("fiberlab: error: ").unwrap_or(&err).to_string());
    }
    let text = String::from_utf8(out.stdout).unwrap();
    let values: Vec<f64> = text.lines().nth(1).unwrap().split(',').skip(7).map(|x| x.parse().unwrap()).collect();
    Ok([values[0], values[1], values[2], values[3]])
}

fn api_eval(model: &str, params: serde_json::Value, row: [f64; 7]) -> Result<[f64; 4], String> {
    let request: EvalRequest = serde_json::from_value(json!({
        "model": model, "params": params, "wi": [row[0], row[1], row[2]], "wo": [row[3], row[4], row[5]], "h": row[6],
    }))
    .unwrap();
    let v = evaluate(&request).map_err(|e| e.message)?;
    let f: Vec<f64> = v["f"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    Ok([f[0], f[1], f[2], v["pdf"].as_f64().unwrap()])
}

#[test]
fn api_eval_is_what_fiberlab_eval_prints() {
    let s = 0.5f64.sqrt();
    let rows = [
        [0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        [0.3, 0.9, (1.0 - 0.81 - 0.09f64).sqrt(), -0.2, s, -(0.5 - 0.04f64).sqrt(), -0.7],
    ];
    let cases: [(&str, &[&str], serde_json::Value); 4] = [
        ("chiang", &["beta_m=0.2", "sigma_a=0.3,0.5,0.9"], json!({ "beta_m": 0.2, "sigma_a": [0.3, 0.5, 0.9] })),
        ("marschner", &["lobes=r,tt", "glints=off"], json!({ "lobes": ["r", "tt"], "glints": false })),
        ("kajiya-kay", &["p=25"], json!({ "p": 25 })),
        ("yan-fur", &[], json!({})),
    ];
    for (model, text, params) in cases {
        for row in rows {
            let cli = cli_eval(model, text, row).unwrap();
            let api = api_eval(model, params.clone(), row).unwrap();
            assert_eq!(cli.map(f64::to_bits), api.map(f64::to_bits), "{model} {row:?}: {cli:?} vs {api:?}");
        }
    }
}

#[test]
fn api_eval_refuses_with_the_command_lines_message() {
    let row = [0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    let cases: [(&str, &[&str], serde_json::Value); 3] = [
        ("chiang", &["beta_m=2"], json!({ "beta_m": 2 })),
        ("chiang", &["nope=1"], json!({ "nope": 1 })),
        ("marschner", &["lobes=r,x"], json!({ "lobes": ["r", "x"] })),
    ];
    for (model, text, params) in cases {
        let cli = cli_eval(model, text, row).unwrap_err();
        let api = api_eval(model, params, row).unwrap_err();
        // The CLI shows a list value as written (`r,x`), the API as a list (`[r, x]`).
        assert_eq!(cli.replace("r,x", "[r, x]"), api, "{model}");
    }
    // A direction that is not a unit vector: the same check and message, without the file
    // and line that only the CSV has.
    let cli = cli_eval("chiang", &[], [0.0, 2.0, 0.0, 0.0, 0.0, 1.0, 0.0]).unwrap_err();
    let api = api_eval("chiang", json!({}), [0.0, 2.0, 0.0, 0.0, 0.0, 1.0, 0.0]).unwrap_err();
    let tail = |m: &str| m.split("expected a unit vector").nth(1).unwrap().to_string();
    assert_eq!(tail(&cli), tail(&api), "{cli} | {api}");
}

#[test]
fn explore_serves_on_the_address_it_prints() {
    let bin = env!("CARGO_BIN_EXE_fiberlab");
    let mut child = std::process::Command::new(bin)
        .args(["explore", "--port", "0"])
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
    let url = line.split_whitespace().find(|w| w.starts_with("http://")).expect("an address");
    let address = url.trim_start_matches("http://").trim_end_matches('/');
    assert!(address.starts_with("127.0.0.1:"), "{line}");
    let mut stream = std::net::TcpStream::connect(address).unwrap();
    write!(stream, "GET /api/models HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n").unwrap();
    let mut answer = String::new();
    stream.read_to_string(&mut answer).unwrap();
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
    assert!(answer.contains("\"name\":\"chiang\""));
    let bad = std::process::Command::new(env!("CARGO_BIN_EXE_fiberlab"))
        .args(["explore", "--host", "not an address"])
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("not an address to listen on"));
}

/// Ctrl-C (SIGINT) while a measurement streams: the server cancels the work in flight (the
/// stream ends with a `cancelled` error event), closes the connection and exits with status 0,
/// saying so. A hang is caught by the bounded waits (the process is then killed and the test
/// fails).
#[test]
fn explore_shuts_down_gracefully_on_sigint_cancelling_work_in_flight() {
    use std::time::{Duration, Instant};
    let bound = Duration::from_secs(60);
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_fiberlab"))
        .args(["explore", "--port", "0"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
    let url = line.split_whitespace().find(|w| w.starts_with("http://")).expect("an address");
    let address = url.trim_start_matches("http://").trim_end_matches('/').to_string();
    // A measurement far longer than the test: 20M rays (the server's limit).
    let body = r#"{"fiber": {}, "theta_i": [30], "rays": 20000000, "bins_theta": 18, "bins_phi": 36}"#;
    let mut stream = std::net::TcpStream::connect(&address).unwrap();
    stream.set_read_timeout(Some(bound)).unwrap();
    write!(
        stream,
        "POST /api/measure HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\r\n{body}",
        body.len()
    )
    .unwrap();
    // Wait for the first progress event: the work is running.
    let mut reader = BufReader::new(stream);
    let mut seen = String::new();
    reader.read_line(&mut seen).unwrap();
    assert!(seen.starts_with("HTTP/1.1 200"), "{seen}");
    while !seen.contains("\"progress\"") {
        let mut l = String::new();
        assert!(reader.read_line(&mut l).unwrap() > 0, "the stream ended before any progress: {seen}");
        seen += &l;
    }
    let sent = std::process::Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap();
    assert!(sent.success());
    // The stream ends (the connection closes) with the cancellation as its last event.
    let mut rest = String::new();
    let _ = reader.read_to_string(&mut rest);
    assert!(rest.contains("\"type\":\"error\"") && rest.contains("\"status\":409"), "no cancellation event: {rest}");
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if start.elapsed() > bound {
            let _ = child.kill();
            panic!("explore did not end after SIGINT");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut err = String::new();
    child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    assert_eq!(status.code(), Some(0), "{err}");
    assert!(err.contains("fiberlab explore: stopping"), "{err}");
    assert!(err.contains("stopped (1 requests cancelled, connections closed)"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}
