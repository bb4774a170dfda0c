//! Resource budget: sizes read from the input (film and texture resolutions, photon counts,
//! mesh vertex and triangle counts) are turned into bytes and refused with a clear error
//! *before* anything is allocated, so that a hostile or mistyped number gives a message instead
//! of an aborted process ("memory allocation of ... bytes failed", "capacity overflow").
//!
//! The limit (bytes) is, in order of precedence:
//! 1. the value set with [`set_memory_limit`] (e.g. by a command-line option);
//! 2. the environment variable [`MEMORY_LIMIT_ENV`] (`OCTOLUX_MEMORY_LIMIT`), a byte count with
//!    an optional binary suffix `K`, `M`, `G` or `T` (`8G`, `512M`, `1073741824`);
//! 3. three quarters of the machine's physical memory (`MemTotal` of `/proc/meminfo` on
//!    Linux), or [`FALLBACK_LIMIT`] where that cannot be read.
//!
//! Each check covers one allocation made from one input number; the estimates per item
//! (e.g. [`FILM_BYTES_PER_PIXEL`]) are deliberately generous so that a size accepted here does
//! not abort later in the stages that follow.

use std::sync::atomic::{AtomicU64, Ordering};

/// Environment variable overriding the memory limit (bytes, optional `K`/`M`/`G`/`T` suffix).
pub const MEMORY_LIMIT_ENV: &str = "OCTOLUX_MEMORY_LIMIT";
/// Limit used when the machine's memory cannot be read (bytes): 8 GiB.
pub const FALLBACK_LIMIT: u64 = 8 << 30;
/// Bytes per film pixel during a render: the f64 RGB + weight accumulator (32 bytes), the f32
/// RGB image (12), tile buffers and the priming pass's pixel order, rounded up.
pub const FILM_BYTES_PER_PIXEL: u64 = 64;
/// Bytes per texel of a decoded texture: the decoder's f32 RGBA buffer (16) and the stored f32
/// RGB image (12), rounded up.
pub const TEXEL_BYTES: u64 = 32;
/// Bytes per mesh vertex: position, normal (f32 x 3 each), texture coordinate (f32 x 2), and
/// the loaders' temporaries, rounded up.
pub const VERTEX_BYTES: u64 = 64;
/// Bytes per triangle, for the whole way from the file to the first pass: the loader's copy
/// and its temporaries, the scene's flattened copy made while the loaded one still lives, the
/// duplicate-triangle pass and the BVH or Embree build. Measured as the peak resident size of
/// `octolux render MESH.ply --resolution 4x4 --spp 1` over grids of `T` triangles and `T/2`
/// vertices (0.5 to 4 million triangles), less a 2-triangle mesh's, less [`VERTEX_BYTES`] per
/// vertex: 150 to 185 bytes per triangle with the BVH, 133 to 142 with Embree (varying with
/// the size), rounded up. 64, the value before, let a 1 KB glTF of 262 million instanced
/// triangles through an 18 GiB limit, and the process was killed, out of memory, at 21 GiB
/// resident (issue 27). `hostile_cli.rs` (`the_mesh_budget_bounds_the_measured_peak`) measures
/// it again.
pub const TRIANGLE_BYTES: u64 = 256;
/// Bytes per stored photon: twice the 48-byte photon record (the record and the search
/// structure built over it, kd-tree or octree) plus 16. `photon/mod.rs` asserts at compile
/// time that the record still fits (this module sits below `photon`, so it does not import it).
pub const PHOTON_BYTES: u64 = 112;

/// 0 means "not set yet": the limit is derived on first use.
static LIMIT: AtomicU64 = AtomicU64::new(0);

/// A request that does not fit in the memory limit.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{what} would need {} of memory, more than the limit of {} (set {MEMORY_LIMIT_ENV} to change the limit)", format_bytes(*.bytes), format_bytes(*.limit))]
pub struct BudgetError {
    /// What was asked for, e.g. "a 32768x32768 film".
    pub what: String,
    /// Bytes it would need (`u64::MAX` when the count overflows).
    pub bytes: u64,
    /// The limit in force (bytes).
    pub limit: u64,
}

/// `1536` -> `"1.5 KiB"`; `u64::MAX` -> `"more than 16 EiB"`.
pub fn format_bytes(bytes: u64) -> String {
    if bytes == u64::MAX {
        return "more than 16 EiB".into();
    }
    const UNITS: [&str; 7] = ["bytes", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    let mut v = bytes as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{bytes} bytes")
    } else {
        format!("{v:.1} {}", UNITS[u])
    }
}

/// Parse a byte count with an optional binary suffix (`K`, `M`, `G`, `T`, optionally followed
/// by `iB` or `B`; case-insensitive). `None` for anything else, zero and overflow.
pub fn parse_bytes(text: &str) -> Option<u64> {
    let t = text.trim();
    let digits = t.find(|c: char| !c.is_ascii_digit()).unwrap_or(t.len());
    let (num, suffix) = t.split_at(digits);
    let n: u64 = num.parse().ok()?;
    let shift = match suffix.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 0,
        "k" | "kb" | "kib" => 10,
        "m" | "mb" | "mib" => 20,
        "g" | "gb" | "gib" => 30,
        "t" | "tb" | "tib" => 40,
        _ => return None,
    };
    let bytes = n.checked_mul(1u64 << shift)?;
    (bytes > 0).then_some(bytes)
}

/// Physical memory of the machine (bytes), where the system tells it.
pub fn machine_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// The limit derived without an explicit setting: the environment variable, else 3/4 of the
/// machine's memory, else [`FALLBACK_LIMIT`]. An unparsable environment value is ignored here;
/// [`limit_from_env`] reports it.
pub fn default_limit() -> u64 {
    if let Ok(Some(v)) = limit_from_env() {
        return v;
    }
    machine_memory().map(|m| m / 4 * 3).filter(|&m| m > 0).unwrap_or(FALLBACK_LIMIT)
}

/// The limit given by [`MEMORY_LIMIT_ENV`]: `Ok(None)` when unset, an error message naming the
/// variable when it is not a positive byte count.
pub fn limit_from_env() -> Result<Option<u64>, String> {
    match std::env::var(MEMORY_LIMIT_ENV) {
        Err(_) => Ok(None),
        Ok(v) => parse_bytes(&v)
            .map(Some)
            .ok_or_else(|| format!("{MEMORY_LIMIT_ENV}={v:?} is not a memory size (expected bytes with an optional K, M, G or T suffix)")),
    }
}

/// The memory limit in force (bytes).
pub fn memory_limit() -> u64 {
    match LIMIT.load(Ordering::Relaxed) {
        0 => {
            let v = default_limit();
            // Another thread may have set a limit meanwhile: keep theirs.
            let _ = LIMIT.compare_exchange(0, v, Ordering::Relaxed, Ordering::Relaxed);
            LIMIT.load(Ordering::Relaxed)
        }
        v => v,
    }
}

/// Set the memory limit for the whole process (bytes; 0 goes back to the default).
pub fn set_memory_limit(bytes: u64) {
    LIMIT.store(bytes, Ordering::Relaxed);
}

/// Refuse `bytes` for `what` when it is above the limit.
pub fn check_bytes(what: impl FnOnce() -> String, bytes: u64) -> Result<(), BudgetError> {
    let limit = memory_limit();
    if bytes > limit {
        return Err(BudgetError { what: what(), bytes, limit });
    }
    Ok(())
}

/// Refuse `count` items of `item_bytes` each (overflow counts as too much).
pub fn check_items(what: impl FnOnce() -> String, count: u64, item_bytes: u64) -> Result<(), BudgetError> {
    check_bytes(what, count.saturating_mul(item_bytes))
}

/// A film of `width` x `height` pixels (see [`FILM_BYTES_PER_PIXEL`]).
pub fn check_film(width: u64, height: u64) -> Result<(), BudgetError> {
    let pixels = width.saturating_mul(height);
    check_items(|| format!("a {width}x{height} film"), pixels, FILM_BYTES_PER_PIXEL)
}

/// A decoded image (texture, environment map) of `width` x `height` texels.
pub fn check_image(width: u64, height: u64) -> Result<(), BudgetError> {
    let texels = width.saturating_mul(height);
    check_items(|| format!("a {width}x{height} image"), texels, TEXEL_BYTES)
}

/// A mesh of `vertices` vertices and `triangles` triangles.
pub fn check_mesh(vertices: u64, triangles: u64) -> Result<(), BudgetError> {
    let v = vertices.saturating_mul(VERTEX_BYTES);
    let t = triangles.saturating_mul(TRIANGLE_BYTES);
    check_bytes(|| format!("a mesh of {vertices} vertices and {triangles} triangles"), v.saturating_add(t))
}

/// A photon map of `count` photons (see [`PHOTON_BYTES`]).
pub fn check_photons(count: u64) -> Result<(), BudgetError> {
    check_items(|| format!("{count} photons"), count, PHOTON_BYTES)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_sizes_parse() {
        assert_eq!(parse_bytes("1024"), Some(1024));
        assert_eq!(parse_bytes("8G"), Some(8 << 30));
        assert_eq!(parse_bytes("512 MiB"), Some(512 << 20));
        assert_eq!(parse_bytes("2t"), Some(2 << 40));
        assert_eq!(parse_bytes("0"), None);
        assert_eq!(parse_bytes("-5"), None);
        assert_eq!(parse_bytes("12X"), None);
        assert_eq!(parse_bytes("99999999999T"), None);
        assert_eq!(format_bytes(512), "512 bytes");
        assert_eq!(format_bytes(3 << 29), "1.5 GiB");
    }

    #[test]
    fn limits_refuse_what_does_not_fit() {
        // The process-wide limit is shared by every test of this crate: only ever raise it
        // to a huge value here, so no other test can be refused because of this one.
        set_memory_limit(1 << 50);
        assert!(check_film(1920, 1080).is_ok());
        let e = check_film(u64::MAX, 2).unwrap_err();
        assert_eq!(e.bytes, u64::MAX);
        assert!(e.to_string().contains("more than 16 EiB"), "{e}");
        let e = check_photons(1 << 60).unwrap_err();
        assert!(e.to_string().starts_with("1152921504606846976 photons would need"), "{e}");
        assert!(e.to_string().contains(MEMORY_LIMIT_ENV), "{e}");
        assert!(check_mesh(4_000_000_000, 1).is_ok());
        assert!(check_mesh(u64::MAX, 1).is_err());
    }
}
