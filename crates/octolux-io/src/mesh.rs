//! OBJ and PLY triangle meshes, read the way Mitsuba 3's `obj` and `ply` shapes read them, and
//! mesh files rendered directly as scenes.
//!
//! Conventions (checked against Mitsuba 3's `src/shapes/obj.cpp`, `ply.cpp` and
//! `Mesh::recompute_vertex_normals`):
//! - OBJ: all groups/objects are merged into one mesh; a vertex is the distinct triple
//!   (position, texcoord, normal) references of a face corner; polygons are triangulated as fans
//!   `(v0, v_k, v_k+1)`; indices are 1-based, negative indices count back from the last element
//!   defined so far (an extension: Mitsuba rejects them); texture coordinates are flipped
//!   vertically (`v -> 1 - v`, Mitsuba's `flip_tex_coords = true` default); `vn` normals are
//!   used when faces reference them. Lines other than `v`, `vt`, `vn`, `f`, `usemtl` and
//!   `mtllib` are ignored.
//! - PLY: ascii, binary little and big endian; vertex `x y z`, optional `nx ny nz` and
//!   `u v` (or `texture_u texture_v`, `s t`, `texture_s texture_t`), not flipped (Mitsuba's PLY
//!   default); faces from the `vertex_indices` or `vertex_index` list, polygons as fans. Other
//!   elements and properties are skipped.
//! - When a file has no vertex normals, smooth ones are computed with Mitsuba's angle-weighted
//!   scheme (Thürmer & Wüthrich 1998), since Mitsuba's default (`face_normals = false`) does
//!   the same. A caller honouring `face_normals = true` just sets `TriMesh::normals = None`.
//! - Non-finite positions and out-of-range indices are errors naming the file, with the line
//!   for OBJ and ascii PLY (the element number for binary PLY). [`load_mesh_checked`] also
//!   removes degenerate triangles and reports them as warnings.
//!
//! [`load_mesh_scene`] renders a mesh file on its own; its material mapping and default camera
//! and lighting are documented there.

use crate::image_io::read_image;
use crate::{IoError, LoadedScene};
use glam::{Vec2, Vec3};
use octolux::camera::{look_at, CameraDesc, FovAxis};
use octolux::light::Light;
use octolux::material::{Image, Material, Texture};
use octolux::math::Color;
use octolux::scene::{FilmDesc, Geometry, SceneDesc, SceneHints, ShapeDesc, TriMesh};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

// ---------------------------------------------------------------------------------------------
// Shared helpers
// ---------------------------------------------------------------------------------------------

fn lower_extension(path: &Path) -> String {
    path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()).unwrap_or_default()
}

fn read_file(path: &Path) -> Result<Vec<u8>, IoError> {
    std::fs::read(path).map_err(|e| IoError::os(path, e))
}

/// Angle-weighted smooth vertex normals (Thürmer & Wüthrich 1998, the scheme of Mitsuba's
/// `Mesh::recompute_vertex_normals`). Degenerate triangles contribute nothing; a vertex whose
/// weighted sum vanishes gets the normal of one of its triangles (or +z when it has none).
pub fn compute_vertex_normals(positions: &[Vec3], indices: &[[u32; 3]]) -> Vec<Vec3> {
    let mut acc = vec![Vec3::ZERO; positions.len()];
    let mut fallback = vec![Vec3::ZERO; positions.len()];
    for t in indices {
        let p = [positions[t[0] as usize], positions[t[1] as usize], positions[t[2] as usize]];
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        let len = n.length();
        if !len.is_finite() || len <= 0.0 {
            continue;
        }
        let n = n / len;
        for j in 0..3 {
            let e0 = (p[(j + 1) % 3] - p[j]).normalize_or_zero();
            let e1 = (p[(j + 2) % 3] - p[j]).normalize_or_zero();
            let angle = e0.dot(e1).clamp(-1.0, 1.0).acos();
            let v = t[j] as usize;
            acc[v] += n * angle;
            if fallback[v] == Vec3::ZERO {
                fallback[v] = n;
            }
        }
    }
    acc.iter()
        .zip(fallback)
        .map(|(a, f)| {
            let l = a.length();
            if l.is_finite() && l > 1e-30 {
                *a / l
            } else if f != Vec3::ZERO {
                f
            } else {
                Vec3::Z
            }
        })
        .collect()
}

/// Computed normals where `given` has none (or an unusable one); returns how many given normals
/// were unusable (zero length).
fn merge_normals(positions: &[Vec3], indices: &[[u32; 3]], given: &[Option<Vec3>]) -> (Vec<Vec3>, usize) {
    let computed = compute_vertex_normals(positions, indices);
    let mut bad = 0;
    let normals = computed
        .into_iter()
        .zip(given)
        .map(|(c, g)| match g {
            Some(n) => {
                let m = n.normalize_or_zero();
                if m == Vec3::ZERO {
                    bad += 1;
                    c
                } else {
                    m
                }
            }
            None => c,
        })
        .collect();
    (normals, bad)
}

/// Fan triangulation `(v0, v_k, v_k+1)` of a polygon, appended to `out`.
fn push_fan(poly: &[u32], out: &mut Vec<[u32; 3]>) {
    for k in 1..poly.len().saturating_sub(1) {
        out.push([poly[0], poly[k], poly[k + 1]]);
    }
}

// ---------------------------------------------------------------------------------------------
// OBJ
// ---------------------------------------------------------------------------------------------

/// A parsed OBJ file: the merged mesh plus what the scene loader needs for materials.
struct ObjData {
    mesh: TriMesh,
    /// Per triangle: index into `material_names`.
    tri_material: Vec<u32>,
    /// `usemtl` names in order of first use; index 0 is "" (faces before any `usemtl`).
    material_names: Vec<String>,
    /// `mtllib` file names with the line that named them.
    mtllibs: Vec<(String, u32)>,
    warnings: Vec<String>,
}

/// Resolve a 1-based (or negative, relative) OBJ index against `count` elements defined so far.
fn obj_index(path: &Path, line: u32, token: &str, what: &str, count: usize) -> Result<usize, IoError> {
    let i: i64 = token.parse().map_err(|_| IoError::parse(path, line, format!("invalid {what} index '{token}'")))?;
    let resolved = if i > 0 {
        i - 1
    } else if i < 0 {
        count as i64 + i
    } else {
        return Err(IoError::parse(path, line, format!("{what} index 0 is invalid (OBJ indices start at 1)")));
    };
    if resolved < 0 || resolved >= count as i64 {
        return Err(IoError::parse(path, line, format!("{what} index {i} is out of range ({count} defined so far)")));
    }
    Ok(resolved as usize)
}

fn parse_floats<'a>(
    path: &Path,
    line: u32,
    what: &str,
    tokens: impl Iterator<Item = &'a str>,
    min: usize,
    out: &mut [f32],
) -> Result<usize, IoError> {
    let mut n = 0;
    for tok in tokens {
        if n == out.len() {
            break;
        }
        out[n] = tok.parse::<f32>().map_err(|_| IoError::parse(path, line, format!("invalid number '{tok}' in {what}")))?;
        n += 1;
    }
    if n < min {
        return Err(IoError::parse(path, line, format!("{what} needs {min} numbers, found {n}")));
    }
    Ok(n)
}

fn parse_obj(path: &Path) -> Result<ObjData, IoError> {
    let bytes = read_file(path)?;
    let text = String::from_utf8_lossy(&bytes);

    let mut v: Vec<Vec3> = Vec::new();
    let mut vt: Vec<Vec2> = Vec::new();
    let mut vn: Vec<Vec3> = Vec::new();
    // (position, texcoord + 1 or 0, normal + 1 or 0) -> output vertex
    let mut vertex_map: HashMap<(u32, u32, u32), u32> = HashMap::new();
    let mut out_pos: Vec<Vec3> = Vec::new();
    let mut out_uv: Vec<Option<Vec2>> = Vec::new();
    let mut out_n: Vec<Option<Vec3>> = Vec::new();
    let mut indices: Vec<[u32; 3]> = Vec::new();
    let mut tri_material: Vec<u32> = Vec::new();
    let mut material_names = vec![String::new()];
    let mut current_material = 0u32;
    let mut mtllibs = Vec::new();
    let mut poly: Vec<u32> = Vec::new();

    for (lineno, raw) in text.lines().enumerate() {
        let line = (lineno + 1) as u32;
        let content = raw.split('#').next().unwrap_or("");
        let mut tokens = content.split_whitespace();
        let Some(keyword) = tokens.next() else { continue };
        match keyword {
            "v" => {
                let mut p = [0.0f32; 3];
                parse_floats(path, line, "vertex position", tokens, 3, &mut p)?;
                let p = Vec3::from(p);
                if !p.is_finite() {
                    return Err(IoError::parse(path, line, format!("vertex position {p} is not finite")));
                }
                v.push(p);
            }
            "vt" => {
                let mut t = [0.0f32; 2];
                parse_floats(path, line, "texture coordinate", tokens, 1, &mut t)?;
                if !(t[0].is_finite() && t[1].is_finite()) {
                    return Err(IoError::parse(path, line, "texture coordinate is not finite"));
                }
                vt.push(Vec2::new(t[0], 1.0 - t[1]));
            }
            "vn" => {
                let mut n = [0.0f32; 3];
                parse_floats(path, line, "vertex normal", tokens, 3, &mut n)?;
                let n = Vec3::from(n);
                if !n.is_finite() {
                    return Err(IoError::parse(path, line, format!("vertex normal {n} is not finite")));
                }
                vn.push(n);
            }
            "f" => {
                poly.clear();
                for corner in tokens {
                    let mut parts = corner.split('/');
                    let pi = obj_index(path, line, parts.next().unwrap_or(""), "vertex", v.len())?;
                    let ti = match parts.next() {
                        Some(s) if !s.is_empty() => obj_index(path, line, s, "texture coordinate", vt.len())? as u32 + 1,
                        _ => 0,
                    };
                    let ni = match parts.next() {
                        Some(s) if !s.is_empty() => obj_index(path, line, s, "normal", vn.len())? as u32 + 1,
                        _ => 0,
                    };
                    if parts.next().is_some() {
                        return Err(IoError::parse(path, line, format!("face corner '{corner}' has more than three indices")));
                    }
                    let key = (pi as u32, ti, ni);
                    let id = *vertex_map.entry(key).or_insert_with(|| {
                        out_pos.push(v[pi]);
                        out_uv.push((ti > 0).then(|| vt[ti as usize - 1]));
                        out_n.push((ni > 0).then(|| vn[ni as usize - 1]));
                        (out_pos.len() - 1) as u32
                    });
                    poly.push(id);
                }
                if poly.len() < 3 {
                    return Err(IoError::parse(path, line, format!("a face needs at least 3 vertices, found {}", poly.len())));
                }
                let before = indices.len();
                push_fan(&poly, &mut indices);
                tri_material.resize(tri_material.len() + indices.len() - before, current_material);
            }
            "usemtl" => {
                let name = content.trim_start().strip_prefix("usemtl").unwrap_or("").trim().to_string();
                current_material = match material_names.iter().position(|n| *n == name) {
                    Some(i) => i as u32,
                    None => {
                        material_names.push(name);
                        (material_names.len() - 1) as u32
                    }
                };
            }
            "mtllib" => {
                for name in tokens {
                    mtllibs.push((name.to_string(), line));
                }
            }
            _ => {}
        }
    }

    let mut warnings = Vec::new();
    let normals = if out_n.iter().any(|n| n.is_some()) {
        let missing = out_n.iter().filter(|n| n.is_none()).count();
        if missing > 0 {
            warnings.push(format!("{}: {missing} face corners have no normal; computed smooth normals for them", path.display()));
        }
        let (normals, bad) = merge_normals(&out_pos, &indices, &out_n);
        if bad > 0 {
            warnings.push(format!("{}: {bad} vertex normals have zero length; replaced by computed normals", path.display()));
        }
        normals
    } else {
        compute_vertex_normals(&out_pos, &indices)
    };
    let uvs = out_uv.iter().any(|t| t.is_some()).then(|| out_uv.iter().map(|t| t.unwrap_or(Vec2::ZERO)).collect());
    Ok(ObjData {
        mesh: TriMesh { positions: out_pos, normals: Some(normals), uvs, indices },
        tri_material,
        material_names,
        mtllibs,
        warnings,
    })
}

/// Load an OBJ file as one world-space mesh (all groups merged), with Mitsuba 3's conventions
/// (see the module documentation). Degenerate triangles are kept; see [`load_mesh_checked`].
pub fn load_obj_mesh(path: &Path) -> Result<TriMesh, IoError> {
    Ok(parse_obj(path)?.mesh)
}

// ---------------------------------------------------------------------------------------------
// PLY
// ---------------------------------------------------------------------------------------------

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
/// conventions (see the module documentation). Degenerate triangles are kept; see
/// [`load_mesh_checked`].
pub fn load_ply_mesh(path: &Path) -> Result<TriMesh, IoError> {
    load_ply_with_warnings(path).map(|(m, _)| m)
}

fn load_ply_with_warnings(path: &Path) -> Result<(TriMesh, Vec<String>), IoError> {
    let bytes = read_file(path)?;
    let header = parse_ply_header(path, &bytes)?;
    let body = &bytes[header.body..];
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
    Ok((TriMesh { positions, normals: Some(normals), uvs, indices }, warnings))
}

// ---------------------------------------------------------------------------------------------
// Checked loading
// ---------------------------------------------------------------------------------------------

fn remove_degenerate_with_warning(path: &Path, mesh: &mut TriMesh, warnings: &mut Vec<String>) {
    let removed = mesh.remove_degenerate();
    if removed > 0 {
        warnings.push(format!("{}: removed {removed} degenerate triangle{}", path.display(), if removed == 1 { "" } else { "s" }));
    }
}

/// Load a `.obj` or `.ply` mesh (by extension, case-insensitive), remove degenerate triangles
/// and return the warnings collected (each naming the file). A file with no usable triangle is
/// an error.
pub fn load_mesh_checked(path: &Path) -> Result<(TriMesh, Vec<String>), IoError> {
    let (mut mesh, mut warnings) = match lower_extension(path).as_str() {
        "obj" => {
            let d = parse_obj(path)?;
            (d.mesh, d.warnings)
        }
        "ply" => load_ply_with_warnings(path)?,
        other => return Err(IoError::invalid(path, format!("unknown mesh format '.{other}' (expected .obj or .ply)"))),
    };
    remove_degenerate_with_warning(path, &mut mesh, &mut warnings);
    if mesh.indices.is_empty() {
        return Err(IoError::invalid(path, "the mesh has no (non-degenerate) triangles"));
    }
    Ok((mesh, warnings))
}

// ---------------------------------------------------------------------------------------------
// Mesh files as scenes
// ---------------------------------------------------------------------------------------------

/// Diffuse reflectance used when a material gives none, and for PLY files.
pub const DEFAULT_REFLECTANCE: f32 = 0.8;
/// Radiance of the constant environment added when a mesh scene has no emitter.
pub const DEFAULT_ENVIRONMENT_RADIANCE: f32 = 1.0;
/// Field of view (degrees, horizontal) of the camera framing a mesh scene.
pub const MESH_SCENE_FOV: f32 = 39.3;

/// The sub-mesh made of the triangles `tris` of `mesh`, with only the vertices they use.
fn submesh(mesh: &TriMesh, tris: &[usize]) -> TriMesh {
    let mut remap: HashMap<u32, u32> = HashMap::new();
    let mut out =
        TriMesh { normals: mesh.normals.as_ref().map(|_| Vec::new()), uvs: mesh.uvs.as_ref().map(|_| Vec::new()), ..Default::default() };
    for &t in tris {
        let mut tri = [0u32; 3];
        for (k, &v) in mesh.indices[t].iter().enumerate() {
            tri[k] = *remap.entry(v).or_insert_with(|| {
                out.positions.push(mesh.positions[v as usize]);
                if let (Some(o), Some(s)) = (out.normals.as_mut(), mesh.normals.as_ref()) {
                    o.push(s[v as usize]);
                }
                if let (Some(o), Some(s)) = (out.uvs.as_mut(), mesh.uvs.as_ref()) {
                    o.push(s[v as usize]);
                }
                (out.positions.len() - 1) as u32
            });
        }
        out.indices.push(tri);
    }
    out
}

fn color_of(c: Option<[f32; 3]>) -> Option<Color> {
    c.map(Color::from)
}

/// Clamp a reflectance-like colour into `[0, 1]`, warning when it had to.
fn clamp_unit(c: Color, what: &str, mtl: &str, warnings: &mut Vec<String>) -> Color {
    let clamped = c.clamp(Color::ZERO, Color::ONE);
    if clamped != c || !c.is_finite() {
        warnings.push(format!("material '{mtl}': {what} {c} clamped to [0, 1]"));
    }
    if clamped.is_finite() {
        clamped
    } else {
        Color::ZERO
    }
}

/// GGX roughness from a Phong exponent: `alpha = sqrt(2 / (Ns + 2))` (Walter et al. 2007's
/// Beckmann–Phong correspondence), clamped to [0.001, 1]; a missing `Ns` counts as 0.
pub fn phong_exponent_to_alpha(ns: f32) -> f32 {
    let ns = if ns.is_finite() { ns.max(0.0) } else { 0.0 };
    (2.0 / (ns + 2.0)).sqrt().clamp(1e-3, 1.0)
}

/// Convert one MTL material (see [`load_mesh_scene`] for the mapping). Returns the material and
/// the area emission, if any.
fn convert_mtl(m: &tobj::Material, mtl_dir: &Path, images: &mut Vec<Image>, warnings: &mut Vec<String>) -> (Material, Option<Color>) {
    let name = m.name.as_str();
    let kd = clamp_unit(color_of(m.diffuse).unwrap_or(Color::splat(DEFAULT_REFLECTANCE)), "Kd", name, warnings);
    let ks = clamp_unit(color_of(m.specular).unwrap_or(Color::ZERO), "Ks", name, warnings);
    let emission = color_of(m.emissive).filter(|e| e.is_finite() && e.max_element() > 0.0).map(|e| e.max(Color::ZERO));
    let ni = m.optical_density.filter(|n| n.is_finite() && *n > 0.0 && *n != 1.0);
    let illum = m.illumination_model;

    let mut diffuse = Texture::Const(kd);
    if let Some(tex) = &m.diffuse_texture {
        // `map_Kd` may carry options before the file name: try the whole string, then its last word.
        let candidates = [mtl_dir.join(tex), mtl_dir.join(tex.split_whitespace().last().unwrap_or(tex))];
        let file = candidates.iter().find(|p| p.is_file()).unwrap_or(&candidates[0]);
        match read_image(file) {
            Ok(img) => {
                images.push(img);
                diffuse = Texture::Bitmap { image: (images.len() - 1) as u32, uv_scale: Vec2::ONE };
            }
            Err(e) => warnings.push(format!("material '{name}': texture not loaded, using Kd instead: {e}")),
        }
    }
    let two_sided = |m: Material| Material::TwoSided { front: Box::new(m.clone()), back: Box::new(m) };

    let material = match illum {
        Some(5) => {
            let r = if ks.max_element() > 0.0 { ks } else { Color::ONE };
            two_sided(Material::Conductor { eta: Color::ZERO, k: Color::ZERO, specular_reflectance: r })
        }
        Some(7) => {
            let tf = m
                .unknown_param
                .get("Tf")
                .and_then(|s| {
                    let v: Vec<f32> = s.split_whitespace().filter_map(|t| t.parse().ok()).collect();
                    match v.as_slice() {
                        [g] => Some(Color::splat(*g)),
                        [r, g, b, ..] => Some(Color::new(*r, *g, *b)),
                        _ => None,
                    }
                })
                .map(|c| clamp_unit(c, "Tf", name, warnings))
                .unwrap_or(Color::ONE);
            Material::Dielectric { eta: ni.unwrap_or(1.5), specular_reflectance: Color::ONE, specular_transmittance: tf }
        }
        Some(0) | Some(1) => two_sided(Material::Diffuse { reflectance: diffuse }),
        _ if ks.max_element() > 0.0 => {
            let alpha = phong_exponent_to_alpha(m.shininess.unwrap_or(0.0));
            let black_base = matches!(diffuse, Texture::Const(c) if c.max_element() <= 1e-4);
            if black_base {
                two_sided(Material::RoughConductor { alpha, eta: Color::ZERO, k: Color::ZERO, specular_reflectance: ks })
            } else {
                let eta = ni.filter(|n| *n > 1.0).unwrap_or(1.5);
                two_sided(Material::RoughPlastic { diffuse_reflectance: diffuse, specular_reflectance: ks, alpha, eta })
            }
        }
        _ => two_sided(Material::Diffuse { reflectance: diffuse }),
    };
    if let Some(i) = illum.filter(|i| ![0, 1, 2, 5, 7].contains(i)) {
        warnings.push(format!("material '{name}': illum {i} is treated like illum 2 (Kd/Ks)"));
    }
    (material, emission)
}

/// A camera framing `bounds`: looking at its centre from the +z side, slightly above
/// (direction (0, 0.25, 1)), +y up, at the distance where the bounding sphere fits the
/// horizontal field of view [`MESH_SCENE_FOV`] with a 10% margin.
fn framing_camera(bounds: octolux::math::Bounds3) -> CameraDesc {
    let (center, radius) = bounds.bounding_sphere();
    let radius = radius.max(1e-6);
    let half = (MESH_SCENE_FOV.to_radians() * 0.5).sin();
    let dist = 1.1 * radius / half;
    let dir = Vec3::new(0.0, 0.25, 1.0).normalize();
    CameraDesc {
        to_world: look_at(center + dir * dist, center, Vec3::Y),
        fov_deg: MESH_SCENE_FOV,
        fov_axis: FovAxis::X,
        near_clip: 1e-3 * dist,
    }
}

/// Load an OBJ or PLY file as a scene of its own.
///
/// - OBJ: one shape per `usemtl` material (faces before any `usemtl`, or naming a material no
///   `mtllib` defines, get a grey diffuse of reflectance [`DEFAULT_REFLECTANCE`]). MTL
///   mapping: `Ke` > 0 makes the shape an area emitter of that radiance (front side only);
///   `illum 5` is a perfect mirror (`Conductor` with eta = k = 0, reflectance `Ks` or 1);
///   `illum 7` is smooth glass (`Dielectric`, eta = `Ni` when given and ≠ 1, else 1.5,
///   transmittance `Tf` or 1); `illum 0/1` is diffuse `Kd`; otherwise a non-zero `Ks` gives a
///   GGX `RoughPlastic` (diffuse `Kd`, specular `Ks`, eta `Ni` > 1 or 1.5) or, when `Kd` is
///   black, a `RoughConductor` with eta = k = 0 and reflectance `Ks`, both with roughness
///   [`phong_exponent_to_alpha`]`(Ns)`; with no `Ks`, diffuse `Kd` (default
///   [`DEFAULT_REFLECTANCE`]). `map_Kd` replaces `Kd` by the texture (not multiplied).
///   Colours are clamped to `[0, 1]`. All but glass are wrapped in `TwoSided`, because meshes
///   found in the wild often have inconsistent winding. Problems with the MTL file or its
///   textures are warnings, not errors.
/// - PLY: one two-sided diffuse shape of reflectance [`DEFAULT_REFLECTANCE`].
/// - Camera: see `framing_camera` (fov [`MESH_SCENE_FOV`] degrees along x); film 512x512, tent.
/// - Lighting: when no shape emits, a constant environment of radiance
///   [`DEFAULT_ENVIRONMENT_RADIANCE`] ("white furnace sky"), so that any mesh renders lit.
pub fn load_mesh_scene(path: &Path) -> Result<LoadedScene, IoError> {
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "mesh".into());
    let mut desc = SceneDesc { film: FilmDesc::default(), hints: SceneHints::default(), ..Default::default() };
    let default_material = Material::Diffuse { reflectance: Texture::Const(Color::splat(DEFAULT_REFLECTANCE)) };
    let default_material = Material::TwoSided { front: Box::new(default_material.clone()), back: Box::new(default_material) };
    let mut warnings;
    match lower_extension(path).as_str() {
        "ply" => {
            let (mesh, w) = load_mesh_checked(path)?;
            warnings = w;
            desc.materials.push(default_material);
            desc.shapes.push(ShapeDesc { name: stem, geometry: Geometry::Mesh(mesh), material: 0, emission: None, flip_normals: false });
        }
        "obj" => {
            let data = parse_obj(path)?;
            warnings = data.warnings;
            let dir = path.parent().map(Path::to_path_buf).unwrap_or_else(|| PathBuf::from("."));
            // Materials of all libraries, first definition wins.
            let mut mtl: HashMap<String, (tobj::Material, PathBuf)> = HashMap::new();
            for (lib, line) in &data.mtllibs {
                let lib_path = dir.join(lib);
                match tobj::load_mtl(&lib_path) {
                    Ok((mats, _)) => {
                        let lib_dir = lib_path.parent().map(Path::to_path_buf).unwrap_or_else(|| dir.clone());
                        for m in mats {
                            mtl.entry(m.name.clone()).or_insert((m, lib_dir.clone()));
                        }
                    }
                    Err(e) => warnings.push(format!(
                        "{}:{line}: material library '{}' not loaded ({e}); using default materials",
                        path.display(),
                        lib_path.display()
                    )),
                }
            }
            let mut by_material: Vec<Vec<usize>> = vec![Vec::new(); data.material_names.len()];
            for (t, &m) in data.tri_material.iter().enumerate() {
                by_material[m as usize].push(t);
            }
            for (slot, tris) in by_material.iter().enumerate() {
                if tris.is_empty() {
                    continue;
                }
                let name = &data.material_names[slot];
                let (material, emission) = match mtl.get(name) {
                    Some((m, mtl_dir)) => convert_mtl(m, mtl_dir, &mut desc.images, &mut warnings),
                    None => {
                        if !name.is_empty() {
                            warnings.push(format!(
                                "{}: material '{name}' is not defined by any material library; using the default",
                                path.display()
                            ));
                        }
                        (default_material.clone(), None)
                    }
                };
                let mut mesh = submesh(&data.mesh, tris);
                remove_degenerate_with_warning(path, &mut mesh, &mut warnings);
                if mesh.indices.is_empty() {
                    continue;
                }
                desc.materials.push(material);
                let shape_name = if name.is_empty() { stem.clone() } else { format!("{stem}:{name}") };
                desc.shapes.push(ShapeDesc {
                    name: shape_name,
                    geometry: Geometry::Mesh(mesh),
                    material: (desc.materials.len() - 1) as u32,
                    emission,
                    flip_normals: false,
                });
            }
            if desc.shapes.is_empty() {
                return Err(IoError::invalid(path, "the mesh has no (non-degenerate) triangles"));
            }
        }
        other => return Err(IoError::invalid(path, format!("unknown mesh format '.{other}' (expected .obj or .ply)"))),
    }
    desc.camera = framing_camera(desc.bounds());
    if desc.shapes.iter().all(|s| s.emission.is_none()) {
        desc.lights.push(Light::Constant { radiance: Color::splat(DEFAULT_ENVIRONMENT_RADIANCE) });
    }
    Ok(LoadedScene { desc, warnings })
}
