//! The scene as triangles for a rasteriser (issue 28: `octolux view` draws the scene in a
//! browser and lights it with the octree evaluated on the GPU).
//!
//! Every triangle of the meshes, and the analytic spheres tessellated (48 x 24 quads each; in a
//! scene of more than about 170 spheres fewer per sphere, down to 8 x 4, so that the spheres
//! take at most [`SPHERE_QUADS`] quads while that suffices: [`sphere_rings`]), with
//! per-vertex shading normals (the mesh's interpolated normals where it has them, the
//! triangle's winding normal otherwise; spheres: the exact normal) and per-vertex Lambertian
//! albedo (the material's diffuse reflectance at the vertex's texture coordinates; a material
//! without a Lambertian part draws as 0.5 grey, and says so in [`DisplayMesh::grey_materials`]),
//! and per-vertex emitted radiance (an area emitter's, towards the side its normal faces: the
//! emitting side, as `LightSet::area_le` counts it; zero elsewhere).

use super::{Light, Scene};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Triangles for a rasteriser, not indexed: vertex `3 t + k` is corner `k` of triangle `t`.
#[derive(Clone, Debug, Default)]
pub struct DisplayMesh {
    /// World positions.
    pub positions: Vec<Vec3>,
    /// Unit shading normals (the front side of the shape).
    pub normals: Vec<Vec3>,
    /// Lambertian albedo (RGB, in [0, 1]).
    pub albedo: Vec<Vec3>,
    /// Emitted radiance (RGB, W/(m² sr)) towards the side the normal faces; zero for shapes
    /// that do not emit.
    pub emission: Vec<Vec3>,
    /// Materials drawn grey (no Lambertian reflectance), by index.
    pub grey_materials: Vec<u32>,
}

/// The grey of a material without a Lambertian part.
const GREY: Vec3 = Vec3::splat(0.5);

/// Quads all the spheres of a scene may take (each 6 vertices of 48 bytes in the viewer's
/// buffer: about 58 MB), unless each is already at the fewest [`sphere_rings`] gives.
pub const SPHERE_QUADS: usize = 200_000;

/// Rings of latitude of each sphere's tessellation (twice as many segments of longitude) in a
/// scene of `n` spheres: 24 while the spheres fit [`SPHERE_QUADS`], fewer when they do not,
/// at least 4. (At 24 x 48 quads each, a thousand spheres made a 330 MB buffer.)
pub fn sphere_rings(n: usize) -> usize {
    let fit = ((SPHERE_QUADS / n.max(1) / 2) as f64).sqrt() as usize;
    fit.clamp(4, 24)
}

impl Scene {
    /// The scene as triangles (module docs).
    pub fn display_mesh(&self) -> DisplayMesh {
        let mut out = DisplayMesh::default();
        let albedo = |material: u32, uv: Vec2, out_grey: &mut Vec<u32>| -> Vec3 {
            match self.materials[material as usize].lambertian_albedo(&self.images, uv, Vec3::Z) {
                Some(c) if c.is_finite() => c.clamp(Vec3::ZERO, Vec3::ONE),
                _ => {
                    if !out_grey.contains(&material) {
                        out_grey.push(material);
                    }
                    GREY
                }
            }
        };
        let emission = |shape: u32| -> Vec3 {
            match self.lights.shape_light(shape).and_then(|l| self.lights.lights.get(l as usize)) {
                Some(Light::Area { radiance, .. }) if radiance.is_finite() => radiance.max(Vec3::ZERO),
                _ => Vec3::ZERO,
            }
        };
        for (t, &s) in self.flat.triangles.iter().zip(&self.flat.tri_shape) {
            let info = &self.flat.shapes[s as usize];
            let le = emission(s);
            let p = t.map(|k| self.flat.positions[k as usize]);
            let mut ng = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
            if info.flip {
                ng = -ng;
            }
            for (c, &k) in t.iter().enumerate() {
                out.positions.push(p[c]);
                let n = if info.has_normals { self.flat.shading[k as usize].n.normalize_or_zero() } else { ng };
                out.normals.push(if info.flip && info.has_normals { -n } else { n });
                let uv = if info.has_uvs { self.flat.shading[k as usize].uv } else { Vec2::ZERO };
                out.albedo.push(albedo(info.material, uv, &mut out.grey_materials));
                out.emission.push(le);
            }
        }
        let nt = sphere_rings(self.flat.spheres.len());
        let np = 2 * nt;
        for sphere in &self.flat.spheres {
            let info = &self.flat.shapes[sphere.shape as usize];
            let sign = if info.flip { -1.0 } else { 1.0 };
            let dir = |i: usize, j: usize| {
                let (th, ph) = (PI * i as f32 / nt as f32, 2.0 * PI * j as f32 / np as f32);
                Vec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos())
            };
            let a = albedo(info.material, Vec2::splat(0.5), &mut out.grey_materials);
            let le = emission(sphere.shape);
            for i in 0..nt {
                for j in 0..np {
                    for (di, dj) in [(0, 0), (1, 0), (1, 1), (0, 0), (1, 1), (0, 1)] {
                        let d = dir(i + di, j + dj);
                        out.positions.push(sphere.center + sphere.radius * d);
                        out.normals.push(sign * d);
                        out.albedo.push(a);
                        out.emission.push(le);
                    }
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::{sphere_rings, SPHERE_QUADS};
    use crate::accel::BackendKind;
    use crate::integrators::test_scenes::{box_desc, box_scene};
    use crate::scene::{Geometry, Scene, ShapeDesc};
    use glam::Vec3;

    /// A few spheres keep the full tessellation, many stay within the budget, and the display
    /// mesh holds the triangles the rings say.
    #[test]
    fn many_spheres_share_a_bounded_tessellation() {
        assert_eq!(sphere_rings(1), 24);
        assert_eq!(sphere_rings(150), 24);
        assert!(sphere_rings(1000) < 24 && 2 * sphere_rings(1000).pow(2) * 1000 <= SPHERE_QUADS);
        assert_eq!(sphere_rings(1_000_000), 4);
        for n in [2usize, 3000] {
            let mut desc = box_desc();
            let box_vertices = 7 * 2 * 3; // the box's six walls and its light, two triangles each
            for i in 0..n {
                let c = Vec3::new(-0.9 + 1.8 * (i % 50) as f32 / 50.0, 0.1 + 1.8 * (i / 50 % 50) as f32 / 50.0, -0.5);
                desc.shapes.push(ShapeDesc {
                    name: format!("ball {i}"),
                    geometry: Geometry::Sphere { center: c, radius: 0.01 },
                    material: 0,
                    emission: None,
                    flip_normals: false,
                });
            }
            let m = Scene::prepare(desc, BackendKind::Bvh).expect("valid").display_mesh();
            let rings = sphere_rings(n);
            assert_eq!(m.positions.len(), box_vertices + n * (rings * 2 * rings) * 6, "n = {n}");
            assert_eq!(rings, if n == 2 { 24 } else { 5 });
        }
    }

    /// The test box's ceiling light (radiance 15, facing down, at y = 1.99) is the only
    /// emitting surface of the display mesh, and its normals face the emitting side.
    #[test]
    fn emitters_carry_their_radiance_on_their_emitting_side() {
        let scene = box_scene(8);
        let m = scene.display_mesh();
        assert_eq!(m.emission.len(), m.positions.len());
        let lit: Vec<usize> = (0..m.positions.len()).filter(|&i| m.emission[i] != Vec3::ZERO).collect();
        assert_eq!(lit.len(), 6, "one quad, two triangles");
        for i in lit {
            assert_eq!(m.emission[i], Vec3::splat(15.0));
            assert!((m.positions[i].y - 1.99).abs() < 1e-4, "{}", m.positions[i]);
            assert!(m.normals[i].y < -0.99, "the light emits downwards: {}", m.normals[i]);
        }
    }
}
