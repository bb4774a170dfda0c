//! Mitsuba `shape` plugins (`obj`, `ply`, `sphere`, `rectangle`, `cube`, `disk`) with their
//! bsdf and area emitter, transformed to world space.

use super::props::ColorKind;
use super::tree::{resolve_file, Elem};
use super::Builder;
use crate::IoError;
use glam::{Mat4, Vec3};
use octolux::scene::{Geometry, ShapeDesc, TriMesh};

impl<'t> Builder<'t> {
    pub(super) fn shape(&mut self, e: &'t Elem) -> Result<(), IoError> {
        let ty = e.req_attr("type")?;
        let p = self.props(e)?;
        let to_world = p.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
        let mut name = e.attr("id").map(str::to_string);
        let geometry = match ty {
            "obj" | "ply" => {
                let file = p.string("filename")?.ok_or_else(|| e.loc.error(format!("{} needs a \"filename\"", e.describe())))?;
                let path = resolve_file(&e.loc, file, &self.main_dir, self.search_dirs)
                    .ok_or_else(|| e.loc.error(format!("{}: mesh file \"{file}\" not found", e.describe())))?;
                let (mut mesh, warns) = crate::mesh::load_mesh_checked(&path)?;
                for w in warns {
                    self.warn(e, w);
                }
                if p.bool_or("face_normals", false)? {
                    mesh.normals = None;
                }
                if ty == "obj" && !p.bool_or("flip_tex_coords", true)? {
                    // The OBJ reader flips v like Mitsuba's default; undo it.
                    if let Some(uvs) = &mut mesh.uvs {
                        for uv in uvs.iter_mut() {
                            uv.y = 1.0 - uv.y;
                        }
                    }
                }
                mesh.transform(&to_world);
                if name.is_none() {
                    name = path.file_stem().map(|s| s.to_string_lossy().into_owned());
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
                if !(r > 0.0 && r.is_finite() && m.w_axis.is_finite()) {
                    return Err(e.loc.error(format!("{}: the sphere radius {r} must be positive", e.describe())));
                }
                Geometry::Sphere { center: m.w_axis.truncate(), radius: r }
            }
            "rectangle" => Geometry::Mesh(TriMesh::rectangle(&to_world)),
            "cube" => Geometry::Mesh(TriMesh::cube(&to_world)),
            "disk" => Geometry::Mesh(TriMesh::disk(&to_world, 128)),
            other => {
                self.warn(e, format!("unsupported shape type \"{other}\"; skipped"));
                return Ok(());
            }
        };
        if let Geometry::Mesh(m) = &geometry {
            if !m.positions.iter().all(|v| v.is_finite()) {
                return Err(e.loc.error(format!("{}: vertices are not finite (check to_world)", e.describe())));
            }
            if m.indices.is_empty() {
                self.warn(e, "the mesh has no triangles; skipped");
                return Ok(());
            }
        }
        let flip_normals = p.bool_or("flip_normals", false)?;
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
                    let radiance = self.color_param(&ep, "radiance", ColorKind::Unbounded, 1.0)?;
                    if !radiance.is_finite() {
                        return Err(em.loc.error(format!("{}: radiance {radiance} is not finite", em.describe())));
                    }
                    emission = Some(radiance);
                    ep.accept(&["sampling_weight"]);
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
            None => self.default_material(),
        };
        p.finish(&mut self.warnings);
        let name = name.unwrap_or_else(|| format!("{ty}@{}", e.loc));
        self.desc.shapes.push(ShapeDesc { name, geometry, material, emission, flip_normals });
        Ok(())
    }
}
