//! Triangle meshes: OBJ (`obj`, with MTL), PLY (`ply`) and Mitsuba's compressed `serialized`
//! format (`serialized`), read the way Mitsuba 3's shapes read them; their normals and their
//! placement in a scene with Mitsuba 3's orientation (`normals`); mesh files rendered directly
//! as scenes (here).
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
//!   The Mitsuba loader places meshes with [`place_mesh`], which recomputes such normals after
//!   the transform (Mitsuba 3's order) and orients mirrored meshes as Mitsuba 3 does.
//! - Non-finite positions and out-of-range indices are errors naming the file, with the line
//!   for OBJ and ascii PLY (the element number for binary PLY). [`load_mesh_checked`] also
//!   removes degenerate triangles and reports them as warnings.
//!
//! [`load_mesh_scene`] renders a mesh file on its own; its material mapping and default camera
//! and lighting are documented there.

mod normals;
mod obj;
mod ply;
mod serialized;

pub use normals::{compute_vertex_normals, mirrors, orient_to_given_normals, place_mesh, rebuild_topology, NormalSource};
pub use obj::{load_obj_mesh, parse_obj_mesh, phong_exponent_to_alpha};
pub use ply::{load_ply_mesh, parse_ply};
pub use serialized::{load_serialized, parse_serialized, serialized_shape_count, SerializedMesh, SERIALIZED_MAGIC};

use normals::merge_normals;

use crate::{IoError, LoadedScene};
use glam::Vec3;
use octolux::math::Color;
use octolux::scene::camera::{look_at, CameraDesc, FovAxis};
use octolux::scene::material::{Material, Texture};
use octolux::scene::Light;
use octolux::scene::{FilmDesc, Geometry, SceneDesc, SceneHints, ShapeDesc, TriMesh};
use std::path::Path;

// ---------------------------------------------------------------------------------------------
// Shared helpers
// ---------------------------------------------------------------------------------------------

/// Hasher of the meshes' vertex maps (small integer keys: OBJ corner triples, vertex groups):
/// the multiply–rotate hash of rustc's `FxHasher`, several times cheaper than the default
/// SipHash there. The maps' contents and the order of first appearance that the loaders keep
/// do not depend on the hash.
#[derive(Clone, Copy, Default)]
pub(crate) struct VertexHasher(u64);

impl std::hash::Hasher for VertexHasher {
    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        for c in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..c.len()].copy_from_slice(c);
            self.write_u64(u64::from_le_bytes(word));
        }
    }
    #[inline]
    fn write_u32(&mut self, v: u32) {
        self.write_u64(v as u64);
    }
    #[inline]
    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(0x517c_c1b7_2722_0a95);
    }
    #[inline]
    fn write_usize(&mut self, v: usize) {
        self.write_u64(v as u64);
    }
    #[inline]
    fn finish(&self) -> u64 {
        self.0
    }
}

/// A hash map keyed by vertex indices, with [`VertexHasher`].
pub(crate) type VertexMap<K, V> = std::collections::HashMap<K, V, std::hash::BuildHasherDefault<VertexHasher>>;

fn lower_extension(path: &Path) -> String {
    path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()).unwrap_or_default()
}

fn read_file(path: &Path) -> Result<Vec<u8>, IoError> {
    crate::files::read(path)
}

/// Fan triangulation `(v0, v_k, v_k+1)` of a polygon, appended to `out`.
fn push_fan(poly: &[u32], out: &mut Vec<[u32; 3]>) {
    for k in 1..poly.len().saturating_sub(1) {
        out.push([poly[0], poly[k], poly[k + 1]]);
    }
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

/// An OBJ or PLY mesh as read (object space, degenerate triangles kept).
#[derive(Clone, Debug)]
pub struct RawMesh {
    /// The mesh; its normals are the file's where it has them, computed elsewhere.
    pub mesh: TriMesh,
    /// True when the file gives vertex normals (then they are transformed with the mesh; else
    /// they are recomputed after the transform, see [`NormalSource`]).
    pub normals_from_file: bool,
    /// Problems met while reading, each naming the file.
    pub warnings: Vec<String>,
}

/// Read a `.obj` or `.ply` mesh (by extension, case-insensitive) without removing anything.
pub fn load_mesh_raw(path: &Path) -> Result<RawMesh, IoError> {
    crate::files::refuse_non_regular(path)?;
    match lower_extension(path).as_str() {
        "obj" => obj::load_obj_with_warnings(path),
        "ply" => ply::load_ply_with_warnings(path),
        _ => Err(crate::files::unknown_format(path, "mesh", ".obj or .ply")),
    }
}

/// Load a `.obj` or `.ply` mesh (by extension, case-insensitive), remove degenerate triangles
/// and return the warnings collected (each naming the file). A file with no usable triangle is
/// an error.
pub fn load_mesh_checked(path: &Path) -> Result<(TriMesh, Vec<String>), IoError> {
    let RawMesh { mut mesh, mut warnings, .. } = load_mesh_raw(path)?;
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

/// A camera framing `bounds`: looking at its centre from the +z side, slightly above
/// (direction (0, 0.25, 1)), +y up, at the distance where the bounding sphere fits the
/// horizontal field of view [`MESH_SCENE_FOV`] with a 10% margin.
pub(crate) fn framing_camera(bounds: octolux::math::Bounds3) -> CameraDesc {
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
    let warnings;
    match lower_extension(path).as_str() {
        "ply" => {
            let (mesh, w) = load_mesh_checked(path)?;
            warnings = w;
            desc.materials.push(default_material);
            desc.shapes.push(ShapeDesc { name: stem, geometry: Geometry::Mesh(mesh), material: 0, emission: None, flip_normals: false });
        }
        "obj" => {
            warnings = obj::obj_scene(path, &mut desc, &default_material)?;
        }
        _ => return Err(crate::files::unknown_format(path, "mesh", ".obj or .ply")),
    }
    desc.camera = framing_camera(desc.bounds());
    if desc.shapes.iter().all(|s| s.emission.is_none()) {
        desc.lights.push(Light::Constant { radiance: Color::splat(DEFAULT_ENVIRONMENT_RADIANCE) });
    }
    Ok(LoadedScene { desc, warnings, sensors: Vec::new(), notes: Vec::new() })
}
