//! Facts about the machine and this process, read in one place (from `/proc` and `/etc` on
//! Linux; elsewhere each falls back to a neutral value rather than failing).

/// Logical CPUs this process may use (`std::thread::available_parallelism`, 1 if unknown).
pub fn available_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// OS threads of the whole process right now (`Threads:` of /proc/self/status; `None` where that
/// file does not exist). Embree and rayon both own pools: a benchmark records this number so it
/// measures what it says.
pub fn os_thread_count() -> Option<usize> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    status
        .lines()
        .find_map(|l| l.strip_prefix("Threads:"))
        .and_then(|v| v.trim().parse().ok())
}

/// This machine's host name (empty if unknown).
pub fn hostname() -> String {
    read("/proc/sys/kernel/hostname").trim().to_string()
}

/// The CPU's model name from /proc/cpuinfo (`unknown` if absent).
pub fn cpu_model() -> String {
    read("/proc/cpuinfo")
        .lines()
        .find_map(|l| {
            l.strip_prefix("model name")
                .and_then(|r| r.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| "unknown".into())
}

/// Total memory in GiB, rounded to 0.1 (0 if unknown).
pub fn memory_gib() -> f64 {
    read("/proc/meminfo")
        .lines()
        .find_map(|l| l.strip_prefix("MemTotal:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
        .map_or(0.0, |kb| (kb / 1024.0 / 1024.0 * 10.0).round() / 10.0)
}

/// The distribution's pretty name (`PRETTY_NAME` of /etc/os-release), else the OS family.
pub fn os_name() -> String {
    read("/etc/os-release")
        .lines()
        .find_map(|l| l.strip_prefix("PRETTY_NAME="))
        .map(|v| v.trim_matches('"').to_string())
        .unwrap_or_else(|| std::env::consts::OS.to_string())
}

/// The kernel release (`uname -r`; empty if unknown).
pub fn kernel() -> String {
    read("/proc/sys/kernel/osrelease").trim().to_string()
}

/// The 1-, 5- and 15-minute load averages (/proc/loadavg; `None` where it does not exist).
pub fn load_average() -> Option<[f64; 3]> {
    let text = load_average_text();
    let mut it = text.split_whitespace().map(|v| v.parse::<f64>().ok());
    Some([it.next()??, it.next()??, it.next()??])
}

/// The three load averages as the kernel writes them (`0.52 0.61 0.70`; empty where
/// /proc/loadavg does not exist): the one reader of that file.
pub fn load_average_text() -> String {
    let text = read("/proc/loadavg");
    text.split_whitespace()
        .take(3)
        .collect::<Vec<_>>()
        .join(" ")
}

fn read(path: &str) -> String {
    std::fs::read_to_string(path).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    #[test]
    fn facts_are_plausible() {
        assert!(super::available_threads() >= 1);
        assert!(super::memory_gib() >= 0.0);
        if cfg!(target_os = "linux") {
            assert!(super::os_thread_count().is_some_and(|n| n >= 1));
            assert!(!super::kernel().is_empty());
        }
    }
}
