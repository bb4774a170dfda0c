//! Mitsuba `shape` plugins (`obj`, `ply`, `serialized`, `sphere`, `rectangle`, `cube`, `disk`)
//! with their bsdf and area emitter, transformed to world space.
//!
//! Meshes are placed as Mitsuba 3 places them (`mesh::place_mesh`): normals stored in the file
//! are transformed, missing ones are computed after the transform, and the winding is reversed
//! under a mirroring `to_world` where the normals are transformed ones, so that octolux's
//! winding normal (which decides the emitting side) is Mitsuba's shading normal. Degenerate
//! triangles are removed in world space with one warning; a mesh left without any triangle is
//! skipped with one warning (Mitsuba 3 loads such files and renders nothing of them).
//!
//! Nothing vanishes without a word (issue 12; docs/guide/errors.md, "No silent drop"): a singular
//! `to_world` (determinant 0: a zero scale) warns once, saying whether the shape was flattened
//! or, left with zero area, skipped; an area emitter on a shape of zero area (a zero scale, a
//! sphere of radius 0, a mesh of degenerate triangles) warns once at the emitter, since it emits
//! nothing (Mitsuba 3 renders nothing of it either).
//! `serialized` reads `shape_index` (0.6: `shapeIndex`), `face_normals` and, from Mitsuba 0.6
//! (Mitsuba 3 has no such parameter), `max_smooth_angle` (`maxSmoothAngle`: creases sharper than
//! the angle stay sharp, see `mesh::rebuild_topology`).

use super::props::{ColorKind, Props};
use super::tree::{resolve_file, Elem};
use super::Builder;
use crate::mesh::{load_mesh_raw, load_serialized, mirrors, orient_to_given_normals, place_mesh, rebuild_topology, NormalSource, RawMesh};
use crate::IoError;
use glam::{Mat4, Vec3};
use octolux::scene::{Geometry, ShapeDesc, TriMesh};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// How a shape's warning names a singular `to_world`.
const SINGULAR: &str = "to_world is singular (determinant 0)";

impl<'t> Builder<'t> {
    pub(super) fn shape(&mut self, e: &'t Elem) -> Result<(), IoError> {
        let ty = e.req_attr("type")?;
        let p = self.props(e)?;
        let to_world = p.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
        // In f64: a product of small scales must not underflow to a false 0.
        let singular = to_world.as_dmat4().determinant() == 0.0;
        let mut name = e.attr("id").map(str::to_string);
        // Mitsuba 3 turns a mirrored sphere inside out (see `sphere` below).
        let mut inside_out = false;
        // Whether a mesh file's normals come from the file (transformed by `to_world`).
        let mut normals_given = false;
        let mut geometry = match ty {
            "obj" | "ply" | "serialized" => {
                let (mesh, stem, given) = self.mesh_file(e, &p, ty, &to_world)?;
                normals_given = given;
                if name.is_none() {
                    name = Some(stem);
                }
                Geometry::Mesh(mesh)
            }
            "sphere" => {
                let center = p.vec3("center")?.unwrap_or(Vec3::ZERO);
                let radius = p.float_or("radius", 1.0)?;
                let m = to_world * Mat4::from_translation(center) * Mat4::from_scale(Vec3::splat(radius));
                let (x, y, z) = (m.x_axis.truncate(), m.y_axis.truncate(), m.z_axis.truncate());
                let r = x.length();
                let tol = 1e-4 * r;
                let similar = (y.length() - r).abs() <= tol
                    && (z.length() - r).abs() <= tol
                    && x.dot(y).abs() <= tol * r
                    && x.dot(z).abs() <= tol * r
                    && y.dot(z).abs() <= tol * r;
                if !similar || m.row(3) != glam::Vec4::W {
                    return Err(e
                        .loc
                        .error(format!("{}: to_world of a sphere may only rotate, translate and scale uniformly", e.describe())));
                }
                if !(r.is_finite() && m.w_axis.is_finite()) {
                    return Err(e.loc.error(format!("{}: the sphere radius {r} is not finite (check to_world)", e.describe())));
                }
                if r == 0.0 {
                    let why = if singular { SINGULAR } else { "the sphere has radius 0" };
                    self.warn(e, format!("{why}: the shape has zero area and is skipped"));
                    return self.zero_area_emitter(&p);
                }
                // Mitsuba 3 splits `to_world` into scale, rotation and translation with the
                // determinant's sign in the scale (Dr.Jit's `transform_decompose`): a mirror (a
                // negative scale, or a negative `radius`) turns the normals inward, so the sphere
                // then emits and reflects on its inside only (measured with Mitsuba 3.9.1;
                // `flip_normals` turns it back).
                inside_out = mirrors(&m);
                Geometry::Sphere { center: m.w_axis.truncate(), radius: r }
            }
            // Their normals are transformed ones (Mitsuba 3's inverse transpose): under a mirror
            // the winding is reversed to agree with them (see `mesh::normals`).
            "rectangle" | "cube" | "disk" => {
                let mut mesh = match ty {
                    "rectangle" => TriMesh::rectangle(&to_world),
                    "cube" => TriMesh::cube(&to_world),
                    _ => TriMesh::disk(&to_world, 128),
                };
                orient_to_given_normals(&mut mesh, &to_world);
                Geometry::Mesh(mesh)
            }
            other => {
                self.warn(e, format!("unsupported shape type \"{other}\"; skipped"));
                return Ok(());
            }
        };
        if let Geometry::Mesh(m) = &mut geometry {
            // The scene's meshes together: each file is checked alone when read, but a small
            // file may name one large mesh file in many shapes (each reads and places its own
            // copy), so the sum is checked as each shape adds to it.
            let (v, t) = self.mesh_totals;
            let (v, t) = (v + m.positions.len() as u64, t + m.indices.len() as u64);
            self.mesh_totals = (v, t);
            octolux::budget::check_mesh(v, t)
                .map_err(|b| e.loc.error(format!("{}: the scene's meshes together, with this one: {b}", e.describe())))?;
            if !m.positions.iter().all(|v| v.is_finite()) {
                return Err(e.loc.error(format!("{}: vertices are not finite (check to_world)", e.describe())));
            }
            // In world space, where a transform may also flatten triangles.
            let before = m.indices.len();
            let removed = m.remove_degenerate();
            if m.indices.is_empty() {
                let what = if before == 0 { "has no triangles".to_string() } else { format!("has only degenerate triangles ({before})") };
                if singular && before > 0 {
                    self.warn(e, format!("{SINGULAR}: the shape has zero area and is skipped"));
                } else {
                    self.warn(e, format!("the mesh {what}; the shape is skipped"));
                }
                return self.zero_area_emitter(&p);
            }
            if singular {
                // Mitsuba 3 transforms given normals (the analytic shapes', a file's) by the
                // inverse transpose of `to_world`, which does not exist here.
                let given = matches!(ty, "rectangle" | "cube" | "disk") || normals_given;
                let note = if given {
                    " (Mitsuba 3 cannot transform its normals by a singular matrix: it renders it black or refuses the file)"
                } else {
                    ""
                };
                self.warn(e, format!("{SINGULAR}: the shape is flattened{note}"));
            }
            if removed > 0 {
                self.warn(e, format!("removed {removed} degenerate triangle{} of {before}", if removed == 1 { "" } else { "s" }));
            }
        }
        let flip_normals = p.bool_or("flip_normals", false)? != inside_out;
        let mut material = None;
        let mut emission = None;
        for (i, o) in p.objects() {
            match o.target.tag.as_str() {
                "bsdf" => {
                    p.mark(i);
                    if material.is_some() {
                        return Err(o.elem.loc.error(format!("{} has more than one bsdf", e.describe())));
                    }
                    material = Some(self.material_index(o.target)?);
                }
                "emitter" => {
                    p.mark(i);
                    let em = o.target;
                    let ety = em.req_attr("type")?;
                    if ety != "area" {
                        self.warn(em, format!("emitter type \"{ety}\" cannot be attached to a shape; ignored"));
                        continue;
                    }
                    if emission.is_some() {
                        return Err(em.loc.error(format!("{} has more than one area emitter", e.describe())));
                    }
                    let ep = self.props(em)?;
                    let radiance = self.color_param(&ep, "radiance", ColorKind::Emission, 1.0)?;
                    if !radiance.is_finite() {
                        return Err(em.loc.error(format!("{}: radiance {radiance} is not finite", em.describe())));
                    }
                    emission = Some(radiance);
                    self.sampling_weight(em, &ep)?;
                    ep.finish(&mut self.warnings);
                }
                "medium" => {
                    p.mark(i);
                    self.warn(o.target, "participating media are not supported; ignored");
                }
                _ => {}
            }
        }
        let material = match material {
            Some(m) => m,
            None if emission.is_some() => self.default_emitter_material(),
            None => self.default_material(),
        };
        p.finish(&mut self.warnings);
        let name = name.unwrap_or_else(|| format!("{ty}@{}", e.loc));
        self.desc.shapes.push(ShapeDesc { name, geometry, material, emission, flip_normals });
        Ok(())
    }
    /// After a shape of zero area was skipped: one warning at each area emitter it carries.
    fn zero_area_emitter(&mut self, p: &Props<'t>) -> Result<(), IoError> {
        for (_, o) in p.objects() {
            if o.target.tag == "emitter" && o.target.attr("type") == Some("area") {
                self.warn(o.target, "its shape has zero area: the emitter emits nothing");
            }
        }
        Ok(())
    }

    /// Load the mesh file of an `obj`, `ply` or `serialized` shape and place it in world space.
    /// Returns the mesh, a default shape name (file stem, `@index` for serialized) and whether
    /// its normals come from the file.
    fn mesh_file(&mut self, e: &'t Elem, p: &Props<'t>, ty: &str, to_world: &Mat4) -> Result<(TriMesh, String, bool), IoError> {
        let file = p.string("filename")?.ok_or_else(|| e.loc.error(format!("{} needs a \"filename\"", e.describe())))?;
        let path = resolve_file(&e.loc, file, &self.main_dir, self.search_dirs)
            .ok_or_else(|| e.loc.error(format!("{}: mesh file \"{file}\" not found", e.describe())))?;
        let mut stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| ty.to_string());
        let face_normals = p.bool_or("face_normals", false)?;
        let (mut mesh, from_file, file_face_normals) = if ty == "serialized" {
            let index = p.int("shape_index")?.unwrap_or(0);
            let Ok(index) = u32::try_from(index) else {
                return Err(e.loc.error(format!("{}: shape_index {index} must be a non-negative integer", e.describe())));
            };
            let s = load_serialized(&path, index).map_err(|err| e.loc.error(format!("{}: {err}", e.describe())))?;
            for w in s.warnings {
                self.warn(e, w);
            }
            stem = format!("{stem}@{index}");
            (s.mesh, s.normals_from_file, s.face_normals)
        } else {
            let raw = match self.prefetched.remove(&path) {
                Some(read) => read?,
                None => load_mesh_raw(&path)?,
            };
            for w in raw.warnings {
                self.warn(e, w);
            }
            (raw.mesh, raw.normals_from_file, false)
        };
        if ty == "obj" && !p.bool_or("flip_tex_coords", true)? {
            // The OBJ reader flips v like Mitsuba's default; undo it.
            if let Some(uvs) = &mut mesh.uvs {
                for uv in uvs.iter_mut() {
                    uv.y = 1.0 - uv.y;
                }
            }
        }
        let source = if face_normals || file_face_normals {
            NormalSource::Face
        } else if from_file {
            NormalSource::Given
        } else {
            NormalSource::Computed
        };
        let given = match p.float("max_smooth_angle")? {
            Some(angle) => {
                if face_normals {
                    return Err(e.loc.error(format!("{}: give either max_smooth_angle or face_normals, not both", e.describe())));
                }
                if !(0.0..=180.0).contains(&angle) {
                    return Err(e.loc.error(format!("{}: max_smooth_angle {angle} must lie in [0, 180] degrees", e.describe())));
                }
                place_mesh(&mut mesh, to_world, NormalSource::Face);
                mesh = rebuild_topology(&mesh, angle);
                false
            }
            None => {
                place_mesh(&mut mesh, to_world, source);
                source == NormalSource::Given
            }
        };
        Ok((mesh, stem, given))
    }
}

/// The OBJ and PLY files of the scene's top-level shapes, read in parallel (rayon's pool) before
/// the scene is built in document order: [`Builder::mesh_file`] takes each file's result from
/// here the first time it meets it (the same mesh, warnings or error as reading it then; a
/// file used twice is read again the second time). Files that cannot be found are left to
/// `mesh_file`'s error.
pub(super) fn prefetch_meshes(root: &Elem, main_dir: &Path, search_dirs: &[PathBuf]) -> HashMap<PathBuf, Result<RawMesh, IoError>> {
    use rayon::prelude::*;
    let mut paths: Vec<PathBuf> = Vec::new();
    for e in root.children.iter().filter(|c| c.tag == "shape" && matches!(c.attr("type"), Some("obj" | "ply"))) {
        let file = e.children.iter().find(|c| c.tag == "string" && c.attr("name") == Some("filename")).and_then(|c| c.attr("value"));
        if let Some(path) = file.and_then(|f| resolve_file(&e.loc, f, main_dir, search_dirs)) {
            if !paths.contains(&path) {
                paths.push(path);
            }
        }
    }
    paths
        .into_par_iter()
        .map(|p| {
            let read = load_mesh_raw(&p);
            (p, read)
        })
        .collect()
}
