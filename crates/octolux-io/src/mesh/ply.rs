//! PLY meshes (ascii, binary little and big endian); conventions in the documentation of
//! [`super`].

use super::{compute_vertex_normals, merge_normals, push_fan, read_file, RawMesh};
use crate::IoError;
use glam::{Vec2, Vec3};
use octolux::scene::TriMesh;
use std::path::Path;

/// Scalar types of the PLY format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum PlyType {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl PlyType {
    fn parse(s: &str) -> Option<PlyType> {
        Some(match s {
            "char" | "int8" => PlyType::I8,
            "uchar" | "uint8" => PlyType::U8,
            "short" | "int16" => PlyType::I16,
            "ushort" | "uint16" => PlyType::U16,
            "int" | "int32" => PlyType::I32,
            "uint" | "uint32" => PlyType::U32,
            "float" | "float32" => PlyType::F32,
            "double" | "float64" => PlyType::F64,
            _ => return None,
        })
    }
    fn size(self) -> usize {
        match self {
            PlyType::I8 | PlyType::U8 => 1,
            PlyType::I16 | PlyType::U16 => 2,
            PlyType::I32 | PlyType::U32 | PlyType::F32 => 4,
            PlyType::F64 => 8,
        }
    }
    fn is_integer(self) -> bool {
        !matches!(self, PlyType::F32 | PlyType::F64)
    }
}

#[derive(Clone, Copy, Debug)]
enum PlyKind {
    Scalar(PlyType),
    List { count: PlyType, item: PlyType },
}

#[derive(Debug)]
struct PlyProperty {
    name: String,
    kind: PlyKind,
}

#[derive(Debug)]
struct PlyElement {
    name: String,
    count: usize,
    props: Vec<PlyProperty>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum PlyFormat {
    Ascii,
    BinaryLittleEndian,
    BinaryBigEndian,
}

struct PlyHeader {
    format: PlyFormat,
    elements: Vec<PlyElement>,
    /// Byte offset of the body.
    body: usize,
    /// Number of header lines (the body's first line is `lines + 1`).
    lines: u32,
}

fn parse_ply_header(path: &Path, bytes: &[u8]) -> Result<PlyHeader, IoError> {
    let mut pos = 0usize;
    let mut line = 0u32;
    let mut format = None;
    let mut elements: Vec<PlyElement> = Vec::new();
    loop {
        if pos >= bytes.len() {
            return Err(IoError::parse(path, line.max(1), "PLY header has no 'end_header' line"));
        }
        let end = bytes[pos..].iter().position(|&b| b == b'\n').map(|i| pos + i).unwrap_or(bytes.len());
        let text = std::str::from_utf8(&bytes[pos..end]).map_err(|_| IoError::parse(path, line + 1, "PLY header is not text"))?;
        pos = (end + 1).min(bytes.len());
        line += 1;
        let mut tok = text.split_whitespace();
        let Some(keyword) = tok.next() else { continue };
        let err = |msg: String| IoError::parse(path, line, msg);
        if line == 1 {
            if keyword != "ply" {
                return Err(err("not a PLY file (first line must be 'ply')".into()));
            }
            continue;
        }
        match keyword {
            "format" => {
                format = Some(match tok.next() {
                    Some("ascii") => PlyFormat::Ascii,
                    Some("binary_little_endian") => PlyFormat::BinaryLittleEndian,
                    Some("binary_big_endian") => PlyFormat::BinaryBigEndian,
                    other => return Err(err(format!("unknown PLY format {:?}", other.unwrap_or("")))),
                });
            }
            "comment" | "obj_info" => {}
            "element" => {
                let name = tok.next().ok_or_else(|| err("element without a name".into()))?;
                let count =
                    tok.next().and_then(|c| c.parse::<usize>().ok()).ok_or_else(|| err(format!("element '{name}' has no valid count")))?;
                elements.push(PlyElement { name: name.to_string(), count, props: Vec::new() });
            }
            "property" => {
                let el = elements.last_mut().ok_or_else(|| err("property before any element".into()))?;
                let t = tok.next().ok_or_else(|| err("property without a type".into()))?;
                let kind = if t == "list" {
                    let c = tok.next().unwrap_or("");
                    let i = tok.next().unwrap_or("");
                    let count =
                        PlyType::parse(c).filter(|t| t.is_integer()).ok_or_else(|| err(format!("invalid list count type '{c}'")))?;
                    let item = PlyType::parse(i).ok_or_else(|| err(format!("unknown property type '{i}'")))?;
                    PlyKind::List { count, item }
                } else {
                    PlyKind::Scalar(PlyType::parse(t).ok_or_else(|| err(format!("unknown property type '{t}'")))?)
                };
                let name = tok.next().ok_or_else(|| err("property without a name".into()))?;
                el.props.push(PlyProperty { name: name.to_string(), kind });
            }
            "end_header" => break,
            other => return Err(err(format!("unknown PLY header keyword '{other}'"))),
        }
    }
    let format = format.ok_or_else(|| IoError::parse(path, line, "PLY header has no 'format' line"))?;
    Ok(PlyHeader { format, elements, body: pos, lines: line })
}

/// Source of PLY values: ascii tokens (with line numbers) or binary data.
enum PlyReader<'a> {
    Ascii { lines: std::iter::Enumerate<std::str::Lines<'a>>, tokens: std::str::SplitWhitespace<'a>, line: u32, first_line: u32 },
    Binary { data: &'a [u8], pos: usize, big_endian: bool },
}

impl<'a> PlyReader<'a> {
    /// Line of the value read last (ascii only).
    fn line(&self) -> Option<u32> {
        match self {
            PlyReader::Ascii { line, .. } => Some(*line),
            PlyReader::Binary { .. } => None,
        }
    }

    /// Read one value of type `t` (as f64, exact for every PLY type). Ascii tokens are read
    /// across line breaks, as the format allows.
    fn read(&mut self, t: PlyType) -> Result<f64, String> {
        match self {
            PlyReader::Ascii { lines, tokens, line, first_line } => {
                let tok = loop {
                    if let Some(tok) = tokens.next() {
                        break tok;
                    }
                    match lines.next() {
                        Some((i, l)) => {
                            *line = *first_line + i as u32;
                            *tokens = l.split_whitespace();
                        }
                        None => return Err("unexpected end of file".into()),
                    }
                };
                if t.is_integer() {
                    tok.parse::<i64>().map(|v| v as f64).map_err(|_| format!("invalid integer '{tok}'"))
                } else {
                    tok.parse::<f64>().map_err(|_| format!("invalid number '{tok}'"))
                }
            }
            PlyReader::Binary { data, pos, big_endian } => {
                let n = t.size();
                if *pos + n > data.len() {
                    return Err("unexpected end of file".into());
                }
                let mut b = [0u8; 8];
                b[..n].copy_from_slice(&data[*pos..*pos + n]);
                *pos += n;
                if *big_endian {
                    b[..n].reverse();
                }
                Ok(match t {
                    PlyType::I8 => b[0] as i8 as f64,
                    PlyType::U8 => b[0] as f64,
                    PlyType::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
                    PlyType::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
                    PlyType::I32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    PlyType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    PlyType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    PlyType::F64 => f64::from_le_bytes(b),
                })
            }
        }
    }
}

/// Names accepted for texture coordinates, in order of preference.
const PLY_UV_NAMES: [(&str, &str); 4] = [("u", "v"), ("texture_u", "texture_v"), ("s", "t"), ("texture_s", "texture_t")];

/// Load a PLY file (ascii, binary little or big endian) as one mesh, with Mitsuba 3's
/// conventions (see the documentation of [`super`]). Degenerate triangles are kept; see
/// [`super::load_mesh_checked`].
pub fn load_ply_mesh(path: &Path) -> Result<TriMesh, IoError> {
    load_ply_with_warnings(path).map(|r| r.mesh)
}

pub(super) fn load_ply_with_warnings(path: &Path) -> Result<RawMesh, IoError> {
    parse_ply(path, &read_file(path)?)
}

/// Refuse element counts the file cannot hold or the memory budget cannot afford, before
/// anything is allocated from them: each entry of an element needs at least one byte per
/// property (ascii) or the size of its scalars and list counts (binary).
fn check_counts(path: &Path, header: &PlyHeader, body_len: usize) -> Result<(), IoError> {
    let mut needed = 0u64;
    for el in &header.elements {
        let per_entry: u64 = match header.format {
            PlyFormat::Ascii => el.props.len() as u64,
            _ => el
                .props
                .iter()
                .map(|p| match p.kind {
                    PlyKind::Scalar(t) => t.size() as u64,
                    PlyKind::List { count, .. } => count.size() as u64,
                })
                .sum(),
        };
        let bytes = (el.count as u64).checked_mul(per_entry);
        needed = match bytes.and_then(|b| b.checked_add(needed)) {
            Some(n) if n <= body_len as u64 => n,
            _ => {
                return Err(IoError::invalid(
                    path,
                    format!(
                        "element '{}' claims {} entries, but the file has only {body_len} bytes after its header (each entry needs at least {per_entry})",
                        el.name, el.count
                    ),
                ))
            }
        };
    }
    let count = |name: &str| header.elements.iter().filter(|e| e.name == name).map(|e| e.count as u64).fold(0u64, u64::saturating_add);
    let (nv, nf) = (count("vertex"), count("face"));
    if nv > u32::MAX as u64 {
        return Err(IoError::invalid(path, format!("{nv} vertices are more than octolux supports (2^32 - 1)")));
    }
    octolux::budget::check_mesh(nv, nf).map_err(|e| IoError::invalid(path, e.to_string()))
}

/// Read a PLY mesh from its bytes (see [`load_ply_mesh`]); `path` names it in messages. This is
/// also the entry point of the `ply` fuzz target.
pub fn parse_ply(path: &Path, bytes: &[u8]) -> Result<RawMesh, IoError> {
    let header = parse_ply_header(path, bytes)?;
    let body = &bytes[header.body..];
    check_counts(path, &header, body.len())?;
    let mut reader = match header.format {
        PlyFormat::Ascii => {
            let text = std::str::from_utf8(body).map_err(|_| IoError::parse(path, header.lines + 1, "ascii PLY body is not text"))?;
            let mut lines = text.lines().enumerate();
            let (line, tokens) = match lines.next() {
                Some((_, l)) => (header.lines + 1, l.split_whitespace()),
                None => (header.lines, "".split_whitespace()),
            };
            PlyReader::Ascii { lines, tokens, line, first_line: header.lines + 1 }
        }
        PlyFormat::BinaryLittleEndian => PlyReader::Binary { data: body, pos: 0, big_endian: false },
        PlyFormat::BinaryBigEndian => PlyReader::Binary { data: body, pos: 0, big_endian: true },
    };

    let mut positions: Vec<Vec3> = Vec::new();
    let mut given_normals: Option<Vec<Option<Vec3>>> = None;
    let mut uvs: Option<Vec<Vec2>> = None;
    // Polygons: (first index into `corners`, corner count, line for ascii files).
    let mut polys: Vec<(usize, usize, u32)> = Vec::new();
    let mut corners: Vec<i64> = Vec::new();
    let mut have_vertices = false;
    let mut have_faces = false;
    let mut scalars: Vec<f64> = Vec::new();
    let mut list: Vec<f64> = Vec::new();

    let fail = |reader: &PlyReader, el: &str, i: usize, msg: String| match reader.line() {
        Some(line) => IoError::parse(path, line, format!("{el} {i}: {msg}")),
        None => IoError::invalid(path, format!("{el} {i}: {msg}")),
    };

    for el in &header.elements {
        let find = |name: &str| el.props.iter().position(|p| p.name == name && matches!(p.kind, PlyKind::Scalar(_)));
        let is_vertex = el.name == "vertex";
        let is_face = el.name == "face";
        let (xyz, nxyz, uv) = if is_vertex {
            let xyz = match (find("x"), find("y"), find("z")) {
                (Some(x), Some(y), Some(z)) => [x, y, z],
                _ => return Err(IoError::invalid(path, "the vertex element lacks x, y or z")),
            };
            let n = match (find("nx"), find("ny"), find("nz")) {
                (Some(x), Some(y), Some(z)) => Some([x, y, z]),
                _ => None,
            };
            let uv = PLY_UV_NAMES.iter().find_map(|(u, v)| Some([find(u)?, find(v)?]));
            (xyz, n, uv)
        } else {
            ([0; 3], None, None)
        };
        let face_list = if is_face {
            let idx = el
                .props
                .iter()
                .position(|p| (p.name == "vertex_indices" || p.name == "vertex_index") && matches!(p.kind, PlyKind::List { .. }))
                .ok_or_else(|| IoError::invalid(path, "the face element has no 'vertex_indices' or 'vertex_index' list"))?;
            Some(idx)
        } else {
            None
        };
        if is_vertex {
            have_vertices = true;
            positions.reserve(el.count);
            if nxyz.is_some() {
                given_normals = Some(Vec::with_capacity(el.count));
            }
            if uv.is_some() {
                uvs = Some(Vec::with_capacity(el.count));
            }
        }
        if is_face {
            have_faces = true;
        }
        if el.props.is_empty() {
            continue; // nothing to read, whatever the count
        }
        for i in 0..el.count {
            scalars.clear();
            for (pi, prop) in el.props.iter().enumerate() {
                match prop.kind {
                    PlyKind::Scalar(t) => {
                        let v = reader.read(t).map_err(|m| fail(&reader, &el.name, i, m))?;
                        scalars.push(v);
                    }
                    PlyKind::List { count, item } => {
                        let n = reader.read(count).map_err(|m| fail(&reader, &el.name, i, m))?;
                        if n < 0.0 {
                            return Err(fail(&reader, &el.name, i, format!("negative list length {n}")));
                        }
                        list.clear();
                        for _ in 0..n as usize {
                            list.push(reader.read(item).map_err(|m| fail(&reader, &el.name, i, m))?);
                        }
                        scalars.push(f64::NAN); // placeholder keeps property positions aligned
                        if Some(pi) == face_list {
                            let start = corners.len();
                            for &c in &list {
                                if c.fract() != 0.0 || !c.is_finite() {
                                    return Err(fail(&reader, &el.name, i, format!("vertex index {c} is not an integer")));
                                }
                                corners.push(c as i64);
                            }
                            polys.push((start, list.len(), reader.line().unwrap_or(0)));
                        }
                    }
                }
            }
            if is_vertex {
                let p = Vec3::new(scalars[xyz[0]] as f32, scalars[xyz[1]] as f32, scalars[xyz[2]] as f32);
                if !p.is_finite() {
                    return Err(fail(&reader, "vertex", i, format!("position {p} is not finite")));
                }
                positions.push(p);
                if let (Some(n), Some(out)) = (nxyz, given_normals.as_mut()) {
                    let v = Vec3::new(scalars[n[0]] as f32, scalars[n[1]] as f32, scalars[n[2]] as f32);
                    if !v.is_finite() {
                        return Err(fail(&reader, "vertex", i, format!("normal {v} is not finite")));
                    }
                    out.push(Some(v));
                }
                if let (Some(t), Some(out)) = (uv, uvs.as_mut()) {
                    let v = Vec2::new(scalars[t[0]] as f32, scalars[t[1]] as f32);
                    if !v.is_finite() {
                        return Err(fail(&reader, "vertex", i, format!("texture coordinate {v} is not finite")));
                    }
                    out.push(v);
                }
            }
        }
    }
    if !have_vertices {
        return Err(IoError::invalid(path, "the PLY file has no vertex element"));
    }
    if !have_faces {
        return Err(IoError::invalid(path, "the PLY file has no face element (point clouds are not supported)"));
    }

    let n = positions.len();
    let ascii = header.format == PlyFormat::Ascii;
    let mut indices = Vec::with_capacity(polys.len());
    let mut poly: Vec<u32> = Vec::new();
    for (fi, &(start, count, where_)) in polys.iter().enumerate() {
        let err = |msg: String| {
            if ascii {
                IoError::parse(path, where_, format!("face {fi}: {msg}"))
            } else {
                IoError::invalid(path, format!("face {fi}: {msg}"))
            }
        };
        if count < 3 {
            return Err(err(format!("a face needs at least 3 vertices, found {count}")));
        }
        poly.clear();
        for &c in &corners[start..start + count] {
            if c < 0 || c as usize >= n {
                return Err(err(format!("vertex index {c} is out of range (the file has {n} vertices)")));
            }
            poly.push(c as u32);
        }
        push_fan(&poly, &mut indices);
    }

    let mut warnings = Vec::new();
    let normals_from_file = given_normals.is_some();
    let normals = match given_normals {
        Some(given) => {
            let (normals, bad) = merge_normals(&positions, &indices, &given);
            if bad > 0 {
                warnings.push(format!("{}: {bad} vertex normals have zero length; replaced by computed normals", path.display()));
            }
            normals
        }
        None => compute_vertex_normals(&positions, &indices),
    };
    Ok(RawMesh { mesh: TriMesh { positions, normals: Some(normals), uvs, indices }, normals_from_file, warnings })
}
