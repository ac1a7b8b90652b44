//! The memory check of every verb that allocates in proportion to its input (`render`,
//! `evaluate`, `measure`, `hair generate`), run before any work: the quantities it will hold
//! are estimated from the command line and the scene file alone — the image from the camera,
//! the strands × segments from each `[[hair]]` generator or `.hair` header, their BVH, the
//! goniophotometer's bins — and the command is refused with an error naming the largest
//! quantity and its estimate when their sum is above what the machine has available.
//! `--memory-limit SIZE` replaces that figure (a smaller budget, or a larger one at the
//! user's risk). The estimators live beside what they estimate
//! ([`fiberlab_render::scene_file::SceneFile::memory_estimate`],
//! [`fiberlab_gonio::Setup::estimated_bytes`],
//! [`fiberlab_procedural::generator::HairParams::estimated_bytes`]); this module only adds them up
//! and compares.
//!
//! Counts are u64 and checked: an estimate that overflows 64 bits, or is more than this
//! machine's address space, is refused even with `--memory-limit`. The available memory is
//! `MemAvailable` of `/proc/meminfo` (Linux); where that cannot be read (other systems), there
//! is no check unless `--memory-limit` is given.
//!
//! `sample` and `eval` stream their CSV rows, so their memory does not grow with `--count` or
//! the input; they have nothing to estimate.

use fiberlab_gonio::Setup;
use fiberlab_procedural::generator::HairParams;
use fiberlab_render::scene_file::{MemoryEstimate, SceneFile};

/// A quantity a command will hold in memory: what it is, as the user wrote it, and its
/// estimated bytes (`None`: more than u64 counts).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Need {
    /// E.g. `image 512×512`.
    pub what: String,
    /// Estimated bytes.
    pub bytes: Option<u64>,
}

impl Need {
    fn new(what: impl Into<String>, bytes: Option<u64>) -> Self {
        Self { what: what.into(), bytes }
    }
}

/// `--memory-limit SIZE`, the flag of every verb that runs the check.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct MemoryLimit {
    /// Memory the command may use, e.g. 8G, 512M or a number of bytes (K, M, G, T: powers of
    /// 1024). Default: what the machine has available (MemAvailable); the command is refused
    /// before any work when its estimate is above it.
    #[arg(long = "memory-limit", value_name = "SIZE", value_parser = memory_size)]
    limit: Option<u64>,
}

impl MemoryLimit {
    /// Refuses `needs` when their sum is above the limit (see the module documentation).
    pub fn check(&self, needs: &[Need]) -> anyhow::Result<()> {
        let budget = match self.limit {
            Some(bytes) => Budget::Flag(bytes),
            None => available_bytes().map_or(Budget::Unknown, Budget::Available),
        };
        check(needs, budget, usize::MAX as u64).map_err(anyhow::Error::msg)
    }

    /// Checks what building and rendering `file` takes ([`scene_needs`]).
    pub fn check_scene(&self, file: &SceneFile) -> anyhow::Result<()> {
        self.check(&scene_needs(&file.memory_estimate()?))
    }

    /// Checks what `evaluate` of `file` with the comma-separated `models` takes
    /// ([`evaluate_needs`]: a reference and one render per model).
    pub fn check_evaluate(&self, file: &SceneFile, models: &str) -> anyhow::Result<()> {
        let renders = 1 + models.split(',').filter(|n| !n.trim().is_empty()).count() as u64;
        self.check(&evaluate_needs(&file.memory_estimate()?, renders))
    }
}

/// What the estimate is compared with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Budget {
    /// `--memory-limit`.
    Flag(u64),
    /// The machine's available memory.
    Available(u64),
    /// Not known: only the address-space limits apply.
    Unknown,
}

/// The check itself: `Err(message)` when the needs cannot be counted in u64, exceed
/// `addressable` bytes, or exceed the budget. The message names the largest need and its
/// estimate, the total when there are several, and the budget.
pub fn check(needs: &[Need], budget: Budget, addressable: u64) -> Result<(), String> {
    let Some(largest) = needs.iter().max_by_key(|n| n.bytes.map_or(u128::MAX, u128::from)) else { return Ok(()) };
    let total = needs.iter().try_fold(0u64, |sum, n| sum.checked_add(n.bytes?));
    let Some(total) = total else {
        return Err(match largest.bytes {
            None => format!("{} needs more memory than 64 bits count (more than 16 EiB)", largest.what),
            Some(_) => format!("{} need more memory than 64 bits count (more than 16 EiB)", all(needs)),
        });
    };
    let needs_text = || {
        let mut text = format!("{} needs ~ {}", largest.what, bytes_text(largest.bytes.unwrap_or(0)));
        let others: Vec<String> =
            needs.iter().filter(|n| !std::ptr::eq(*n, largest) && n.bytes.is_some_and(|b| b > 0)).map(one).collect();
        if !others.is_empty() {
            text += &format!(" (~ {} in all with {})", bytes_text(total), others.join(", "));
        }
        text
    };
    if total > addressable {
        return Err(format!("{}, more than this machine can address ({})", needs_text(), bytes_text(addressable)));
    }
    match budget {
        Budget::Flag(limit) if total > limit => {
            Err(format!("{}, above --memory-limit {}", needs_text(), bytes_text(limit)))
        }
        Budget::Available(available) if total > available => Err(format!(
            "{}, this machine has {} available; --memory-limit SIZE to override",
            needs_text(),
            bytes_text(available)
        )),
        _ => Ok(()),
    }
}

fn one(n: &Need) -> String {
    format!("{} ~ {}", n.what, n.bytes.map_or("> 16 EiB".into(), bytes_text))
}

fn all(needs: &[Need]) -> String {
    needs.iter().map(|n| n.what.as_str()).collect::<Vec<_>>().join(", ")
}

/// Bytes in binary units with three significant digits: `512 B`, `1.50 KiB`, `373 GiB`.
#[must_use]
pub fn bytes_text(bytes: u64) -> String {
    const UNITS: [&str; 6] = ["KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    if bytes < 1024 {
        return format!("{bytes} B");
    }
    let mut value = bytes as f64 / 1024.0;
    let mut unit = 0;
    while value >= 1024.0 && unit < UNITS.len() - 1 {
        value /= 1024.0;
        unit += 1;
    }
    let digits = if value >= 100.0 {
        0
    } else if value >= 10.0 {
        1
    } else {
        2
    };
    format!("{value:.digits$} {}", UNITS[unit])
}

/// The needs of building and rendering a scene: the image, then each `[[hair]]` entry's
/// strands and BVH.
#[must_use]
pub fn scene_needs(e: &MemoryEstimate) -> Vec<Need> {
    let mut needs = vec![Need::new(format!("image {}×{}", e.width, e.height), e.image_bytes)];
    for h in &e.hair {
        needs.push(Need::new(
            format!("hair {} strands × {} segments ({})", h.strands, h.segments, h.source),
            h.hair_bytes,
        ));
        needs.push(Need::new(format!("BVH of {} segments", h.segments), h.bvh_bytes));
    }
    needs
}

/// `evaluate`: the scene, and the `renders` images (the reference and one per model) kept as
/// f64 RGB (24 bytes per pixel) and laid side by side in the 8-bit grid (3 per pixel).
#[must_use]
pub fn evaluate_needs(e: &MemoryEstimate, renders: u64) -> Vec<Need> {
    let mut needs = scene_needs(e);
    let pixels = u64::from(e.width) * u64::from(e.height);
    let kept = pixels.checked_mul(24 + 3).and_then(|b| b.checked_mul(renders));
    needs.push(Need::new(format!("{renders} images {}×{} compared and in the grid", e.width, e.height), kept));
    needs
}

/// `measure`: one measurement at a time ([`Setup::estimated_bytes`]), the finished tables of
/// every incidence ([`fiberlab_gonio::RESULT_BYTES_PER_BIN`] per bin), and the figure and EXR
/// of the first (a f64 and 3 f32 per bin).
#[must_use]
pub fn measure_needs(setup: &Setup, incidences: usize, threads: usize) -> Vec<Need> {
    let bins = setup.bin_count();
    let kept = bins
        .and_then(|b| b.checked_mul(fiberlab_gonio::RESULT_BYTES_PER_BIN))
        .and_then(|b| b.checked_mul(incidences.saturating_sub(1) as u64));
    let figure = bins.and_then(|b| b.checked_mul(8 + 12));
    let what = format!("goniophotometer bins {}×{}", setup.bins_theta, setup.bins_phi);
    vec![
        Need::new(what.clone(), setup.estimated_bytes(threads)),
        Need::new(format!("{what} of {} more incidences", incidences.saturating_sub(1)), kept),
        Need::new(format!("figure and EXR of {what}"), figure),
    ]
}

/// `hair generate`: the generator's peak ([`HairParams::estimated_bytes`]; the file written
/// from it afterwards is smaller).
#[must_use]
pub fn hair_generate_needs(p: &HairParams) -> Vec<Need> {
    vec![Need::new(format!("hair {} strands × {} segments", p.strands, p.segments), p.estimated_bytes())]
}

/// `--memory-limit`'s value: a positive number of bytes, optionally with a unit `K`, `M`,
/// `G` or `T` (powers of 1024; also written `KB`/`KiB`, any case) and a fraction (`1.5G`).
pub fn memory_size(text: &str) -> Result<u64, String> {
    let expected = || format!("expected a size such as 8G, 512M or 1000000 (bytes), got `{text}`");
    let t = text.trim();
    let split = t.find(|c: char| c.is_ascii_alphabetic()).unwrap_or(t.len());
    let (number, unit) = (t[..split].trim(), t[split..].trim().to_ascii_lowercase());
    let scale: u64 = match unit.as_str() {
        "" | "b" => 1,
        "k" | "kb" | "kib" => 1 << 10,
        "m" | "mb" | "mib" => 1 << 20,
        "g" | "gb" | "gib" => 1 << 30,
        "t" | "tb" | "tib" => 1 << 40,
        _ => return Err(expected()),
    };
    if number.is_empty() || !number.chars().all(|c| c.is_ascii_digit() || c == '.') {
        return Err(expected());
    }
    let bytes = match number.parse::<u64>() {
        Ok(n) => n.checked_mul(scale).ok_or_else(|| format!("`{text}` is more than 16 EiB"))?,
        Err(_) => {
            let x: f64 = number.parse().map_err(|_| expected())?;
            let b = (x * scale as f64).round();
            if b >= u64::MAX as f64 {
                return Err(format!("`{text}` is more than 16 EiB"));
            }
            b as u64
        }
    };
    if bytes == 0 {
        return Err(format!("expected a size > 0, got `{text}`"));
    }
    Ok(bytes)
}

/// The machine's available memory: `MemAvailable` of `/proc/meminfo`, or `None`.
fn available_bytes() -> Option<u64> {
    mem_available(&std::fs::read_to_string("/proc/meminfo").ok()?)
}

/// `MemAvailable:  N kB` of a `/proc/meminfo` text, in bytes.
fn mem_available(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find_map(|l| l.strip_prefix("MemAvailable:"))?;
    let mut words = line.split_whitespace();
    let n: u64 = words.next()?.parse().ok()?;
    match words.next() {
        Some("kB") => n.checked_mul(1024),
        None => Some(n),
        Some(_) => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_in_bytes_and_binary_units() {
        assert_eq!(memory_size("1000000"), Ok(1_000_000));
        assert_eq!(memory_size("512M"), Ok(512 * 1024 * 1024));
        assert_eq!(memory_size("8G"), Ok(8 << 30));
        assert_eq!(memory_size("8g"), Ok(8 << 30));
        assert_eq!(memory_size("8GiB"), Ok(8 << 30));
        assert_eq!(memory_size("8 GB"), Ok(8 << 30));
        assert_eq!(memory_size("64k"), Ok(65_536));
        assert_eq!(memory_size("2T"), Ok(2 << 40));
        assert_eq!(memory_size("1.5G"), Ok(3 << 29));
        assert_eq!(memory_size("100B"), Ok(100));
        for bad in ["", "G", "0", "0G", "-1G", "8X", "8GG", "nan", "inf", "1e9", "8.5.1G", "0x10"] {
            assert!(memory_size(bad).is_err(), "{bad}");
        }
        assert!(memory_size("8X").unwrap_err().contains("8G, 512M"));
        assert!(memory_size("0").unwrap_err().contains("> 0"));
        assert!(memory_size("16777216T").unwrap_err().contains("16 EiB"));
        assert!(memory_size("99999999999999999999").is_err());
    }

    #[test]
    fn byte_counts_read_in_binary_units() {
        assert_eq!(bytes_text(512), "512 B");
        assert_eq!(bytes_text(1536), "1.50 KiB");
        assert_eq!(bytes_text(22 << 30), "22.0 GiB");
        // 100000 × 100000 pixels of 43 bytes: 4.3e11 B = 400.5 GiB.
        assert_eq!(bytes_text(430_000_000_000), "400 GiB");
        assert_eq!(bytes_text(u64::MAX), "16.0 EiB");
    }

    #[test]
    fn meminfo_gives_the_available_bytes() {
        let text = "MemTotal:       24576000 kB\nMemFree:  9000000 kB\nMemAvailable:   23499384 kB\n";
        assert_eq!(mem_available(text), Some(23_499_384 * 1024));
        assert_eq!(mem_available("MemTotal: 1 kB\n"), None);
        assert_eq!(mem_available("MemAvailable: x kB\n"), None);
    }

    fn need(what: &str, bytes: Option<u64>) -> Need {
        Need::new(what, bytes)
    }

    #[test]
    fn the_check_names_the_largest_quantity_its_estimate_and_the_budget() {
        let needs =
            [need("image 100000×100000", Some(430_000_000_000)), need("hair 10 strands × 2 segments", Some(1000))];
        let e = check(&needs, Budget::Available(22 << 30), u64::MAX).unwrap_err();
        assert!(e.starts_with("image 100000×100000 needs ~ 400 GiB (~ 400 GiB in all with hair 10 strands"), "{e}");
        assert!(e.ends_with("this machine has 22.0 GiB available; --memory-limit SIZE to override"), "{e}");
        let e = check(&needs, Budget::Flag(1 << 30), u64::MAX).unwrap_err();
        assert!(e.ends_with("above --memory-limit 1.00 GiB"), "{e}");
        // Enough memory, or none known: no error.
        assert_eq!(check(&needs, Budget::Flag(1 << 40), u64::MAX), Ok(()));
        assert_eq!(check(&needs, Budget::Unknown, u64::MAX), Ok(()));
        // The sum counts: two halves over the budget are refused.
        let halves = [need("a", Some(600)), need("b", Some(500))];
        assert!(check(&halves, Budget::Flag(1000), u64::MAX).unwrap_err().contains("~ 1.07 KiB in all"));
        assert_eq!(check(&halves, Budget::Flag(1100), u64::MAX), Ok(()));
        // More than 64 bits or than the address space: refused whatever the budget.
        let e = check(&[need("x", None)], Budget::Flag(u64::MAX), u64::MAX).unwrap_err();
        assert!(e.contains("x needs more memory than 64 bits count"), "{e}");
        let e = check(&[need("a", Some(u64::MAX)), need("b", Some(1))], Budget::Unknown, u64::MAX).unwrap_err();
        assert!(e.contains("a, b need more memory than 64 bits"), "{e}");
        let e = check(&[need("a", Some(5 << 30))], Budget::Unknown, u64::from(u32::MAX)).unwrap_err();
        assert!(e.contains("a needs ~ 5.00 GiB, more than this machine can address (4.00 GiB)"), "{e}");
        assert_eq!(check(&[], Budget::Flag(1), u64::MAX), Ok(()));
    }

    #[test]
    fn scene_and_measure_needs_add_their_parts() {
        let e = SceneFile::default_scene().memory_estimate().unwrap();
        let needs = scene_needs(&e);
        let what: Vec<&str> = needs.iter().map(|n| n.what.as_str()).collect();
        assert_eq!(
            what,
            ["image 512×512", "hair 20000 strands × 480000 segments (generated)", "BVH of 480000 segments"]
        );
        // 512² · 139 + 20000 · (25 · 40 + 50) + 480000 · 1200 bytes.
        let sum: u64 = needs.iter().map(|n| n.bytes.unwrap()).sum();
        assert_eq!(sum, 512 * 512 * 139 + 20_000 * 1050 + 480_000 * 1200);
        let eval = evaluate_needs(&e, 4);
        assert_eq!(eval.last().unwrap().bytes, Some(4 * 512 * 512 * 27));
        let setup = Setup { theta_i: 0.0, phi_i: 0.0, rays: 1, bins_theta: 10, bins_phi: 20, seed: 1 };
        let m = measure_needs(&setup, 3, 1);
        // One measurement in flight (576 per bin, 2 chunks of records), two more kept (288 per
        // bin each), the figure and EXR (20 per bin).
        assert_eq!(m[0].bytes, Some(200 * 576 + 2 * 65_536 * 32));
        assert_eq!(m[1].bytes, Some(2 * 200 * 288));
        assert_eq!(m[2].bytes, Some(200 * 20));
    }
}
