//! The process's CPU time (user and system), through `getrusage(2)`: the only FFI of the
//! measurement code. Recorded beside each wall time, so a sample slowed by a neighbour (wall
//! time up, CPU time not) can be told from one that did more work.

/// User and system CPU seconds of the whole process so far (every thread), `None` where
/// `getrusage` is unavailable or fails.
pub fn process_cpu_s() -> Option<(f64, f64)> {
    #[cfg(unix)]
    {
        let mut u = std::mem::MaybeUninit::<libc::rusage>::uninit();
        // SAFETY: `u` points to writable memory of the size of `rusage`; getrusage fills it
        // completely when it returns 0 and we read it only then.
        let ok = unsafe { libc::getrusage(libc::RUSAGE_SELF, u.as_mut_ptr()) } == 0;
        if !ok {
            return None;
        }
        // SAFETY: getrusage returned 0, so it initialised the whole struct.
        let u = unsafe { u.assume_init() };
        let s = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
        Some((s(u.ru_utime), s(u.ru_stime)))
    }
    #[cfg(not(unix))]
    {
        None
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn cpu_time_grows_with_work() {
        let Some((u0, s0)) = super::process_cpu_s() else {
            return;
        };
        let mut x = 0u64;
        for i in 0..20_000_000u64 {
            x = x.wrapping_mul(31).wrapping_add(std::hint::black_box(i));
        }
        std::hint::black_box(x);
        let (u1, s1) = super::process_cpu_s().unwrap();
        assert!(u1 + s1 > u0 + s0, "{u0} {s0} → {u1} {s1}");
    }
}
