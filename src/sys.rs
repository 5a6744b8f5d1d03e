//! Facts about the machine and the process that bound what a run may allocate, and how sizes are printed.

/// The machine's physical memory in bytes (`MemTotal` of `/proc/meminfo`), or `None` where it cannot be
/// read (then callers apply no memory limit).
#[must_use]
pub fn physical_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let kib: u64 = text.lines().find_map(|l| l.strip_prefix("MemTotal:"))?.trim().strip_suffix("kB")?.trim().parse().ok()?;
    Some(kib.saturating_mul(1024))
}

/// What bounds the memory this process may use: the smallest of the machine's physical memory, the
/// memory limit of the process's control group (cgroup v2 `memory.max`, v1 `memory.limit_in_bytes`: what
/// Slurm, systemd and containers set) and the address-space limit (`ulimit -v`, `RLIMIT_AS` as
/// `/proc/self/limits` shows it, less the address space the process already holds). `None` where none can
/// be read.
#[must_use]
pub fn memory_bound() -> Option<(u64, MemorySource)> {
    let address_space = address_space_limit().map(|limit| limit.saturating_sub(status_bytes("VmSize:").unwrap_or(0)));
    [
        physical_memory().map(|b| (b, MemorySource::Physical)),
        cgroup_memory_limit().map(|b| (b, MemorySource::Cgroup)),
        address_space.map(|b| (b, MemorySource::AddressSpace)),
    ]
    .into_iter()
    .flatten()
    .min_by_key(|&(b, _)| b)
}

/// Where a memory limit comes from (named in the error that refuses a render or a mesh).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MemorySource {
    /// The machine's physical memory.
    Physical,
    /// The control group's memory limit (a Slurm job's `--mem`, a container's limit).
    Cgroup,
    /// The address-space limit (`ulimit -v`).
    AddressSpace,
    /// `--memory-limit GB`.
    User,
}

impl MemorySource {
    /// How an error names the limit.
    #[must_use]
    pub fn describe(self) -> &'static str {
        match self {
            Self::Physical => "this machine's physical memory",
            Self::Cgroup => "the memory limit of this process's control group (the job's or container's limit)",
            Self::AddressSpace => "what the address-space limit (ulimit -v) leaves",
            Self::User => "the memory limit given",
        }
    }
}

/// `RLIMIT_AS`'s soft limit from `/proc/self/limits` ("Max address space  SOFT  HARD  bytes"), `None` when
/// unlimited or unreadable.
fn address_space_limit() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = text.lines().find_map(|l| l.strip_prefix("Max address space"))?;
    line.split_whitespace().next()?.parse().ok()
}

/// The memory limit of the process's cgroup (v2 `memory.max`, else v1 `memory.limit_in_bytes`), at the
/// path `/proc/self/cgroup` names under `/sys/fs/cgroup`, or at the mount's root (a container sees its
/// own cgroup there). `None` when unlimited ("max") or unreadable.
fn cgroup_memory_limit() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let mut candidates = Vec::new();
    for line in text.lines() {
        let mut fields = line.splitn(3, ':');
        let (Some(_), Some(controllers), Some(path)) = (fields.next(), fields.next(), fields.next()) else { continue };
        let path = path.trim_start_matches('/');
        if controllers.is_empty() {
            candidates.push(format!("/sys/fs/cgroup/{path}/memory.max"));
            candidates.push("/sys/fs/cgroup/memory.max".to_string());
        } else if controllers.split(',').any(|c| c == "memory") {
            candidates.push(format!("/sys/fs/cgroup/memory/{path}/memory.limit_in_bytes"));
            candidates.push("/sys/fs/cgroup/memory/memory.limit_in_bytes".to_string());
        }
    }
    candidates.iter().find_map(|p| std::fs::read_to_string(p).ok()?.trim().parse::<u64>().ok())
}

/// A `kB` line of `/proc/self/status` (`VmRSS:`, `VmSize:`) in bytes.
fn status_bytes(key: &str) -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    let kib: u64 = text.lines().find_map(|l| l.strip_prefix(key))?.trim().strip_suffix("kB")?.trim().parse().ok()?;
    Some(kib.saturating_mul(1024))
}

/// The memory this process holds now (resident set, `VmRSS`), 0 where it cannot be read.
#[must_use]
pub fn resident_bytes() -> u64 {
    status_bytes("VmRSS:").unwrap_or(0)
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
    fn the_bound_is_at_most_physical_memory() {
        if cfg!(target_os = "linux") {
            let (bound, _) = super::memory_bound().expect("/proc/meminfo");
            assert!(bound <= super::physical_memory().unwrap());
            assert!(super::resident_bytes() > 0);
        }
    }

    #[test]
    fn gigabytes_have_two_decimals() {
        assert_eq!(super::gb(1_234_567_890), "1.23 GB");
    }
}
