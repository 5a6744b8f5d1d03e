//! Facts about the machine that bound what a run may allocate, and how sizes are printed.

/// The machine's physical memory in bytes (`MemTotal` of `/proc/meminfo`), or `None` where it cannot be
/// read (then callers apply no memory limit).
#[must_use]
pub fn physical_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let kib: u64 = text.lines().find_map(|l| l.strip_prefix("MemTotal:"))?.trim().strip_suffix("kB")?.trim().parse().ok()?;
    Some(kib.saturating_mul(1024))
}

/// Bytes as `12.35 GB` (powers of 1000).
#[must_use]
pub fn gb(bytes: u64) -> String {
    format!("{:.2} GB", bytes as f64 / 1e9)
}

#[cfg(test)]
mod tests {
    #[test]
    fn physical_memory_is_read_on_linux() {
        if cfg!(target_os = "linux") {
            let m = super::physical_memory().expect("/proc/meminfo");
            assert!(m > 1 << 28, "{m}");
        }
    }

    #[test]
    fn gigabytes_have_two_decimals() {
        assert_eq!(super::gb(1_234_567_890), "1.23 GB");
    }
}
