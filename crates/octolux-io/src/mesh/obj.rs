//! OBJ meshes (and their MTL materials when an OBJ file is rendered as a scene); conventions in
//! the documentation of [`super`].

use super::{
    compute_vertex_normals, merge_normals, push_fan, read_file, remove_degenerate_with_warning, RawMesh, VertexMap, DEFAULT_REFLECTANCE,
};
use crate::IoError;
use glam::{Vec2, Vec3};
use octolux::image::Image;
use octolux::math::Color;
use octolux::scene::material::{Material, Microfacet, MicrofacetKind, Texture};
use octolux::scene::{Geometry, SceneDesc, ShapeDesc, TriMesh};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

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
    /// True when faces reference `vn` normals.
    normals_from_file: bool,
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
    parse_obj_bytes(path, &read_file(path)?)
}

/// Triangles between two memory-budget checks while reading an OBJ file (its sizes are not
/// declared up front; they grow with the file).
const BUDGET_STEP: usize = 1 << 20;

fn parse_obj_bytes(path: &Path, bytes: &[u8]) -> Result<ObjData, IoError> {
    // (valid UTF-8, the usual case, is checked by the faster `from_utf8`; the text is the same)
    let text = match std::str::from_utf8(bytes) {
        Ok(t) => std::borrow::Cow::Borrowed(t),
        Err(_) => String::from_utf8_lossy(bytes),
    };

    let mut v: Vec<Vec3> = Vec::new();
    let mut vt: Vec<Vec2> = Vec::new();
    let mut vn: Vec<Vec3> = Vec::new();
    // (position, texcoord + 1 or 0, normal + 1 or 0) -> output vertex
    let mut vertex_map: VertexMap<(u32, u32, u32), u32> = VertexMap::default();
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
        let content = raw.as_bytes().iter().position(|&b| b == b'#').map_or(raw, |i| &raw[..i]);
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
                if before / BUDGET_STEP != (before + poly.len()) / BUDGET_STEP {
                    octolux::budget::check_mesh(out_pos.len() as u64, (before + poly.len()) as u64)
                        .map_err(|e| IoError::parse(path, line, e.to_string()))?;
                }
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
    let normals_from_file = out_n.iter().any(|n| n.is_some());
    let normals = if normals_from_file {
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
        normals_from_file,
    })
}

/// Load an OBJ file as one world-space mesh (all groups merged), with Mitsuba 3's conventions
/// (see the documentation of [`super`]). Degenerate triangles are kept; see [`super::load_mesh_checked`].
pub fn load_obj_mesh(path: &Path) -> Result<TriMesh, IoError> {
    Ok(parse_obj(path)?.mesh)
}

/// Read an OBJ mesh from its bytes (all groups merged, materials ignored); `path` names it in
/// messages. This is also the entry point of the `obj` fuzz target.
pub fn parse_obj_mesh(path: &Path, bytes: &[u8]) -> Result<RawMesh, IoError> {
    let d = parse_obj_bytes(path, bytes)?;
    Ok(RawMesh { mesh: d.mesh, normals_from_file: d.normals_from_file, warnings: d.warnings })
}

/// The merged mesh of an OBJ file and the warnings of reading it.
pub(super) fn load_obj_with_warnings(path: &Path) -> Result<RawMesh, IoError> {
    let d = parse_obj(path)?;
    Ok(RawMesh { mesh: d.mesh, normals_from_file: d.normals_from_file, warnings: d.warnings })
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

/// The isotropic GGX distribution of roughness `alpha`.
fn ggx(alpha: f32) -> Microfacet {
    Microfacet::isotropic(MicrofacetKind::Ggx, alpha)
}

/// GGX roughness from a Phong exponent: `alpha = sqrt(2 / (Ns + 2))` (Walter et al. 2007's
/// Beckmann–Phong correspondence), clamped to [0.001, 1]; a missing `Ns` counts as 0.
pub fn phong_exponent_to_alpha(ns: f32) -> f32 {
    let ns = if ns.is_finite() { ns.max(0.0) } else { 0.0 };
    (2.0 / (ns + 2.0)).sqrt().clamp(1e-3, 1.0)
}

/// The sub-mesh made of the triangles `tris` of `mesh`, with only the vertices they use.
fn submesh(mesh: &TriMesh, tris: &[usize]) -> TriMesh {
    let mut remap: VertexMap<u32, u32> = VertexMap::default();
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

/// Convert one MTL material (see [`super::load_mesh_scene`] for the mapping). Returns the material and
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
        let file = candidates.iter().find(|p| p.exists()).unwrap_or(&candidates[0]);
        match crate::image_io::read_texture(file) {
            Ok((img, negative)) => {
                warnings.extend(negative);
                images.push(img);
                diffuse = Texture::bitmap((images.len() - 1) as u32, Vec2::ONE);
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
                two_sided(Material::RoughConductor {
                    distribution: ggx(alpha).into(),
                    eta: Color::ZERO,
                    k: Color::ZERO,
                    specular_reflectance: ks,
                })
            } else {
                let eta = ni.filter(|n| *n > 1.0).unwrap_or(1.5);
                two_sided(Material::RoughPlastic {
                    diffuse_reflectance: diffuse,
                    specular_reflectance: ks,
                    distribution: ggx(alpha),
                    eta,
                    nonlinear: false,
                })
            }
        }
        _ => two_sided(Material::Diffuse { reflectance: diffuse }),
    };
    if let Some(i) = illum.filter(|i| ![0, 1, 2, 5, 7].contains(i)) {
        warnings.push(format!("material '{name}': illum {i} is treated like illum 2 (Kd/Ks)"));
    }
    (material, emission)
}

/// The shapes of an OBJ file rendered as a scene: one per `usemtl` material (see
/// [`super::load_mesh_scene`] for the mapping). Returns the warnings.
pub(super) fn obj_scene(path: &Path, desc: &mut SceneDesc, default_material: &Material) -> Result<Vec<String>, IoError> {
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "mesh".into());
    let data = parse_obj(path)?;
    let mut warnings = data.warnings;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_else(|| PathBuf::from("."));
    // Materials of all libraries, first definition wins.
    let mut mtl: HashMap<String, (tobj::Material, PathBuf)> = HashMap::new();
    for (lib, line) in &data.mtllibs {
        let lib_path = dir.join(lib);
        let read = crate::files::read(&lib_path)
            .map_err(|e| e.to_string())
            .and_then(|bytes| tobj::load_mtl_buf(&mut std::io::Cursor::new(bytes)).map_err(|e| e.to_string()));
        match read {
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
                    warnings
                        .push(format!("{}: material '{name}' is not defined by any material library; using the default", path.display()));
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
    Ok(warnings)
}
