//! Runtime dispatch of the hot kernels (issue 29, item 2): a kernel compiled for a wider
//! instruction set than the binary's baseline runs only where the CPU has it, so one portable
//! binary runs at the machine's width. The level is chosen once per process.
//!
//! `OCTOLUX_KERNELS` forces a level for tests and comparisons (`baseline` or `avx2`); a
//! forced level the CPU lacks is not used (the detected one is). Every level gives the same
//! results, bit for bit: a kernel's wide version does the same IEEE operations per lane as
//! its baseline (tested per kernel).
//!
//! The library's tests run at the detected level and, in a child process of the same test
//! binary, once at every lower level with that level forced (test
//! `every_level_passes_the_library_tests`), so one `cargo test` covers each level.
//!
//! Kernels so far: the BVH8's box test (`accel::bvh`), its eight boxes in one AVX register
//! instead of two SSE ones.

use serde::Serialize;
use std::sync::OnceLock;

/// The environment variable that forces a level.
pub const KERNELS_ENV: &str = "OCTOLUX_KERNELS";

/// An instruction-set level of the kernels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum KernelLevel {
    /// The binary's target as built (SSE2 on x86-64).
    Baseline,
    /// AVX2 with FMA (x86-64).
    Avx2,
}

impl KernelLevel {
    /// Every level, narrowest first.
    pub const ALL: [KernelLevel; 2] = [KernelLevel::Baseline, KernelLevel::Avx2];

    pub fn name(self) -> &'static str {
        match self {
            KernelLevel::Baseline => "baseline",
            KernelLevel::Avx2 => "avx2",
        }
    }

    fn parse(s: &str) -> Option<KernelLevel> {
        match s.trim().to_ascii_lowercase().as_str() {
            "baseline" | "sse2" => Some(KernelLevel::Baseline),
            "avx2" => Some(KernelLevel::Avx2),
            _ => None,
        }
    }
}

/// The widest level this CPU runs.
pub fn detected() -> KernelLevel {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
            return KernelLevel::Avx2;
        }
    }
    KernelLevel::Baseline
}

/// The level [`KERNELS_ENV`] asks for: `None` when unset or empty, an error naming the value
/// when it is not a level.
pub fn forced() -> Result<Option<KernelLevel>, String> {
    match std::env::var(KERNELS_ENV) {
        Ok(v) if !v.trim().is_empty() => KernelLevel::parse(&v)
            .map(Some)
            .ok_or_else(|| format!("{KERNELS_ENV}={v:?} is not a kernel level: expected `baseline` or `avx2`")),
        _ => Ok(None),
    }
}

/// The level the kernels run at: the forced one where the CPU has it, else the detected one.
pub fn level() -> KernelLevel {
    static LEVEL: OnceLock<KernelLevel> = OnceLock::new();
    *LEVEL.get_or_init(|| {
        let d = detected();
        match forced() {
            Ok(Some(f)) => f.min(d),
            _ => d,
        }
    })
}

/// One line for `--version` and reports: the level in use and the CPU's.
pub fn describe() -> String {
    let (l, d) = (level(), detected());
    if l == d {
        format!("kernels: {} (the CPU's widest)", l.name())
    } else {
        format!("kernels: {} ({KERNELS_ENV}; the CPU runs {})", l.name(), d.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The library's tests, run again by this test binary in a child process with each level
    /// below the CPU's forced (`OCTOLUX_KERNELS`), must pass there too. In the child (the
    /// variable set) this test is skipped, and on a CPU whose widest level is the baseline there
    /// is nothing to force.
    #[test]
    fn every_level_passes_the_library_tests() {
        const NAME: &str = "every_level_passes_the_library_tests";
        if std::env::var_os(KERNELS_ENV).is_some() {
            eprintln!("{KERNELS_ENV} is set: the levels are run by the parent test");
            return;
        }
        let exe = std::env::current_exe().expect("the test binary's path");
        let lower: Vec<_> = KernelLevel::ALL.into_iter().filter(|&l| l < detected()).collect();
        if lower.is_empty() {
            eprintln!("this CPU's widest level is {}: no lower level to force", detected().name());
        }
        for l in lower {
            let out = std::process::Command::new(&exe)
                .env(KERNELS_ENV, l.name())
                .args(["--skip", NAME])
                .output()
                .expect("the test binary runs again");
            let text = String::from_utf8_lossy(&out.stdout);
            let summary = text.lines().filter(|t| t.starts_with("test result:")).collect::<Vec<_>>().join(" ");
            eprintln!("{KERNELS_ENV}={}: {summary}", l.name());
            assert!(
                out.status.success() && text.contains("test result: ok"),
                "the library's tests at level {} failed:\n{}\n{}",
                l.name(),
                text.lines().filter(|t| t.contains("FAILED") || t.contains("panicked")).collect::<Vec<_>>().join("\n"),
                String::from_utf8_lossy(&out.stderr)
            );
        }
    }

    #[test]
    fn a_forced_level_is_named_back() {
        for l in KernelLevel::ALL {
            assert_eq!(KernelLevel::parse(&l.name().to_ascii_uppercase()), Some(l));
        }
        assert_eq!(KernelLevel::parse("avx512"), None);
    }
}
