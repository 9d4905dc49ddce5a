//! Memory the process may still take, so that a computation too large for the machine stops
//! with an [`Error::InsufficientMemory`] before it allocates instead of being aborted by the
//! allocator halfway. (The peak a finite element run will need is estimated in tetfem's own
//! `memory` module, from mesh sizes.)
//!
//! The available memory is the least of what the kernel would grant: `MemAvailable`
//! (/proc/meminfo), the cgroup's limit less its usage (v2 `memory.max − memory.current`, v1
//! `memory.limit_in_bytes − memory.usage_in_bytes`), and the resource limits of
//! /proc/self/limits less what the process already holds (`RLIMIT_AS` − `VmSize`,
//! `RLIMIT_DATA` − `VmData`, from /proc/self/status). Read from /proc and /sys only: no libc.

use crate::error::{Error, Result};

/// One bound on the memory the process may still allocate (bytes), and where it comes from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MemoryBound {
    /// What the bound is, e.g. "MemAvailable" or "address-space limit (RLIMIT_AS) less VmSize".
    pub source: &'static str,
    /// Bytes still available under it.
    pub bytes: u64,
}

/// The bounds that apply to this process (those that could be read; none where /proc is
/// missing, which counts as unlimited).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct MemoryLimits {
    /// Every bound found.
    pub bounds: Vec<MemoryBound>,
}

/// A cgroup v1 limit this large means "no limit" (the kernel reports 2^63 rounded to a page).
const CGROUP_V1_UNLIMITED: u64 = 1 << 60;

impl MemoryLimits {
    /// The bounds of the running process, read now.
    pub fn current() -> Self {
        let read = |path: &str| std::fs::read_to_string(path).ok();
        let mut bounds = Vec::new();
        if let Some(bytes) = read("/proc/meminfo").and_then(|t| meminfo_available(&t)) {
            bounds.push(MemoryBound {
                source: "MemAvailable",
                bytes,
            });
        }
        if let Some(bound) = read("/proc/self/cgroup").and_then(|t| cgroup_bound(&t)) {
            bounds.push(bound);
        }
        let status = read("/proc/self/status").unwrap_or_default();
        if let Some(limits) = read("/proc/self/limits") {
            for (limit_name, held_key, source) in [
                (
                    "Max address space",
                    "VmSize:",
                    "address-space limit (RLIMIT_AS) less VmSize",
                ),
                (
                    "Max data size",
                    "VmData:",
                    "data limit (RLIMIT_DATA) less VmData",
                ),
            ] {
                if let Some(limit) = soft_limit(&limits, limit_name) {
                    let held = status_bytes(&status, held_key).unwrap_or(0);
                    bounds.push(MemoryBound {
                        source,
                        bytes: limit.saturating_sub(held),
                    });
                }
            }
        }
        MemoryLimits { bounds }
    }

    /// The tightest bound (`None`: unlimited).
    pub fn tightest(&self) -> Option<&MemoryBound> {
        self.bounds.iter().min_by_key(|b| b.bytes)
    }

    /// Bytes available: the least of the bounds (`None`: unlimited).
    pub fn available(&self) -> Option<u64> {
        self.tightest().map(|b| b.bytes)
    }

    /// `Ok` if `needed` bytes fit, otherwise [`Error::InsufficientMemory`] naming `what`,
    /// the bytes needed, the bytes available and the bound that binds.
    pub fn ensure_fits(&self, what: impl Into<String>, needed: u128) -> Result<()> {
        match self.tightest() {
            Some(bound) if needed > u128::from(bound.bytes) => Err(Error::InsufficientMemory {
                what: what.into(),
                needed,
                available: bound.bytes,
                limit: self.describe(),
            }),
            _ => Ok(()),
        }
    }

    /// Every bound in GB, the tightest first, e.g. "address-space limit (RLIMIT_AS) less
    /// VmSize 9.87 GB; MemAvailable 24.1 GB".
    pub fn describe(&self) -> String {
        let mut bounds: Vec<&MemoryBound> = self.bounds.iter().collect();
        bounds.sort_by_key(|b| b.bytes);
        bounds
            .iter()
            .map(|b| format!("{} {}", b.source, format_bytes(b.bytes as u128)))
            .collect::<Vec<_>>()
            .join("; ")
    }
}

/// Bytes in GB with three significant digits, e.g. "8.29 GB" (MB below 1 GB).
pub fn format_bytes(bytes: u128) -> String {
    let b = bytes as f64;
    if b >= 1e9 {
        format!("{:.3} GB", b * 1e-9)
    } else {
        format!("{:.1} MB", b * 1e-6)
    }
}

/// `MemAvailable` of a /proc/meminfo text, in bytes.
pub fn meminfo_available(meminfo: &str) -> Option<u64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemAvailable:"))?;
    kib_field(line)
}

/// A `Key:   123 kB` line of /proc/self/status, in bytes.
pub fn status_bytes(status: &str, key: &str) -> Option<u64> {
    kib_field(status.lines().find(|l| l.starts_with(key))?)
}

fn kib_field(line: &str) -> Option<u64> {
    line.split_whitespace()
        .nth(1)?
        .parse::<u64>()
        .ok()?
        .checked_mul(1024)
}

/// The soft limit of the /proc/self/limits row `name` (e.g. "Max address space"), in bytes;
/// `None` when unlimited or absent.
pub fn soft_limit(limits: &str, name: &str) -> Option<u64> {
    let rest = limits.lines().find_map(|l| l.strip_prefix(name))?;
    rest.split_whitespace().next()?.parse().ok()
}

/// The memory cgroup's limit less its usage, from the /proc/self/cgroup text: v2 (`0::path`,
/// `memory.max`, `memory.current`) or v1 (`N:memory:path`, `memory.limit_in_bytes`,
/// `memory.usage_in_bytes`). The cgroup's own directory is tried first, then the mount's root
/// (inside a container the root is the container's cgroup). `None` when unlimited or unreadable.
fn cgroup_bound(cgroup: &str) -> Option<MemoryBound> {
    let read =
        |path: String| -> Option<u64> { std::fs::read_to_string(path).ok()?.trim().parse().ok() };
    for line in cgroup.lines() {
        let mut fields = line.splitn(3, ':');
        let (_, controllers, path) = (fields.next()?, fields.next()?, fields.next()?);
        let path = path.trim_end_matches('/');
        let (roots, max, current, source): (&[&str], _, _, _) = if controllers.is_empty() {
            (
                &["/sys/fs/cgroup", "/sys/fs/cgroup/unified"],
                "memory.max",
                "memory.current",
                "cgroup limit (memory.max) less memory.current",
            )
        } else if controllers.split(',').any(|c| c == "memory") {
            (
                &["/sys/fs/cgroup/memory"],
                "memory.limit_in_bytes",
                "memory.usage_in_bytes",
                "cgroup limit (memory.limit_in_bytes) less usage",
            )
        } else {
            continue;
        };
        for root in roots {
            for dir in [format!("{root}{path}"), root.to_string()] {
                // "max" (v2, no limit) does not parse and is skipped.
                if let (Some(limit), Some(used)) = (
                    read(format!("{dir}/{max}")),
                    read(format!("{dir}/{current}")),
                ) && limit < CGROUP_V1_UNLIMITED
                {
                    return Some(MemoryBound {
                        source,
                        bytes: limit.saturating_sub(used),
                    });
                }
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_proc_texts() {
        let meminfo =
            "MemTotal:       24684084 kB\nMemFree:  100 kB\nMemAvailable:   24055636 kB\n";
        assert_eq!(meminfo_available(meminfo), Some(24055636 * 1024));
        let limits = "Limit                     Soft Limit           Hard Limit           Units     \n\
                      Max data size             unlimited            unlimited            bytes     \n\
                      Max address space         10000000000          unlimited            bytes     \n";
        assert_eq!(
            soft_limit(limits, "Max address space"),
            Some(10_000_000_000)
        );
        assert_eq!(soft_limit(limits, "Max data size"), None);
        let status = "Name:\ttetfem\nVmSize:\t  123456 kB\nVmData:\t    2048 kB\n";
        assert_eq!(status_bytes(status, "VmSize:"), Some(123456 * 1024));
        assert_eq!(status_bytes(status, "VmData:"), Some(2048 * 1024));
    }
}
