//! The memory check shared by the command line and Python: what a command or call will hold
//! in memory, estimated before any work from its input, compared with what the process may
//! use; refused with an error naming the largest quantity and its estimate when the sum is
//! above it. The same budget bounds every input file ([`input_bound`]): a file larger than
//! the memory the process may use cannot be read into it.
//!
//! The budget is, in order: a limit set for the process ([`set_limit`]: `--memory-limit
//! SIZE` on the command line), else what the machine has available — the least of
//! `MemAvailable` of `/proc/meminfo`, the room left under the process's cgroup limit
//! (`memory.max − memory.current`, cgroup v2) and the room left under its address-space limit
//! (`ulimit -v`: the soft `Max address space` of `/proc/self/limits` minus `VmSize`). Where
//! none of these can be read (other systems), only the address-space bound applies.
//!
//! Counts are u64 and checked: an estimate that overflows 64 bits, or is more than this
//! machine's address space, is refused even with a limit set.

use std::sync::atomic::{AtomicU64, Ordering};

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
    /// A need of `bytes` for `what`.
    pub fn new(what: impl Into<String>, bytes: Option<u64>) -> Self {
        Self { what: what.into(), bytes }
    }

    /// `count` items of `each` bytes (`None` when the product overflows u64).
    pub fn items(what: impl Into<String>, count: u64, each: u64) -> Self {
        Self::new(what, count.checked_mul(each))
    }
}

/// What the estimate is compared with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Budget {
    /// A limit set for the process (`--memory-limit`).
    Flag(u64),
    /// The machine's (or the process's) available memory.
    Available(u64),
    /// Not known: only the address-space limits apply.
    Unknown,
}

impl Budget {
    /// The budget in bytes, `None` when unknown.
    #[must_use]
    pub fn bytes(self) -> Option<u64> {
        match self {
            Budget::Flag(b) | Budget::Available(b) => Some(b),
            Budget::Unknown => None,
        }
    }

    /// How the budget is named in messages: `--memory-limit 1.00 GiB` or `22.0 GiB available`.
    #[must_use]
    pub fn describe(self) -> String {
        match self {
            Budget::Flag(b) => format!("--memory-limit {}", bytes_text(b)),
            Budget::Available(b) => format!("{} available", bytes_text(b)),
            Budget::Unknown => "no known limit".into(),
        }
    }
}

/// A request refused by the memory check; the message names the largest quantity, its
/// estimate and the budget.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct MemoryError(pub String);

/// The process's limit (0: none set).
static LIMIT: AtomicU64 = AtomicU64::new(0);

/// Sets (or with `None` clears) the memory limit of the process: every later check and
/// input bound uses it instead of the available memory.
pub fn set_limit(bytes: Option<u64>) {
    LIMIT.store(bytes.unwrap_or(0), Ordering::Relaxed);
}

/// The process's budget now: the limit set, else the available memory, else unknown.
#[must_use]
pub fn budget() -> Budget {
    match LIMIT.load(Ordering::Relaxed) {
        0 => available_bytes().map_or(Budget::Unknown, Budget::Available),
        limit => Budget::Flag(limit),
    }
}

/// Checks `needs` against the process's [`budget`] (see [`check`]).
pub fn check_needs(needs: &[Need]) -> Result<(), MemoryError> {
    check(needs, budget(), usize::MAX as u64).map_err(MemoryError)
}

/// The largest input file the process reads whole: the budget, or the address space when
/// the budget is unknown.
#[must_use]
pub fn input_bound() -> u64 {
    budget().bytes().unwrap_or(usize::MAX as u64)
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

/// A memory size: a positive number of bytes, optionally with a unit `K`, `M`, `G` or `T`
/// (powers of 1024; also written `KB`/`KiB`, any case) and a fraction (`1.5G`).
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

/// What the process may still allocate: the least of the machine's `MemAvailable`, the room
/// under its cgroup limit and the room under its address-space limit (module docs); `None`
/// when none can be read.
#[must_use]
pub fn available_bytes() -> Option<u64> {
    let read = |p: &str| std::fs::read_to_string(p).ok();
    let machine = read("/proc/meminfo").and_then(|t| mem_available(&t));
    let cgroup = read("/sys/fs/cgroup/memory.max")
        .zip(read("/sys/fs/cgroup/memory.current"))
        .and_then(|(max, current)| cgroup_room(&max, &current));
    let address_space = read("/proc/self/limits")
        .zip(read("/proc/self/status"))
        .and_then(|(limits, status)| address_space_room(&limits, &status));
    [machine, cgroup, address_space].into_iter().flatten().min()
}

/// `MemAvailable:  N kB` of a `/proc/meminfo` text, in bytes.
fn mem_available(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find_map(|l| l.strip_prefix("MemAvailable:"))?;
    kilobytes(line)
}

/// `N kB` (or a bare number of bytes).
fn kilobytes(text: &str) -> Option<u64> {
    let mut words = text.split_whitespace();
    let n: u64 = words.next()?.parse().ok()?;
    match words.next() {
        Some("kB") => n.checked_mul(1024),
        None => Some(n),
        Some(_) => None,
    }
}

/// `memory.max − memory.current` of cgroup v2 (`max`: no limit).
fn cgroup_room(max: &str, current: &str) -> Option<u64> {
    let max: u64 = max.trim().parse().ok()?;
    let current: u64 = current.trim().parse().ok()?;
    Some(max.saturating_sub(current))
}

/// The soft `Max address space` of `/proc/self/limits` minus `VmSize` of
/// `/proc/self/status` (`unlimited`: no limit).
fn address_space_room(limits: &str, status: &str) -> Option<u64> {
    let line = limits.lines().find_map(|l| l.strip_prefix("Max address space"))?;
    let soft: u64 = line.split_whitespace().next()?.parse().ok()?;
    let size = status.lines().find_map(|l| l.strip_prefix("VmSize:")).and_then(kilobytes)?;
    Some(soft.saturating_sub(size))
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
    fn the_available_memory_is_the_least_of_machine_cgroup_and_address_space() {
        let text = "MemTotal:       24576000 kB\nMemFree:  9000000 kB\nMemAvailable:   23499384 kB\n";
        assert_eq!(mem_available(text), Some(23_499_384 * 1024));
        assert_eq!(mem_available("MemTotal: 1 kB\n"), None);
        assert_eq!(mem_available("MemAvailable: x kB\n"), None);
        assert_eq!(cgroup_room("1073741824\n", "73741824\n"), Some(1_000_000_000));
        assert_eq!(cgroup_room("max\n", "5\n"), None);
        let limits = "Limit                     Soft Limit           Hard Limit           Units\n\
                      Max address space         2147483648           unlimited            bytes\n";
        assert_eq!(address_space_room(limits, "Name: x\nVmSize:  1048576 kB\n"), Some(1 << 30));
        let unlimited = limits.replace("2147483648", "unlimited ");
        assert_eq!(address_space_room(&unlimited, "VmSize:  1048576 kB\n"), None);
        // On this machine at least one source is read, and it is positive.
        if cfg!(target_os = "linux") {
            assert!(available_bytes().is_some_and(|b| b > 0));
        }
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
        assert_eq!(Need::items("n", u64::MAX, 2).bytes, None);
    }
}
