//! `exr-identical A.exr B.exr`: exit 0 when the two OpenEXR files hold the same pixels bit for bit.
//!
//! Two EXR files with the same pixels need not have the same bytes: the chunks may be stored in another
//! order and the header attributes in another order or with other values (a merged image carries no
//! `fiberlab.part`). This decodes both files and compares what matters for "the same image": the layers,
//! their data windows, the channel names and sample types, and every sample's bits (f32 compared as
//! `to_bits`, so −0 ≠ +0 and NaN payloads count). Header attributes that differ are listed, not judged.

use std::process::ExitCode;

use exr::prelude::*;

type Flat = Image<Layers<AnyChannels<FlatSamples>>>;

fn decode(path: &str) -> std::result::Result<Flat, String> {
    read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_file(path)
        .map_err(|e| format!("{path}: {e}"))
}

/// The bits of every sample of a channel, with the name of its sample type.
fn bits(samples: &FlatSamples) -> (&'static str, Vec<u32>) {
    match samples {
        FlatSamples::F16(v) => ("f16", v.iter().map(|x| u32::from(x.to_bits())).collect()),
        FlatSamples::F32(v) => ("f32", v.iter().map(|x| x.to_bits()).collect()),
        FlatSamples::U32(v) => ("u32", v.clone()),
    }
}

fn compare(a_path: &str, b_path: &str) -> std::result::Result<String, String> {
    let (a, b) = (decode(a_path)?, decode(b_path)?);
    if a.layer_data.len() != b.layer_data.len() {
        return Err(format!("{} layers against {}", a.layer_data.len(), b.layer_data.len()));
    }
    let mut samples = 0usize;
    let mut channels = Vec::new();
    for (la, lb) in a.layer_data.iter().zip(b.layer_data.iter()) {
        if la.size != lb.size || la.attributes.layer_position != lb.attributes.layer_position {
            return Err(format!(
                "data window {:?} at {:?} against {:?} at {:?}",
                la.size, la.attributes.layer_position, lb.size, lb.attributes.layer_position
            ));
        }
        let names = |l: &Layer<AnyChannels<FlatSamples>>| -> Vec<String> {
            l.channel_data.list.iter().map(|c| c.name.to_string()).collect()
        };
        if names(la) != names(lb) {
            return Err(format!("channels {:?} against {:?}", names(la), names(lb)));
        }
        for (ca, cb) in la.channel_data.list.iter().zip(lb.channel_data.list.iter()) {
            let ((ta, va), (tb, vb)) = (bits(&ca.sample_data), bits(&cb.sample_data));
            if ta != tb {
                return Err(format!("channel {}: {ta} samples against {tb}", ca.name));
            }
            let differing = va.iter().zip(&vb).filter(|(x, y)| x != y).count();
            if differing > 0 || va.len() != vb.len() {
                let first = va.iter().zip(&vb).position(|(x, y)| x != y).unwrap_or(va.len().min(vb.len()));
                let (x, y) = (first % la.size.width(), first / la.size.width());
                return Err(format!(
                    "channel {}: {differing} of {} samples differ, the first at pixel ({x}, {y})",
                    ca.name,
                    va.len()
                ));
            }
            samples += va.len();
            channels.push(format!("{} ({ta})", ca.name));
        }
        for (key, value) in &la.attributes.other {
            match lb.attributes.other.get(key) {
                Some(other) if other == value => {}
                Some(other) => eprintln!("note: attribute {key}: {value:?} against {other:?}"),
                None => eprintln!("note: attribute {key} only in {a_path}"),
            }
        }
        for key in lb.attributes.other.keys().filter(|k| !la.attributes.other.contains_key(*k)) {
            eprintln!("note: attribute {key} only in {b_path}");
        }
    }
    Ok(format!("{samples} samples of {} channels bit-identical: {}", channels.len(), channels.join(", ")))
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [a, b] = args.as_slice() else {
        eprintln!("usage: exr-identical A.exr B.exr");
        return ExitCode::from(2);
    };
    match compare(a, b) {
        Ok(summary) => {
            println!("{summary}");
            ExitCode::SUCCESS
        }
        Err(why) => {
            eprintln!("exr-identical: {a} and {b} differ: {why}");
            ExitCode::FAILURE
        }
    }
}
