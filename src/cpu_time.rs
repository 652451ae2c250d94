//! CPU time, the only FFI of the measurement code: the process's (user and system, through
//! `getrusage(2)`), recorded beside each wall time so that a sample slowed by a neighbour
//! (wall time up, CPU time not) can be told from one that did more work; and the calling
//! thread's (`clock_gettime(2)`), which the cost model's stand-in items spin on.

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

/// CPU seconds the calling thread has run so far (`CLOCK_THREAD_CPUTIME_ID`), `None` where
/// that clock is unavailable. Unlike a wall clock it stops while the thread is preempted.
pub fn thread_cpu_s() -> Option<f64> {
    #[cfg(unix)]
    {
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: `ts` is a valid, writable timespec; clock_gettime only writes it.
        let ok = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) } == 0;
        ok.then(|| ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
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

    #[test]
    fn thread_cpu_time_grows_with_work_and_not_while_asleep() {
        let Some(c0) = super::thread_cpu_s() else {
            return;
        };
        std::thread::sleep(std::time::Duration::from_millis(50));
        let c1 = super::thread_cpu_s().unwrap();
        // 50 ms asleep: far less than 50 ms of CPU time (a wall clock would read 0.05).
        assert!(c1 - c0 < 0.02, "{c0} → {c1} asleep");
        let t0 = std::time::Instant::now();
        let mut x = 0u64;
        while t0.elapsed().as_millis() < 30 {
            x = x.wrapping_mul(31).wrapping_add(std::hint::black_box(1));
        }
        std::hint::black_box(x);
        let c2 = super::thread_cpu_s().unwrap();
        assert!(c2 > c1, "{c1} → {c2} after 30 ms of work");
    }
}
