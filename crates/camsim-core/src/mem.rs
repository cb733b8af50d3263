//! Refuse work that would not fit in memory before allocating it.

use crate::error::{CoreError, Result};

/// Memory available to this process in bytes: `MemAvailable` from /proc/meminfo on Linux,
/// otherwise a conservative 8 GiB. `CAMSIM_MEMORY_LIMIT_MIB` overrides it (tests, shared hosts).
pub fn available_bytes() -> u64 {
    if let Some(mib) = std::env::var("CAMSIM_MEMORY_LIMIT_MIB")
        .ok()
        .and_then(|s| s.parse::<u64>().ok())
    {
        return mib << 20;
    }
    if let Ok(s) = std::fs::read_to_string("/proc/meminfo") {
        for line in s.lines() {
            if let Some(rest) = line.strip_prefix("MemAvailable:") {
                if let Some(kb) = rest
                    .split_whitespace()
                    .next()
                    .and_then(|v| v.parse::<u64>().ok())
                {
                    return kb * 1024;
                }
            }
        }
    }
    8 << 30
}

/// Error if allocating `bytes` for `what` would exceed the available memory.
pub fn check_alloc(bytes: u64, what: &str) -> Result<()> {
    let avail = available_bytes();
    if bytes > avail {
        return Err(CoreError::OutOfMemory {
            what: what.to_string(),
            needed_mib: bytes >> 20,
            available_mib: avail >> 20,
        });
    }
    Ok(())
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
