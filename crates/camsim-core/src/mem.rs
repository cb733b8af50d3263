//! Refuse work that would not fit in memory before allocating it.

use crate::error::{CoreError, Result};

/// Memory available to this process in bytes: `MemAvailable` from /proc/meminfo on Linux,
/// otherwise a conservative 8 GiB. `CAMSIM_MEMORY_LIMIT_MIB` overrides it (tests, shared hosts).
pub fn available_bytes() -> u64 {
    if let Some(mib) = std::env::var("CAMSIM_MEMORY_LIMIT_MIB").ok().and_then(|s| s.parse::<u64>().ok()) {
        return mib << 20;
    }
    if let Ok(s) = std::fs::read_to_string("/proc/meminfo") {
        for line in s.lines() {
            if let Some(rest) = line.strip_prefix("MemAvailable:") {
                if let Some(kb) = rest.split_whitespace().next().and_then(|v| v.parse::<u64>().ok()) {
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
        return Err(CoreError::OutOfMemory { what: what.to_string(), needed_mib: bytes >> 20, available_mib: avail >> 20 });
    }
    Ok(())
}
