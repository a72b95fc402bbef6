//! The process's resident memory as the kernel reports it (`VmRSS` and `VmHWM` of
//! `/proc/self/status`, Linux): `bsarap bench`'s peak and the editor's status bar; and the
//! system's available memory, which a recording must fit in. `None` where the kernel does
//! not report it.

/// Resident memory now and at its peak, in MiB.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Memory {
    pub resident_mib: f64,
    pub peak_mib: f64,
}

/// This process's [`Memory`], read now.
pub fn process_memory() -> Option<Memory> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let mib = |key: &str| -> Option<f64> {
        let kb = status.lines().find_map(|l| l.strip_prefix(key))?.split_whitespace().next()?;
        Some(kb.parse::<f64>().ok()? / 1024.0)
    };
    Some(Memory { resident_mib: mib("VmRSS:")?, peak_mib: mib("VmHWM:")? })
}

/// Memory the system can give without swapping (`MemAvailable` of `/proc/meminfo`), in MiB;
/// less where this process's control group has a limit closer (cgroup v2 `memory.max` less
/// `memory.current`: a container).
pub fn available_mib() -> Option<f64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let kb =
        info.lines().find_map(|l| l.strip_prefix("MemAvailable:"))?.split_whitespace().next()?;
    let system = kb.parse::<f64>().ok()? / 1024.0;
    let read = |name: &str| -> Option<f64> {
        let text = std::fs::read_to_string(format!("/sys/fs/cgroup/{name}")).ok()?;
        text.trim().parse::<f64>().ok() // "max": no limit
    };
    let group = read("memory.max").zip(read("memory.current")).map(|(m, c)| (m - c) / 1048576.0);
    Some(group.map_or(system, |g| g.clamp(0.0, system)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Where the kernel reports it (Linux), the peak is at least what is resident now, and this
    /// test's process holds more than a mebibyte.
    #[test]
    fn resident_memory_is_read() {
        if !std::path::Path::new("/proc/self/status").exists() {
            eprintln!("skipped: no /proc/self/status on this system");
            return;
        }
        let m = process_memory().expect("VmRSS and VmHWM in /proc/self/status");
        assert!(m.resident_mib > 1.0 && m.peak_mib >= m.resident_mib, "{m:?}");
        assert!(available_mib().expect("MemAvailable in /proc/meminfo") > 0.0);
    }
}
