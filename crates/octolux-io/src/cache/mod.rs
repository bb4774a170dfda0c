//! Baked lighting files (`.oxc`, issue 13): the `octree` integrator's global and caustic
//! octrees with their settings, and the fingerprint of the scene they were baked in. The byte
//! layout is tabled in docs/guide/baking.md; in short (all integers little-endian):
//!
//! ```text
//! header   magic "OXCACHE\0" (8) | format version u32 | reserved u32 = 0 | body length u64
//! body     fingerprint: geometry u64, materials u64, emitters u64
//!          meta: u32 length + JSON {octolux_version, scene, backend, settings, stats}
//!          trees u8 (bit 0: global, always; bit 1: caustic; bit 2: free-space), then per tree
//!          in that order:
//!            u32 length + JSON {stats}; origin 3 x f32; size f32; depth limit u32;
//!            nodes: node count u32, 2-bit kinds, u32 length + the valid leaves' photon
//!              counts as varints (`nodes.rs`);
//!            storage u8 (0 compressed, 1 full), value count u32, values
//!              (36 bytes, or 54 f32: six column-major 3x3 matrices);
//!            facing count u32, facing bytes;
//!            anchors u8 (0: means only, 1: means and samples), anchor count u32, anchors
//!              (per valid leaf: the mean (position 3 x u8, normal 3 x i8), then with 1
//!              4 x (position 3 x u8, incident direction 3 x i8));
//!            atmosphere u8 (0: none, 1: diffused values follow; `atmosphere.rs`):
//!              filled count u32, filled bits (one byte per leaf, depth-first),
//!              storage u8 (the tree's), value count u32, values (as the leaves'; a
//!              compressed free-space leaf as SH coefficients, version 8),
//!              anchor count u32 (0 or the value count), anchors (3 x u8 each, version 9)
//! trailer  CRC-32 (IEEE, zlib's) of every byte before it, u32
//! ```
//!
//! Version 7 (issue 26, item 3: compact leaves) stores the nodes as their kinds and the valid
//! leaves' photon counts (8 bytes per node before), the leak test's sampled photons only when
//! the bake's leak test or its volumetric values need them (`bake --volume`; 30 bytes per valid
//! leaf before, 6 without them), and a bake writes the volumetric values only with
//! `--volume`. Version 8 stores a compressed atmospheric leaf with all six matrices filled as
//! the SH coefficients of its free-space light (`caches::octree` `atmosphere.rs`). Version 9
//! holds the volumetric solution as a third tree, the free-space tree (`caches::octree`
//! `refine.rs`), its values' anchors beside them. The cache
//! holds no time: the same bake gives the same bytes, for any thread
//! count and any run ([`TIMING_KEYS`]; the bake's JSON report holds the times); the meta JSON
//! holds the `octree` integrator's settings, those of the termination rule included. An older
//! version is refused by name (re-bake it).
//!
//! Reading checks, in this order and before any large allocation: the file size against the
//! memory budget, the length (at least a header and a trailer), the magic, the version (an
//! older or a newer one is refused by name), the length the header announces (truncated or
//! trailing bytes), the checksum, then every count against the bytes left (and the nodes
//! against the memory budget: 8 bytes each in memory from 2 bits on disk), the JSON, and last
//! the octrees' invariants (`Octree::from_parts`). Every error names the file. The checksum is
//! `flate2::Crc` (already a dependency for EXR and PNG): CRC-32 catches every burst error up to
//! 32 bits and any truncation the length check missed; it is not a defence against a forged
//! file, and the invariants checked after it are.

mod atmosphere;
mod meta;
mod nodes;

use meta::{build_stats_from_json, build_stats_json, with_zero_times, without_times, Meta, TreeMeta};
pub use meta::{TIMING_KEYS, TREE_TIMING_KEYS};

use crate::IoError;
use glam::{Mat3, Vec3};
use octolux::caches::octree::compress::{CompressedLeaf, FullLeaf, LEAF_BYTES};
use octolux::caches::octree::{Anchor, LeafAnchors, LeafValueParts, OctreeParts, ANCHOR_SAMPLES};
use octolux::caches::OctreeStats;
use octolux::integrators::octree::OctreeIntegratorParts;
use octolux::integrators::{build_from_parts, Integrator};
use octolux::scene::LightingFingerprint;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Bytes of one anchor on disk (position 3 x u8, normal or direction 3 x i8).
const ANCHOR_BYTES: usize = 6;
/// Bytes of one valid leaf's anchors on disk with the samples: the mean and the samples.
const ANCHORS_BYTES: usize = ANCHOR_BYTES * (1 + ANCHOR_SAMPLES);

/// The first 8 bytes of a cache file.
pub const MAGIC: [u8; 8] = *b"OXCACHE\0";
/// The format version this octolux writes and reads.
pub const FORMAT_VERSION: u32 = 9;
/// The trees byte: the global octree (always), the caustic one, the free-space tree.
const TREE_GLOBAL: u8 = 1;
const TREE_CAUSTIC: u8 = 2;
const TREE_VOLUME: u8 = 4;
/// Header bytes: magic, version, reserved, body length.
pub const HEADER_BYTES: usize = 24;
/// Trailer bytes: the CRC-32.
pub const TRAILER_BYTES: usize = 4;
/// Bytes of a full leaf on disk (54 f32).
pub const FULL_LEAF_BYTES: usize = 6 * 9 * 4;

/// Where a cache came from (informative; only the fingerprint is checked).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CacheInfo {
    /// The octolux version that baked it.
    pub octolux_version: String,
    /// The scene as named on the bake's command line.
    pub scene: String,
    /// The ray-intersection backend of the bake (a render reproduces the bake bit for bit only
    /// with the same backend).
    pub backend: String,
}

/// The content of a cache file.
#[derive(Clone, Debug, PartialEq)]
pub struct CacheFile {
    pub fingerprint: LightingFingerprint,
    pub info: CacheInfo,
    pub parts: OctreeIntegratorParts,
}

/// A cache read and checked, its integrator ready to render.
pub struct LoadedCache {
    pub fingerprint: LightingFingerprint,
    pub info: CacheInfo,
    /// The `octree` integrator built from the cached octrees (no photon traced).
    pub integrator: Integrator,
    /// Bytes of the file.
    pub file_bytes: usize,
}

// ---------------------------------------------------------------- writing

fn put_u32(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put_f32(out: &mut Vec<u8>, v: f32) {
    out.extend_from_slice(&v.to_le_bytes());
}

/// A count as u32 (the octree's counts are u32 by construction).
fn count(n: usize) -> u32 {
    u32::try_from(n).unwrap_or(u32::MAX)
}

fn put_json(out: &mut Vec<u8>, v: &impl Serialize) {
    // The metadata is plain numbers, strings and enums: serialising cannot fail.
    let text = serde_json::to_vec(v).unwrap_or_default();
    put_u32(out, count(text.len()));
    out.extend_from_slice(&text);
}

/// Bytes of a cache file by part (both trees together), for the bake's report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct CacheLayout {
    /// Header, trailer, fingerprint, metadata and the trees' statistics, cube and depth.
    pub header: usize,
    /// Node kinds and photon counts.
    pub nodes: usize,
    /// The leaves' values (36 bytes each compressed).
    pub values: usize,
    /// The facing bits.
    pub facing: usize,
    /// The leak test's anchors (6 bytes per valid leaf, 30 with the sampled photons).
    pub anchors: usize,
    /// The volumetric solution (`bake --volume`): the free-space tree, whole, and any tree's
    /// diffused values.
    pub atmosphere: usize,
}

fn put_tree(out: &mut Vec<u8>, t: &OctreeParts, layout: &mut CacheLayout) {
    let mut mark = out.len();
    let mut part = |out: &Vec<u8>, into: &mut usize| {
        *into += out.len() - mark;
        mark = out.len();
    };
    put_json(out, &TreeMeta { stats: without_times(&t.stats, &TREE_TIMING_KEYS) });
    for v in t.origin.to_array() {
        put_f32(out, v);
    }
    put_f32(out, t.size);
    put_u32(out, t.h_max);
    part(out, &mut layout.header);
    nodes::put_nodes(out, &t.nodes);
    part(out, &mut layout.nodes);
    put_values(out, &t.values);
    part(out, &mut layout.values);
    put_u32(out, count(t.facing.len()));
    out.extend_from_slice(&t.facing);
    part(out, &mut layout.facing);
    out.push(t.leak_samples as u8);
    put_u32(out, count(t.anchors.len()));
    for a in &t.anchors {
        let samples = if t.leak_samples { &a.samples[..] } else { &[] };
        for x in std::iter::once(&a.mean).chain(samples) {
            out.extend_from_slice(&x.pos);
            out.extend(x.normal.map(|c| c as u8));
        }
    }
    part(out, &mut layout.anchors);
    atmosphere::put_atmosphere(out, t);
    part(out, &mut layout.atmosphere);
}

fn put_values(out: &mut Vec<u8>, values: &LeafValueParts) {
    match values {
        LeafValueParts::Compressed(v) => {
            out.push(0);
            put_u32(out, count(v.len()));
            v.iter().for_each(|l| out.extend_from_slice(l));
        }
        LeafValueParts::Full(v) => {
            out.push(1);
            put_u32(out, count(v.len()));
            for m in v.iter().flatten() {
                m.to_cols_array().iter().for_each(|&x| put_f32(out, x));
            }
        }
    }
}

/// Bytes one tree takes in a cache file, by part (its share of the header: its statistics,
/// cube and depth): what a comparison at equal bytes counts for one octree
/// (`examples/probes_vs_octree.rs`).
pub fn tree_layout(t: &OctreeParts) -> CacheLayout {
    let mut layout = CacheLayout::default();
    put_tree(&mut Vec::new(), t, &mut layout);
    layout
}

impl CacheLayout {
    /// All the bytes counted.
    pub fn total(&self) -> usize {
        self.header + self.nodes + self.values + self.facing + self.anchors + self.atmosphere
    }
}

/// The bytes of a cache file.
pub fn encode(c: &CacheFile) -> Vec<u8> {
    encode_with_layout(c).0
}

/// The bytes of a cache file and where they go.
pub fn encode_with_layout(c: &CacheFile) -> (Vec<u8>, CacheLayout) {
    let mut layout = CacheLayout::default();
    let mut body = Vec::new();
    for v in [c.fingerprint.geometry, c.fingerprint.materials, c.fingerprint.emitters] {
        body.extend_from_slice(&v.to_le_bytes());
    }
    let meta = Meta {
        octolux_version: c.info.octolux_version.clone(),
        scene: c.info.scene.clone(),
        backend: c.info.backend.clone(),
        settings: c.parts.settings.clone(),
        stats: build_stats_json(&c.parts.stats),
    };
    put_json(&mut body, &meta);
    body.push(
        TREE_GLOBAL | if c.parts.caustic.is_some() { TREE_CAUSTIC } else { 0 } | if c.parts.volume.is_some() { TREE_VOLUME } else { 0 },
    );
    layout.header = body.len();
    put_tree(&mut body, &c.parts.global, &mut layout);
    if let Some(t) = &c.parts.caustic {
        put_tree(&mut body, t, &mut layout);
    }
    if let Some(t) = &c.parts.volume {
        let mut free = CacheLayout::default();
        put_tree(&mut body, t, &mut free);
        layout.atmosphere += free.total();
    }
    let mut out = Vec::with_capacity(HEADER_BYTES + body.len() + TRAILER_BYTES);
    out.extend_from_slice(&MAGIC);
    put_u32(&mut out, FORMAT_VERSION);
    put_u32(&mut out, 0);
    out.extend_from_slice(&(body.len() as u64).to_le_bytes());
    out.extend_from_slice(&body);
    let crc = crc32(&out);
    put_u32(&mut out, crc);
    layout.header += HEADER_BYTES + TRAILER_BYTES;
    (out, layout)
}

/// CRC-32 (IEEE 802.3, as zlib and PNG compute it).
pub fn crc32(bytes: &[u8]) -> u32 {
    let mut c = flate2::Crc::new();
    c.update(bytes);
    c.sum()
}

// ---------------------------------------------------------------- reading

/// A reader that never reads past the end: every take is checked against what is left.
struct Reader<'a> {
    data: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn left(&self) -> usize {
        self.data.len() - self.at
    }

    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], String> {
        if n > self.left() {
            return Err(format!("{what}: {n} bytes needed at offset {}, {} left", self.at + HEADER_BYTES, self.left()));
        }
        let s = &self.data[self.at..self.at + n];
        self.at += n;
        Ok(s)
    }

    fn u8(&mut self, what: &str) -> Result<u8, String> {
        Ok(self.take(1, what)?[0])
    }

    fn u32(&mut self, what: &str) -> Result<u32, String> {
        let b = self.take(4, what)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    fn u64(&mut self, what: &str) -> Result<u64, String> {
        let b = self.take(8, what)?;
        Ok(u64::from_le_bytes(b.try_into().unwrap_or([0; 8])))
    }

    fn f32(&mut self, what: &str) -> Result<f32, String> {
        Ok(f32::from_bits(self.u32(what)?))
    }

    /// A count of items of `size` bytes, checked against the bytes left before anything is
    /// allocated; returns the count and the items' bytes.
    fn array(&mut self, size: usize, what: &str) -> Result<(usize, &'a [u8]), String> {
        let n = self.u32(what)? as usize;
        let bytes = n.checked_mul(size).filter(|&b| b <= self.left());
        match bytes {
            Some(b) => Ok((n, self.take(b, what)?)),
            None => Err(format!("{what}: {n} entries of {size} bytes announced, {} bytes left", self.left())),
        }
    }

    fn json<T: serde::de::DeserializeOwned>(&mut self, what: &str) -> Result<T, String> {
        let (_, text) = self.array(1, what)?;
        serde_json::from_slice(text).map_err(|e| format!("{what}: {e}"))
    }
}

fn words(b: &[u8]) -> impl Iterator<Item = u32> + '_ {
    b.chunks_exact(4).map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
}

fn read_tree(r: &mut Reader, name: &str, settings: &octolux::caches::OctreeSettings) -> Result<OctreeParts, String> {
    let what = |w: &str| format!("{name} octree, {w}");
    let meta: TreeMeta = r.json(&what("statistics"))?;
    let stats: OctreeStats = with_zero_times(meta.stats, &TREE_TIMING_KEYS, &what("statistics"))?;
    let origin = Vec3::new(r.f32(&what("origin"))?, r.f32(&what("origin"))?, r.f32(&what("origin"))?);
    let size = r.f32(&what("size"))?;
    let h_max = r.u32(&what("depth limit"))?;
    let nodes = nodes::get_nodes(r, &what)?;
    let values = read_values(r, &what("storage"), &what("compressed leaves"), &what("full leaves"))?;
    let (_, facing) = r.array(1, &what("facing bits"))?;
    let leak_samples = match r.u8(&what("anchors"))? {
        0 => false,
        1 => true,
        a => return Err(what(&format!("anchors flag {a} (0: means only, 1: means and samples)"))),
    };
    let size_on_disk = if leak_samples { ANCHORS_BYTES } else { ANCHOR_BYTES };
    let (n_anchors, ab) = r.array(size_on_disk, &what("leaf anchors"))?;
    octolux::budget::check_items(
        || what(&format!("{n_anchors} leaf anchors")),
        n_anchors as u64,
        std::mem::size_of::<LeafAnchors>() as u64,
    )
    .map_err(|e| e.to_string())?;
    let anchor = |b: &[u8]| Anchor { pos: [b[0], b[1], b[2]], normal: [b[3] as i8, b[4] as i8, b[5] as i8] };
    let anchors = ab
        .chunks_exact(size_on_disk)
        .map(|l| {
            let mean = anchor(&l[..ANCHOR_BYTES]);
            let samples = match leak_samples {
                true => std::array::from_fn(|k| anchor(&l[ANCHOR_BYTES * (k + 1)..ANCHOR_BYTES * (k + 2)])),
                false => [mean; ANCHOR_SAMPLES],
            };
            LeafAnchors { mean, samples }
        })
        .collect();
    let atmosphere = atmosphere::get_atmosphere(r, &nodes, &what)?;
    Ok(OctreeParts {
        origin,
        size,
        h_max,
        settings: settings.clone(),
        nodes,
        values,
        facing: facing.to_vec(),
        anchors,
        leak_samples,
        stats,
        atmosphere,
    })
}

fn read_values(r: &mut Reader, storage: &str, compressed: &str, full: &str) -> Result<LeafValueParts, String> {
    Ok(match r.u8(storage)? {
        0 => {
            let (_, b) = r.array(LEAF_BYTES, compressed)?;
            LeafValueParts::Compressed(b.chunks_exact(LEAF_BYTES).map(|l| CompressedLeaf::try_from(l).unwrap_or([0; LEAF_BYTES])).collect())
        }
        1 => {
            let (_, b) = r.array(FULL_LEAF_BYTES, full)?;
            full_leaves(b)
        }
        s => return Err(format!("{storage}: unknown storage {s} (0: compressed, 1: full)")),
    })
}

/// Full leaves (54 f32 each) from their bytes.
fn full_leaves(b: &[u8]) -> LeafValueParts {
    let f: Vec<f32> = words(b).map(f32::from_bits).collect();
    LeafValueParts::Full(
        f.chunks_exact(54).map(|l| -> FullLeaf { std::array::from_fn(|k| Mat3::from_cols_slice(&l[9 * k..9 * k + 9])) }).collect(),
    )
}

/// Parse the bytes of a cache file (module docs for the order of the checks). The octrees'
/// invariants are not checked here but by [`read`] (`Octree::from_parts`). With
/// `verify_checksum` false the CRC is not compared (the fuzz target, so that mutated inputs
/// reach the parser; every other check still runs).
pub fn decode(bytes: &[u8], verify_checksum: bool) -> Result<CacheFile, String> {
    if bytes.len() < HEADER_BYTES + TRAILER_BYTES {
        return Err(format!("{} bytes: too short for an octolux cache file ({} at least)", bytes.len(), HEADER_BYTES + TRAILER_BYTES));
    }
    if bytes[..8] != MAGIC {
        return Err("not an octolux cache file (its first bytes are not \"OXCACHE\")".into());
    }
    let word = |at: usize| u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    let version = word(8);
    if version > FORMAT_VERSION {
        return Err(format!(
            "cache format version {version} was written by a newer octolux; this one reads version {FORMAT_VERSION}: re-bake, or use a newer octolux"
        ));
    }
    if (1..FORMAT_VERSION).contains(&version) {
        return Err(format!(
            "cache format version {version} was written by an older octolux (its layout or settings differ); this one \
             reads version {FORMAT_VERSION}: re-bake it"
        ));
    }
    if version != FORMAT_VERSION {
        return Err(format!("unknown cache format version {version} (this octolux reads {FORMAT_VERSION})"));
    }
    if word(12) != 0 {
        return Err(format!("reserved header field is {:#x}, not 0", word(12)));
    }
    let body_len = u64::from_le_bytes(bytes[16..24].try_into().unwrap_or([0; 8]));
    let expected = (HEADER_BYTES + TRAILER_BYTES) as u64 + body_len.min(u64::MAX - 64);
    if (bytes.len() as u64) < expected {
        return Err(format!("truncated: {} bytes, the header announces {expected}", bytes.len()));
    }
    if (bytes.len() as u64) > expected {
        return Err(format!("{} bytes after the end the header announces ({expected} bytes)", bytes.len() as u64 - expected));
    }
    let end = bytes.len() - TRAILER_BYTES;
    let stored = word(end);
    if verify_checksum {
        let actual = crc32(&bytes[..end]);
        if actual != stored {
            return Err(format!("corrupt: checksum {actual:08x} does not match the stored {stored:08x}"));
        }
    }
    let mut r = Reader { data: &bytes[HEADER_BYTES..end], at: 0 };
    let fingerprint =
        LightingFingerprint { geometry: r.u64("fingerprint")?, materials: r.u64("fingerprint")?, emitters: r.u64("fingerprint")? };
    let meta: Meta = r.json("metadata")?;
    // the values checked as every other source's are (a crafted max_depth of -5, say)
    crate::settings::check_values(&octolux::integrators::IntegratorSettings::Octree(meta.settings.clone()))
        .map_err(|e| format!("its settings: {e}"))?;
    let trees = r.u8("trees")?;
    if trees & TREE_GLOBAL == 0 || trees & !(TREE_GLOBAL | TREE_CAUSTIC | TREE_VOLUME) != 0 {
        return Err(format!("trees {trees:#05b} (bit 0: global, always; bit 1: caustic; bit 2: free-space)"));
    }
    let global = read_tree(&mut r, "global", &meta.settings.global)?;
    let caustic = if trees & TREE_CAUSTIC != 0 { Some(read_tree(&mut r, "caustic", &meta.settings.caustic)?) } else { None };
    let volume = if trees & TREE_VOLUME != 0 { Some(read_tree(&mut r, "free-space", &meta.settings.global)?) } else { None };
    if r.left() != 0 {
        return Err(format!("{} unread bytes after the octrees", r.left()));
    }
    Ok(CacheFile {
        fingerprint,
        info: CacheInfo { octolux_version: meta.octolux_version, scene: meta.scene, backend: meta.backend },
        parts: OctreeIntegratorParts { settings: meta.settings, global, caustic, volume, stats: build_stats_from_json(meta.stats)? },
    })
}

/// Decode and check bytes into a ready integrator; errors are plain messages (no file).
pub fn load_bytes(bytes: &[u8], verify_checksum: bool) -> Result<LoadedCache, String> {
    let c = decode(bytes, verify_checksum)?;
    let integrator = build_from_parts(c.parts).map_err(|e| e.to_string())?;
    Ok(LoadedCache { fingerprint: c.fingerprint, info: c.info, integrator, file_bytes: bytes.len() })
}

/// Read a cache file: every check of the module docs, errors naming the file.
pub fn read(path: &Path) -> Result<LoadedCache, IoError> {
    // the file and the octrees made from it, about twice its size, within the memory budget
    let len = crate::files::check_input(path)?;
    octolux::budget::check_items(|| format!("a lighting cache of {len} bytes"), len, 2)
        .map_err(|b| IoError::invalid(path, b.to_string()))?;
    let bytes = crate::files::read(path)?;
    load_bytes(&bytes, true).map_err(|m| IoError::invalid(path, format!("cannot use this lighting cache: {m}")))
}

/// Compare a scene's lighting fingerprint with the bake's: an error naming what changed, or
/// with `allow_stale` a warning (returned, for the caller to print).
pub fn check_fingerprint(
    path: &Path,
    c: &LoadedCache,
    scene: &LightingFingerprint,
    scene_name: &str,
    allow_stale: bool,
) -> Result<Option<String>, String> {
    let changes = scene.changes(&c.fingerprint);
    if changes.is_empty() {
        return Ok(None);
    }
    let what = changes.join(", ");
    let msg = format!(
        "lighting cache {} does not match scene '{scene_name}': the {what} changed since it was baked (from '{}')",
        path.display(),
        c.info.scene
    );
    if allow_stale {
        Ok(Some(format!("{msg}; rendering anyway (--allow-stale-cache): the indirect light is the bake's")))
    } else {
        Err(format!("{msg}: re-bake it, or pass --allow-stale-cache to render with it anyway (camera and film changes need neither)"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc32_is_zlibs() {
        assert_eq!(crc32(b"123456789"), 0xcbf4_3926);
        assert_eq!(crc32(b""), 0);
    }
}
