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
//!
//! The first two bound resident memory, the last two address space: every mapping counts
//! against them, touched or not. A computation that factorizes also maps the buffers faer's
//! dense kernels reserve per thread ([`dense_kernel_reservation`]: 2·L3 per thread, 1.64 GB on a
//! machine with a 260 MiB L3 and a 2-thread pool, 0.2 GB with a 32 MiB L3), which are almost
//! never touched: [`MemoryLimits::for_factorization`] keeps them back from the address-space
//! bounds, and only paths that run a supernodal factorization use it ([`MemoryLimits::current`]
//! does not), so that an explicit or iterative run is not refused for buffers it never maps.

pub use crate::bytes::format_bytes;
use crate::error::{Error, Result};

/// One bound on the memory the process may still allocate (bytes), and where it comes from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MemoryBound {
    /// What the bound is, e.g. "MemAvailable" or "address-space limit (RLIMIT_AS) less VmSize".
    pub source: &'static str,
    /// Bytes still available under it.
    pub bytes: u64,
    /// Whether it bounds address space (`RLIMIT_AS`, `RLIMIT_DATA`: every mapping counts,
    /// touched or not) rather than resident memory (`MemAvailable`, a cgroup's limit).
    pub address_space: bool,
}

/// The bounds that apply to this process (those that could be read; none where /proc is
/// missing, which counts as unlimited).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct MemoryLimits {
    /// Every bound found.
    pub bounds: Vec<MemoryBound>,
    /// Bytes of dense-kernel buffers already kept back from the address-space bounds
    /// ([`for_factorization`](Self::for_factorization); 0 otherwise), named in the error's hint.
    pub dense_kernels: u64,
}

/// The hint of an [`Error::InsufficientMemory`] when the caller gives none.
pub const COARSER_MESH: &str = "use a coarser mesh";

/// A cgroup v1 limit this large means "no limit" (the kernel reports 2^63 rounded to a page).
const CGROUP_V1_UNLIMITED: u64 = 1 << 60;

impl MemoryLimits {
    /// The bounds of the running process, read now, for a computation that does not factorize
    /// (nothing kept back for the dense kernels: see [`for_factorization`](Self::for_factorization)).
    pub fn current() -> Self {
        let read = |path: &str| std::fs::read_to_string(path).ok();
        let mut bounds = Vec::new();
        if let Some(bytes) = read("/proc/meminfo").and_then(|t| meminfo_available(&t)) {
            bounds.push(MemoryBound {
                source: "MemAvailable",
                bytes,
                address_space: false,
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
                        address_space: true,
                    });
                }
            }
        }
        MemoryLimits {
            bounds,
            dense_kernels: 0,
        }
    }

    /// [`current`](Self::current) for a computation that runs a supernodal factorization: the
    /// dense kernels' buffers ([`dense_kernel_reservation`]) are kept back from the
    /// address-space bounds only. Their pages are never all touched, so `MemAvailable` and the
    /// cgroup's usage see only the part used (counted in the estimates), while VmSize and
    /// VmData (a private writable mapping) grow by all of it the moment a thread first
    /// multiplies, and a mapping refused there aborts the process.
    pub fn for_factorization() -> Self {
        Self::current().keeping_back(dense_kernel_reservation().bytes)
    }

    /// These limits with `bytes` of dense-kernel buffers kept back from the address-space
    /// bounds (see [`for_factorization`](Self::for_factorization)).
    pub fn keeping_back(mut self, bytes: u64) -> Self {
        for bound in self.bounds.iter_mut().filter(|b| b.address_space) {
            bound.bytes = bound.bytes.saturating_sub(bytes);
        }
        self.dense_kernels += bytes;
        self
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
    /// the bytes needed, the bytes available and the bound that binds, with the hint
    /// [`COARSER_MESH`].
    pub fn ensure_fits(&self, what: impl Into<String>, needed: u128) -> Result<()> {
        self.ensure_fits_or(what, needed, COARSER_MESH)
    }

    /// [`ensure_fits`](Self::ensure_fits) with the `hint` that fits the caller's path (e.g.
    /// "use the iterative solver" for a factor). When the binding bound is an address-space
    /// one that had dense-kernel buffers kept back, the hint also names them and what lowers
    /// them.
    pub fn ensure_fits_or(&self, what: impl Into<String>, needed: u128, hint: &str) -> Result<()> {
        match self.tightest() {
            Some(bound) if needed > u128::from(bound.bytes) => {
                let mut hint = hint.to_string();
                if bound.address_space && self.dense_kernels > 0 {
                    let per_thread = dense_kernel_reservation().per_thread;
                    hint.push_str(&format!(
                        "; the address-space limit must also hold the {} of buffers the \
                         factorization's dense kernels map (2·L3 = {} per thread, {} threads): \
                         raise `ulimit -v` or run on fewer threads (RAYON_NUM_THREADS)",
                        format_bytes(u128::from(self.dense_kernels)),
                        format_bytes(u128::from(per_thread)),
                        self.dense_kernels.div_ceil(per_thread.max(1))
                    ));
                }
                Err(Error::InsufficientMemory {
                    what: what.into(),
                    needed,
                    available: bound.bytes,
                    limit: self.describe(),
                    hint,
                })
            }
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
                        address_space: false,
                    });
                }
            }
        }
    }
    None
}

/// Bytes of the buffer one thread reserves on its first use of faer's x86 matrix-multiply
/// kernels (crate `private-gemm-x86`, used by every dense block of a Cholesky factorization:
/// the direct solver, the multigrid's coarse solve, the inertia check), and how many threads
/// may hold one.
///
/// Each thread's first product reserves a thread-local `Vec` of 2·L3 bytes (packed left and
/// right operands, `lib.rs` of private-gemm-x86 0.1.22), where L3 is that crate's own reading of
/// the cache: from /sys/devices/system/cpu/cpu0/cache, L3 = size₃ / n₃ · n₁ · cores, with nₖ the
/// CPUs sharing the level-k cache (`shared_cpu_list`) and cores the physical cores of
/// /proc/cpuinfo (Σ of `cpu cores` over the `physical id`s), raised to at least 2 MiB and to
/// 4 × the L2 (itself at least 256 KiB and 4 × the L1d of 32 KiB at least). The allocator maps
/// it with two more pages (measured: `mmap` of 545 267 712 B = 2 × 266 240 KiB + 8 KiB on this
/// machine, L3 = 260 MiB, 2 cores).
///
/// The buffer is almost never touched in full, so it costs address space (VmSize, VmData)
/// and not resident memory: [`MemoryLimits::for_factorization`] keeps it back from the
/// `RLIMIT_AS` and `RLIMIT_DATA` bounds only (counting it against `MemAvailable` or a cgroup
/// limit would refuse runs that fit), and only for computations that factorize: a simplicial
/// factor, the explicit step, CG's products and the assembly never call these kernels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DenseKernelReservation {
    /// The kernels' L3 size (bytes), as computed above; [`FALLBACK_L3_BYTES`] when
    /// /sys/devices/system/cpu/cpu0/cache has no level-3 cache.
    pub l3_bytes: u64,
    /// Bytes one thread maps: 2·`l3_bytes` + 8 KiB.
    pub per_thread: u64,
    /// Threads that may run the kernels: rayon's pool size (of the calling thread's pool) + 1
    /// for the calling (main) thread. Measured with `strace -f -e mmap`: a one-thread
    /// factorization maps one buffer (on the main thread), a two-thread one three (the main
    /// thread and both workers of the 2-thread pool).
    pub threads: u64,
    /// `per_thread` × `threads` (bytes); 0 off x86_64, where the kernels are not used.
    pub bytes: u64,
}

impl DenseKernelReservation {
    /// Bytes a factorization on `threads` threads maps: one buffer (the calling thread's) for
    /// one thread, all of [`bytes`](Self::bytes) for more (measured: a two-thread
    /// factorization maps the main thread's and both pool workers' buffers); 0 off x86_64.
    pub fn for_threads(&self, threads: usize) -> u64 {
        match (self.bytes, threads) {
            (0, _) => 0,
            (_, 0 | 1) => self.per_thread,
            _ => self.bytes,
        }
    }
}

/// The L3 size assumed when /sys does not give one (bytes): 256 MiB, above the L3 of all but a
/// few server parts. Too large only costs runs under a tight `RLIMIT_AS`; too small would let
/// the allocator abort one.
pub const FALLBACK_L3_BYTES: u64 = 256 << 20;

/// The dense kernels' address-space reservation of this process, read now (see
/// [`DenseKernelReservation`]). Computed once: the cache does not change while it runs.
pub fn dense_kernel_reservation() -> DenseKernelReservation {
    static L3: std::sync::OnceLock<u64> = std::sync::OnceLock::new();
    let l3_bytes = *L3.get_or_init(|| {
        let caches = sys_caches("/sys/devices/system/cpu/cpu0/cache");
        let cores = std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|t| physical_cores(&t))
            .or_else(|| {
                std::thread::available_parallelism()
                    .ok()
                    .map(|n| n.get() as u64)
            })
            .unwrap_or(1);
        gemm_l3_bytes(&caches, cores).unwrap_or(FALLBACK_L3_BYTES)
    });
    let per_thread = 2 * l3_bytes + 8192;
    let threads = rayon::current_num_threads() as u64 + 1;
    let bytes = if cfg!(target_arch = "x86_64") {
        per_thread * threads
    } else {
        0
    };
    DenseKernelReservation {
        l3_bytes,
        per_thread,
        threads,
        bytes,
    }
}

/// One data or unified cache of /sys/devices/system/cpu/cpuN/cache/indexK: its level, size
/// (bytes) and the number of CPUs sharing it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CacheLevel {
    /// 1, 2 or 3.
    pub level: u8,
    /// `size` in bytes (the file says e.g. "266240K").
    pub bytes: u64,
    /// CPUs in `shared_cpu_list` (at least 1).
    pub shared: u64,
}

/// The data and unified caches under `dir` (e.g. /sys/devices/system/cpu/cpu0/cache); empty
/// when it cannot be read.
fn sys_caches(dir: &str) -> Vec<CacheLevel> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut caches = Vec::new();
    for entry in entries.flatten() {
        let path = entry.path();
        let read = |name: &str| std::fs::read_to_string(path.join(name)).ok();
        let (Some(kind), Some(level), Some(size)) = (read("type"), read("level"), read("size"))
        else {
            continue;
        };
        if !matches!(kind.trim(), "Data" | "Unified") {
            continue;
        }
        let shared = read("shared_cpu_list")
            .map_or(1, |l| cpu_list_len(&l))
            .max(1);
        if let (Ok(level), Some(bytes)) = (level.trim().parse(), cache_size_bytes(&size)) {
            caches.push(CacheLevel {
                level,
                bytes,
                shared,
            });
        }
    }
    caches
}

/// A /sys cache `size` ("48K", "2048K", "260M", "1G" or plain bytes) in bytes.
pub fn cache_size_bytes(size: &str) -> Option<u64> {
    let size = size.trim();
    let (digits, unit) = match size.as_bytes().last()? {
        b'K' => (&size[..size.len() - 1], 1 << 10),
        b'M' => (&size[..size.len() - 1], 1 << 20),
        b'G' => (&size[..size.len() - 1], 1 << 30),
        _ => (size, 1),
    };
    digits.parse::<u64>().ok()?.checked_mul(unit)
}

/// The number of CPUs of a `shared_cpu_list` such as "0-1,4,6-7" (5); 0 if unreadable.
pub fn cpu_list_len(list: &str) -> u64 {
    list.trim()
        .split(',')
        .filter_map(|item| match item.split_once('-') {
            Some((a, b)) => Some(b.parse::<u64>().ok()?.checked_sub(a.parse().ok()?)? + 1),
            None => item.parse::<u64>().ok().map(|_| 1),
        })
        .sum()
}

/// Physical cores of a /proc/cpuinfo text: the sum of `cpu cores` over the distinct
/// `physical id`s (num_cpus' count, which private-gemm-x86 multiplies the L3 by).
pub fn physical_cores(cpuinfo: &str) -> Option<u64> {
    let mut packages = std::collections::BTreeMap::new();
    let mut package = None;
    for line in cpuinfo.lines() {
        let Some((key, value)) = line.split_once(':') else {
            continue;
        };
        match key.trim() {
            "physical id" => package = value.trim().parse::<u64>().ok(),
            "cpu cores" => {
                if let (Some(p), Ok(c)) = (package, value.trim().parse::<u64>()) {
                    packages.insert(p, c);
                }
            }
            _ => {}
        }
    }
    let cores: u64 = packages.values().sum();
    (cores > 0).then_some(cores)
}

/// private-gemm-x86's L3 size (bytes) from one CPU's caches and the physical core count:
/// size₃ / n₃ · n₁ · cores, at least 2 MiB and 4 × its L2 (size₂ / n₂ · n₁, at least 256 KiB
/// and 4 × the L1d, itself at least 32 KiB). `None` without a level-3 cache.
pub fn gemm_l3_bytes(caches: &[CacheLevel], cores: u64) -> Option<u64> {
    let find = |level: u8| caches.iter().find(|c| c.level == level);
    let l1_shared = find(1).map_or(1, |c| c.shared);
    let share = |c: &CacheLevel| c.bytes / c.shared * l1_shared;
    let l3 = find(3)?;
    let l1 = find(1).map_or(0, share).max(32 << 10);
    let l2 = find(2).map_or(0, share).max(256 << 10).max(4 * l1);
    Some((share(l3) * cores).max(2 << 20).max(4 * l2))
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

    #[test]
    fn gemm_l3_follows_private_gemm_x86() {
        assert_eq!(cache_size_bytes("266240K\n"), Some(266240 << 10));
        assert_eq!(cache_size_bytes("1G"), Some(1 << 30));
        assert_eq!(cache_size_bytes("K"), None);
        assert_eq!(cpu_list_len("0-1,4,6-7\n"), 5);
        assert_eq!(cpu_list_len("0"), 1);
        let cpuinfo = "processor\t: 0\nphysical id\t: 0\ncpu cores\t: 2\n\
                       processor\t: 1\nphysical id\t: 0\ncpu cores\t: 2\n";
        assert_eq!(physical_cores(cpuinfo), Some(2));
        let cache = |level, bytes, shared| CacheLevel {
            level,
            bytes,
            shared,
        };
        // This machine: L1d 48K (1 CPU), L2 2048K (1), L3 266240K shared by 2, 2 cores. The
        // crate's buffer was measured at 2 × 266240 KiB, so L3 must come out at 266240 KiB.
        let here = [
            cache(1, 48 << 10, 1),
            cache(2, 2048 << 10, 1),
            cache(3, 266240 << 10, 2),
        ];
        assert_eq!(gemm_l3_bytes(&here, 2), Some(266240 << 10));
        // A small L3 is raised to 4 × the L2.
        let small = [cache(2, 2048 << 10, 1), cache(3, 4 << 20, 4)];
        assert_eq!(gemm_l3_bytes(&small, 2), Some(8 << 20));
        assert_eq!(gemm_l3_bytes(&small[..1], 2), None);
    }

    #[test]
    fn reservation_is_per_thread_buffer_times_threads() {
        let r = dense_kernel_reservation();
        // Here: L3 272629760 B, 545267712 B per thread, 3 threads (the mmap sizes strace saw).
        println!("{r:?}");
        assert_eq!(r.per_thread, 2 * r.l3_bytes + 8192);
        assert_eq!(r.threads, rayon::current_num_threads() as u64 + 1);
        if cfg!(target_arch = "x86_64") {
            assert_eq!(r.bytes, r.per_thread * r.threads);
            assert_eq!(r.for_threads(1), r.per_thread);
            assert_eq!(r.for_threads(2), r.bytes);
        }
    }

    fn bound(source: &'static str, bytes: u64, address_space: bool) -> MemoryBound {
        MemoryBound {
            source,
            bytes,
            address_space,
        }
    }

    #[test]
    fn dense_kernel_buffers_are_kept_back_from_address_space_bounds_only() {
        let limits = MemoryLimits {
            bounds: vec![
                bound("MemAvailable", 8_000, false),
                bound("address-space limit", 5_000, true),
            ],
            dense_kernels: 0,
        };
        // Without a factorization the address-space bound is the tightest, whole.
        assert_eq!(limits.available(), Some(5_000));
        limits.ensure_fits("explicit", 4_900).unwrap();
        let factoring = limits.clone().keeping_back(3_000);
        assert_eq!(factoring.available(), Some(2_000));
        assert_eq!(factoring.bounds[0].bytes, 8_000, "resident bound untouched");
        let message = factoring
            .ensure_fits_or("a factor", 2_500, "use the iterative solver")
            .unwrap_err()
            .to_string();
        assert!(message.contains("use the iterative solver"), "{message}");
        assert!(message.contains("dense kernels map"), "{message}");
        assert!(message.contains("ulimit -v"), "{message}");
        // A resident bound that binds gets the caller's hint alone.
        let resident = MemoryLimits {
            bounds: vec![bound("MemAvailable", 1_000, false)],
            dense_kernels: 0,
        }
        .keeping_back(3_000);
        let message = resident
            .ensure_fits("a run", 2_000)
            .unwrap_err()
            .to_string();
        assert!(message.ends_with("use a coarser mesh"), "{message}");
    }
}
