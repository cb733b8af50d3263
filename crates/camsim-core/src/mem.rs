//! Refuse work that would not fit in memory (or on disk) before allocating (or writing) it.
//!
//! One budget for every stage: a stage adds up its peak memory ([`MemoryBudget`]: image planes,
//! frames, FFT buffers, ...) before it allocates any of it, and refuses with the estimate, its
//! largest parts and the limit when it does not fit. The limit is the memory available to this
//! process: `CAMSIM_MEMORY_LIMIT_MIB` (less what the process already holds) when set, else the
//! kernel's `MemAvailable` (which already excludes it). Outputs that will be large check the free
//! space of their folder the same way ([`check_disk`]; `CAMSIM_DISK_LIMIT_MIB` caps it).

use crate::error::{CoreError, Result};
use std::path::Path;

/// A limit set in the environment variable `name`, in MiB, as bytes.
fn env_mib(name: &str) -> Option<u64> {
    std::env::var(name)
        .ok()
        .and_then(|s| s.trim().parse::<u64>().ok())
        .map(|mib| mib.saturating_mul(1 << 20))
}

/// Bytes this process holds in memory now (resident set, /proc/self/statm on Linux; 0 elsewhere).
pub fn resident_bytes() -> u64 {
    #[cfg(target_os = "linux")]
    {
        // SAFETY: sysconf only reads a configuration value.
        let page = unsafe { libc::sysconf(libc::_SC_PAGESIZE) };
        let page = if page > 0 { page as u64 } else { 4096 };
        if let Ok(s) = std::fs::read_to_string("/proc/self/statm") {
            if let Some(pages) = s
                .split_whitespace()
                .nth(1)
                .and_then(|v| v.parse::<u64>().ok())
            {
                return pages * page;
            }
        }
    }
    0
}

/// The memory this process may still allocate, bytes, and where that figure comes from.
pub fn memory_limit() -> (u64, String) {
    if let Some(limit) = env_mib("CAMSIM_MEMORY_LIMIT_MIB") {
        let held = resident_bytes();
        return (
            limit.saturating_sub(held),
            format!(
                "CAMSIM_MEMORY_LIMIT_MIB = {} less the {} MiB this process holds",
                limit >> 20,
                held >> 20
            ),
        );
    }
    if let Ok(s) = std::fs::read_to_string("/proc/meminfo") {
        for line in s.lines() {
            if let Some(rest) = line.strip_prefix("MemAvailable:") {
                if let Some(kb) = rest
                    .split_whitespace()
                    .next()
                    .and_then(|v| v.parse::<u64>().ok())
                {
                    return (
                        kb * 1024,
                        "MemAvailable in /proc/meminfo; CAMSIM_MEMORY_LIMIT_MIB sets another limit"
                            .into(),
                    );
                }
            }
        }
    }
    (
        8 << 30,
        "a default of 8 GiB on a system that does not report its free memory; CAMSIM_MEMORY_LIMIT_MIB sets another limit".into(),
    )
}

/// Memory available to this process in bytes ([`memory_limit`]).
pub fn available_bytes() -> u64 {
    memory_limit().0
}

/// The peak memory of one stage, item by item, checked against [`memory_limit`] before the
/// stage allocates any of it.
///
/// ```
/// use camsim_core::mem::MemoryBudget;
/// let (rows, cols, frames) = (3000usize, 4000usize, 8usize);
/// let budget = MemoryBudget::new("the sensor stage")
///     .f32s("the electron image", rows * cols)
///     .bytes("the raw frames (16 bits)", (rows * cols * 2 * frames) as u64);
/// assert_eq!(budget.total_bytes(), (rows * cols * (4 + 16)) as u64);
/// budget.check("use a smaller sensor window or fewer frames").unwrap();
/// ```
#[derive(Debug, Clone)]
pub struct MemoryBudget {
    what: String,
    items: Vec<(String, u64)>,
}

impl MemoryBudget {
    /// An empty budget for `what` (a stage: "the sensor stage").
    pub fn new(what: impl Into<String>) -> Self {
        MemoryBudget {
            what: what.into(),
            items: Vec::new(),
        }
    }

    /// Add `bytes` for `item`.
    pub fn bytes(mut self, item: impl Into<String>, bytes: u64) -> Self {
        self.items.push((item.into(), bytes));
        self
    }

    /// Add `count` f32 values (4 bytes each) for `item`.
    pub fn f32s(self, item: impl Into<String>, count: usize) -> Self {
        self.bytes(item, (count as u64).saturating_mul(4))
    }

    /// The estimate, bytes.
    pub fn total_bytes(&self) -> u64 {
        self.items
            .iter()
            .fold(0u64, |a, (_, b)| a.saturating_add(*b))
    }

    /// Refuse when the estimate exceeds [`memory_limit`]; the error names the stage, the
    /// estimate, its three largest items, the limit and `advice` (what to change).
    pub fn check(&self, advice: &str) -> Result<()> {
        let needed = self.total_bytes();
        let (avail, limit) = memory_limit();
        if needed <= avail {
            return Ok(());
        }
        let mut items = self.items.clone();
        items.sort_by_key(|i| std::cmp::Reverse(i.1));
        let parts: Vec<String> = items
            .iter()
            .filter(|(_, b)| *b >= 1 << 20)
            .take(3)
            .map(|(n, b)| format!("{n} {} MiB", b >> 20))
            .collect();
        let breakdown = if parts.len() > 1 {
            format!(" ({})", parts.join(", "))
        } else {
            String::new()
        };
        Err(CoreError::OutOfMemory(format!(
            "{} needs about {} MiB of memory{breakdown}, but {} MiB is available ({limit}); {advice}",
            self.what,
            needed >> 20,
            avail >> 20
        )))
    }
}

/// Bytes of image blocks a streaming writer assembles before compressing them as one batch
/// (camsim-io's OpenEXR writer; it holds two batches at most, one compressed and one being
/// assembled). Stage budgets count it for the files they write.
pub const WRITE_BATCH_BYTES: usize = 64 << 20;

/// Error if allocating `bytes` for `what` would exceed the available memory (a budget of one
/// item).
pub fn check_alloc(bytes: u64, what: &str) -> Result<()> {
    MemoryBudget::new(what)
        .bytes(what, bytes)
        .check("reduce the image size or the number of bands")
}

/// Free space, bytes, of the file system holding `dir` (its nearest existing ancestor), capped by
/// `CAMSIM_DISK_LIMIT_MIB` when set; `None` where it cannot be asked. The flag says whether the
/// environment's cap applied.
pub fn free_disk_bytes(dir: &Path) -> Option<(u64, bool)> {
    let cap = env_mib("CAMSIM_DISK_LIMIT_MIB");
    let free = statvfs_free(dir);
    match (free, cap) {
        (Some(f), Some(c)) => Some((f.min(c), c <= f)),
        (None, Some(c)) => Some((c, true)),
        (Some(f), None) => Some((f, false)),
        (None, None) => None,
    }
}

#[cfg(target_os = "linux")]
fn statvfs_free(dir: &Path) -> Option<u64> {
    use std::os::unix::ffi::OsStrExt;
    let mut p = dir;
    while !p.as_os_str().is_empty() && !p.exists() {
        p = p.parent()?;
    }
    let p = if p.as_os_str().is_empty() {
        Path::new(".")
    } else {
        p
    };
    let c = std::ffi::CString::new(p.as_os_str().as_bytes()).ok()?;
    // SAFETY: `c` is a valid NUL-terminated path and `st` a properly sized out-parameter.
    let mut st: libc::statvfs = unsafe { std::mem::zeroed() };
    if unsafe { libc::statvfs(c.as_ptr(), &mut st) } != 0 {
        return None;
    }
    Some((st.f_bavail as u64).saturating_mul(st.f_frsize as u64))
}

#[cfg(not(target_os = "linux"))]
fn statvfs_free(_dir: &Path) -> Option<u64> {
    None
}

/// Refuse to write about `bytes` of output for `what` into folder `dir` when its file system has
/// less free space (see [`free_disk_bytes`]); where free space cannot be asked, accept.
pub fn check_disk(dir: &Path, bytes: u64, what: &str) -> Result<()> {
    let Some((free, capped)) = free_disk_bytes(dir) else {
        return Ok(());
    };
    if bytes <= free {
        return Ok(());
    }
    let limit = if capped {
        " (CAMSIM_DISK_LIMIT_MIB)"
    } else {
        ""
    };
    Err(CoreError::OutOfDisk(format!(
        "{what} needs about {} MiB on disk, but {} has {} MiB free{limit}; free some space or choose another output folder",
        bytes >> 20,
        dir.display(),
        free >> 20
    )))
}

/// The most worker threads worth starting: 4 per core (`std::thread::available_parallelism`).
/// More only cost memory (a stack each) and start-up time; output never depends on the count.
pub fn thread_limit() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get()) * 4
}

/// CPU time this process has used so far, `(user_s, system_s)`, from /proc/self/stat on Linux
/// (`(0, 0)` elsewhere). Benchmarks report it beside wall time: on a shared machine CPU time per
/// thread estimates the wall time of an unloaded run.
pub fn process_cpu_s() -> (f64, f64) {
    #[cfg(target_os = "linux")]
    {
        // SAFETY: sysconf only reads a configuration value.
        let ticks = unsafe { libc::sysconf(libc::_SC_CLK_TCK) };
        let ticks = if ticks > 0 { ticks as f64 } else { 100.0 };
        let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
        // Fields after the command name (which may hold spaces) closed by ')': utime is the 12th,
        // stime the 13th (proc(5)).
        let f: Vec<f64> = stat
            .rsplit(')')
            .next()
            .unwrap_or("")
            .split_whitespace()
            .map(|v| v.parse().unwrap_or(0.0))
            .collect();
        if f.len() > 12 {
            return (f[11] / ticks, f[12] / ticks);
        }
    }
    (0.0, 0.0)
}

/// Below this size a buffer is left to the allocator as it is (huge pages would not pay).
const HUGE_PAGE_MIN_BYTES: usize = 8 << 20;

/// A zero-filled `Vec<f32>` of `n` samples for a full-size image plane or cube.
///
/// Large zeroed allocations come from the kernel as untouched pages, each faulted in (and
/// zeroed) on first write: 4 KiB at a time, ~390 000 faults for a 1.6 GB spectral image, which
/// cost the optics stage ~0.8 s of system time. On Linux the buffer is advised as a candidate for
/// transparent huge pages (`madvise(MADV_HUGEPAGE)`, see the kernel's
/// Documentation/admin-guide/mm/transhuge.rst), so it faults in 2 MiB at a time wherever the
/// kernel's THP mode is `always` or `madvise`. The advice changes nothing but speed; where it is
/// refused the buffer is the same.
pub fn zeroed_f32(n: usize) -> Vec<f32> {
    let mut v = vec![0.0f32; n];
    advise_huge_pages(&mut v);
    v
}

#[cfg(target_os = "linux")]
fn advise_huge_pages(v: &mut [f32]) {
    const HUGE: usize = 2 << 20;
    let bytes = std::mem::size_of_val(v);
    if bytes < HUGE_PAGE_MIN_BYTES {
        return;
    }
    // The 2 MiB-aligned part of the buffer.
    let start = v.as_mut_ptr() as usize;
    let lo = start.next_multiple_of(HUGE);
    let hi = (start + bytes) / HUGE * HUGE;
    if hi > lo {
        // SAFETY: [lo, hi) lies inside `v`'s allocation, which we borrow mutably; MADV_HUGEPAGE
        // only changes how the kernel backs the pages, never their contents.
        unsafe {
            libc::madvise(lo as *mut libc::c_void, hi - lo, libc::MADV_HUGEPAGE);
        }
    }
}

#[cfg(not(target_os = "linux"))]
fn advise_huge_pages(_v: &mut [f32]) {}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 25 item 6: the refusal names the estimate, its largest parts and the limit.
    #[test]
    fn a_budget_over_the_limit_is_refused_with_its_parts_and_the_limit() {
        let b = MemoryBudget::new("the sensor stage")
            .f32s("the electron image", 1 << 40)
            .bytes("the raw frames", 1 << 41)
            .bytes("a row buffer", 100);
        assert_eq!(b.total_bytes(), (1u64 << 42) + (1 << 41) + 100);
        let e = b.check("use a smaller window").unwrap_err().to_string();
        assert!(
            e.starts_with("the sensor stage needs about 6291456 MiB of memory (the electron image 4194304 MiB, the raw frames 2097152 MiB)"),
            "{e}"
        );
        assert!(
            e.contains("use a smaller window") && e.contains("available"),
            "{e}"
        );
        assert!(MemoryBudget::new("x")
            .bytes("y", 1 << 20)
            .check("z")
            .is_ok());
        assert!(check_alloc(u64::MAX, "everything").is_err());
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn a_write_larger_than_the_free_disk_space_is_refused() {
        let dir = std::env::temp_dir();
        let (free, _) = free_disk_bytes(&dir).expect("statvfs works on Linux");
        assert!(check_disk(&dir, 1 << 20, "a small file").is_ok() || free < 1 << 20);
        let e = check_disk(&dir.join("not/yet/made"), u64::MAX, "the series")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("the series needs about") && e.contains("free"),
            "{e}"
        );
    }
}
