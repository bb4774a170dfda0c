//! The process's CPU time (user and system, all threads): what `OUT.json`'s
//! `timings.render_cpu_s` reports, the cost the benches divide by where the machine is shared
//! (docs/guide/benchmarks.md).

/// Seconds of CPU the process has used so far, all its threads together; `None` where the
/// platform has no such clock (outside unix) or the clock cannot be read.
pub fn process_cpu_s() -> Option<f64> {
    #[cfg(unix)]
    {
        let t = nix::time::clock_gettime(nix::time::ClockId::CLOCK_PROCESS_CPUTIME_ID).ok()?;
        Some(t.tv_sec() as f64 + t.tv_nsec() as f64 * 1e-9)
    }
    #[cfg(not(unix))]
    {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The clock runs while the process computes and does not run backwards.
    #[test]
    fn the_clock_counts_work() {
        let Some(a) = process_cpu_s() else {
            return;
        };
        let mut x = 1u64;
        let t = std::time::Instant::now();
        while t.elapsed().as_secs_f64() < 0.05 {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(std::hint::black_box(1442695040888963407));
        }
        std::hint::black_box(x);
        let b = process_cpu_s().unwrap();
        assert!(b - a >= 0.02, "50 ms of work counted as {} s of CPU", b - a);
    }
}
