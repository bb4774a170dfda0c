//! Runtime dispatch of the hot kernels (issue 29, item 2): a kernel compiled for a wider
//! instruction set than the binary's baseline runs only where the CPU has it, so one portable
//! binary runs at the machine's width. The level is chosen once per process.
//!
//! `OCTOLUX_KERNELS` forces a level for tests and comparisons (`baseline` or `avx2`); a
//! forced level the CPU lacks is not used (the detected one is). Every level gives the same
//! results, bit for bit: a kernel's wide version does the same IEEE operations per lane as
//! its baseline (tested per kernel).
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
