//! Mitsuba's `serialized` meshes: the compressed binary format of Mitsuba 0.4–0.6 (and read by
//! Mitsuba 3), in which many published scenes ship their geometry.
//!
//! Layout (all little endian), per mesh: `u16` format `0x041C`, `u16` version (3 or 4), then a
//! zlib stream holding `u32` flags (`0x0001` vertex normals, `0x0002` texture coordinates,
//! `0x0008` vertex colours, `0x0010` face normals, `0x1000` single / `0x2000` double
//! precision), the shape's name as a NUL-terminated string (version 4 only), `u64` vertex and
//! `u64` triangle counts, positions, normals, texture coordinates and colours (`f32` or `f64`,
//! each present when its flag is), then the triangles as `u32` triples. Several meshes are
//! concatenated; the file ends with a dictionary of the meshes' byte offsets (`u64` each in
//! version 4, `u32` in version 3) followed by the `u32` mesh count. Mesh `shape_index` starts at
//! the offset the dictionary gives (mesh 0 at offset 0, as Mitsuba reads it).
//!
//! Conventions, those of Mitsuba 3's `serialized` shape: vertex colours are skipped; the
//! face-normals flag discards the file's normals like `face_normals = true`; when the file has
//! no normals, smooth ones are computed (by the caller, after the transform: see
//! [`SerializedMesh::normals_from_file`]). Errors name the file and the mesh index: bad header,
//! index out of range, truncated or corrupt stream, non-finite positions, indices out of range.

use crate::IoError;
use flate2::read::ZlibDecoder;
use glam::{Vec2, Vec3};
use octolux::scene::TriMesh;
use std::io::Read;
use std::path::Path;

/// First `u16` of every mesh in a serialized file.
pub const SERIALIZED_MAGIC: u16 = 0x041C;

const HAS_NORMALS: u32 = 0x0001;
const HAS_TEXCOORDS: u32 = 0x0002;
const HAS_COLORS: u32 = 0x0008;
const FACE_NORMALS: u32 = 0x0010;
const DOUBLE_PRECISION: u32 = 0x2000;

/// One mesh read from a serialized file (object space).
#[derive(Clone, Debug)]
pub struct SerializedMesh {
    /// Positions, triangles, texture coordinates and the file's normals (when it has them and
    /// does not ask for face normals; `None` otherwise).
    pub mesh: TriMesh,
    /// The name stored in the file (version 4), if not empty.
    pub name: Option<String>,
    /// True when `mesh.normals` came from the file; false when the file has none (the caller
    /// computes smooth ones, after transforming, as Mitsuba does) or asks for face normals.
    pub normals_from_file: bool,
    /// The file's face-normals flag (`0x0010`).
    pub face_normals: bool,
    /// Problems that did not stop the reading (unusable normals), each naming file and mesh.
    pub warnings: Vec<String>,
}

/// Number of meshes in a serialized file (from its end-of-file dictionary; 1 when it has none).
pub fn serialized_shape_count(path: &Path) -> Result<u32, IoError> {
    let bytes = crate::files::read(path)?;
    let version = header(path, &bytes, 0)?;
    Ok(dictionary(&bytes, version).map(|d| d.len() as u32).unwrap_or(1))
}

/// Read mesh `shape_index` of a serialized file.
pub fn load_serialized(path: &Path, shape_index: u32) -> Result<SerializedMesh, IoError> {
    let bytes = crate::files::read(path)?;
    parse_serialized(path, &bytes, shape_index)
}

/// Read mesh `shape_index` from the bytes of a serialized file; `path` names it in messages.
pub fn parse_serialized(path: &Path, bytes: &[u8], shape_index: u32) -> Result<SerializedMesh, IoError> {
    let version = header(path, bytes, 0)?;
    let offset = if shape_index == 0 {
        0
    } else {
        let dict = dictionary(bytes, version).ok_or_else(|| {
            IoError::invalid(path, format!("shape index {shape_index} requested, but the file has no mesh dictionary (one mesh only)"))
        })?;
        let count = dict.len();
        let offset = *dict.get(shape_index as usize).ok_or_else(|| {
            IoError::invalid(path, format!("shape index {shape_index} is out of range (the file has {count} meshes: 0..{})", count - 1))
        })?;
        if offset > bytes.len() as u64 {
            return Err(IoError::invalid(path, format!("mesh {shape_index}: offset {offset} lies beyond the end of the file")));
        }
        offset as usize
    };
    let v = header(path, bytes, offset).map_err(|e| match e {
        IoError::Invalid { file, msg } => IoError::Invalid { file, msg: format!("mesh {shape_index}: {msg}") },
        e => e,
    })?;
    if v != version {
        return Err(IoError::invalid(path, format!("mesh {shape_index}: version {v} differs from the file's version {version}")));
    }
    let err = |msg: String| IoError::invalid(path, format!("mesh {shape_index}: {msg}"));
    let mut r = Reader { z: ZlibDecoder::new(&bytes[offset + 4..]) };
    let flags = r.u32().map_err(&err)?;
    let name = if version == 4 { r.name().map_err(&err)? } else { String::new() };
    let nv = r.u64().map_err(&err)?;
    let nf = r.u64().map_err(&err)?;
    if nv > u32::MAX as u64 {
        return Err(err(format!("{nv} vertices are more than octolux supports (2^32 - 1)")));
    }
    if nf > u32::MAX as u64 {
        return Err(err(format!("{nf} triangles are more than octolux supports (2^32 - 1)")));
    }
    octolux::budget::check_mesh(nv, nf).map_err(|e| err(e.to_string()))?;
    let (nv, nf) = (nv as usize, nf as usize);
    let double = flags & DOUBLE_PRECISION != 0;
    let positions: Vec<Vec3> = r.floats(nv * 3, double, "vertex positions").map_err(&err)?.chunks_exact(3).map(Vec3::from_slice).collect();
    if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
        return Err(err(format!("vertex {i}: position {} is not finite", positions[i])));
    }
    let file_normals = if flags & HAS_NORMALS != 0 {
        let n: Vec<Vec3> = r.floats(nv * 3, double, "vertex normals").map_err(&err)?.chunks_exact(3).map(Vec3::from_slice).collect();
        Some(n)
    } else {
        None
    };
    let uvs = if flags & HAS_TEXCOORDS != 0 {
        let t: Vec<Vec2> = r.floats(nv * 2, double, "texture coordinates").map_err(&err)?.chunks_exact(2).map(Vec2::from_slice).collect();
        if t.iter().any(|t| !t.is_finite()) {
            return Err(err("a texture coordinate is not finite".into()));
        }
        Some(t)
    } else {
        None
    };
    if flags & HAS_COLORS != 0 {
        r.floats(nv * 3, double, "vertex colours").map_err(&err)?;
    }
    let raw = r.u32s(nf * 3, "triangles").map_err(&err)?;
    let mut indices = Vec::with_capacity(nf);
    for (t, c) in raw.chunks_exact(3).enumerate() {
        if let Some(&i) = c.iter().find(|&&i| i as usize >= nv) {
            return Err(err(format!("triangle {t}: vertex index {i} is out of range (the mesh has {nv} vertices)")));
        }
        indices.push([c[0], c[1], c[2]]);
    }
    let face_normals = flags & FACE_NORMALS != 0;
    let mut warnings = Vec::new();
    let normals = match file_normals {
        Some(ns) if !face_normals => {
            let ns: Vec<Vec3> = ns.into_iter().map(Vec3::normalize_or_zero).collect();
            // Unusable (zero or non-finite) normals: all are recomputed, as for a file without any.
            let bad = ns.iter().filter(|n| **n == Vec3::ZERO).count();
            if bad > 0 {
                warnings.push(format!(
                    "{}: mesh {shape_index}: {bad} vertex normals have zero length; all normals are recomputed",
                    path.display()
                ));
                None
            } else {
                Some(ns)
            }
        }
        _ => None,
    };
    let normals_from_file = normals.is_some();
    let mesh = TriMesh { positions, normals, uvs, indices };
    Ok(SerializedMesh { mesh, name: (!name.is_empty()).then_some(name), normals_from_file, face_normals, warnings })
}

/// Check the 4-byte header at `at`; returns the version.
fn header(path: &Path, bytes: &[u8], at: usize) -> Result<u16, IoError> {
    let Some(h) = bytes.get(at..at + 4) else {
        return Err(IoError::invalid(path, "truncated file: no serialized mesh header"));
    };
    let magic = u16::from_le_bytes([h[0], h[1]]);
    let version = u16::from_le_bytes([h[2], h[3]]);
    if magic != SERIALIZED_MAGIC {
        return Err(IoError::invalid(path, format!("not a Mitsuba serialized mesh (header 0x{magic:04X}, expected 0x041C)")));
    }
    if version != 3 && version != 4 {
        return Err(IoError::invalid(path, format!("unsupported serialized mesh version {version} (3 and 4 are supported)")));
    }
    Ok(version)
}

/// The mesh offsets of the end-of-file dictionary, or `None` when the file has no consistent
/// dictionary (a single mesh).
fn dictionary(bytes: &[u8], version: u16) -> Option<Vec<u64>> {
    let n = bytes.len();
    let count = u32::from_le_bytes(bytes.get(n.checked_sub(4)?..)?.try_into().ok()?) as usize;
    let width = if version == 4 { 8 } else { 4 };
    let start = n.checked_sub(4)?.checked_sub(count.checked_mul(width)?)?;
    if count == 0 || start < 4 {
        return None;
    }
    let offsets: Vec<u64> = bytes[start..n - 4]
        .chunks_exact(width)
        .map(|c| {
            if width == 8 {
                u64::from_le_bytes(c.try_into().unwrap_or([0; 8]))
            } else {
                u32::from_le_bytes([c[0], c[1], c[2], c[3]]) as u64
            }
        })
        .collect();
    // The first mesh is always at offset 0 and offsets increase.
    (offsets[0] == 0 && offsets.windows(2).all(|w| w[0] < w[1])).then_some(offsets)
}

/// Little-endian reads from the decompressed stream; errors are messages (the caller adds the
/// file and mesh).
struct Reader<'a> {
    z: ZlibDecoder<&'a [u8]>,
}

/// Values read per chunk: bounds the memory a corrupt count can claim before the stream ends.
const CHUNK: usize = 1 << 16;

impl Reader<'_> {
    fn exact(&mut self, buf: &mut [u8], what: &str) -> Result<(), String> {
        self.z.read_exact(buf).map_err(|e| match e.kind() {
            std::io::ErrorKind::UnexpectedEof => format!("truncated data while reading the {what}"),
            _ => format!("corrupt compressed data while reading the {what} ({e})"),
        })
    }
    fn u32(&mut self) -> Result<u32, String> {
        let mut b = [0u8; 4];
        self.exact(&mut b, "flags")?;
        Ok(u32::from_le_bytes(b))
    }
    fn u64(&mut self) -> Result<u64, String> {
        let mut b = [0u8; 8];
        self.exact(&mut b, "vertex and triangle counts")?;
        Ok(u64::from_le_bytes(b))
    }
    fn name(&mut self) -> Result<String, String> {
        let mut name = Vec::new();
        loop {
            let mut b = [0u8; 1];
            self.exact(&mut b, "shape name")?;
            if b[0] == 0 {
                break;
            }
            if name.len() >= 1 << 16 {
                return Err("the shape name is not terminated".into());
            }
            name.push(b[0]);
        }
        Ok(String::from_utf8_lossy(&name).into_owned())
    }
    /// `count` floats stored as f32 or f64.
    fn floats(&mut self, count: usize, double: bool, what: &str) -> Result<Vec<f32>, String> {
        let size = if double { 8 } else { 4 };
        let mut out = Vec::with_capacity(count.min(CHUNK));
        let mut buf = vec![0u8; CHUNK.min(count.max(1)) * size];
        let mut left = count;
        while left > 0 {
            let n = left.min(CHUNK);
            let b = &mut buf[..n * size];
            self.exact(b, what)?;
            if double {
                out.extend(b.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])) as f32));
            } else {
                out.extend(b.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])));
            }
            left -= n;
        }
        Ok(out)
    }
    fn u32s(&mut self, count: usize, what: &str) -> Result<Vec<u32>, String> {
        let mut out = Vec::with_capacity(count.min(CHUNK));
        let mut buf = vec![0u8; CHUNK.min(count.max(1)) * 4];
        let mut left = count;
        while left > 0 {
            let n = left.min(CHUNK);
            let b = &mut buf[..n * 4];
            self.exact(b, what)?;
            out.extend(b.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])));
            left -= n;
        }
        Ok(out)
    }
}
