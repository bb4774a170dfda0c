//! The prepared scene: a [`SceneDesc`] turned into what rendering reads — one flat triangle
//! array inside a ray-intersection backend, analytic spheres, a light set — plus the
//! computation of a full [`SurfaceHit`] (position, normals, uv, material, emitter) from a hit.
//!
//! Invariant: built once by [`Scene::prepare`], then only read (shared across threads without
//! locks).
//!
//! The scene's rooms, upstream to downstream (no module imports one further down):
//! - [`camera`]: camera description and the prepared pinhole camera;
//! - [`material`]: the BSDFs (closed enum), their Fresnel, microfacet and texture pieces;
//! - [`envmap`], [`sunsky`]: the environment emitters' models (latitude-longitude map; Mitsuba
//!   3's sun and sky with its tables), with their importance sampling;
//! - [`desc`]: the plain-data description loaders produce ([`SceneDesc`], shapes, meshes,
//!   film, the light enum [`Light`]), with its validation;
//! - [`environment`]: the prepared environment emitters behind one enum;
//! - [`lights`]: the prepared [`lights::LightSet`] that samples the lights;
//! - this module: the prepared [`Scene`] and its [`SurfaceHit`]; `prepare.rs` makes it
//!   ([`Scene::prepare`], and [`Scene::prepare_adding`] for an object added to a prepared scene,
//!   sharing its intersection structure, textures and lights).

pub mod camera;
pub mod camera_path;
pub mod desc;
pub mod display;
pub mod environment;
pub mod envmap;
pub mod fingerprint;
pub mod lights;
pub mod material;
pub mod object_path;
mod prepare;
mod spheres;
pub mod sunsky;

pub use desc::{FilmDesc, Geometry, Light, PixelFilter, SceneDesc, SceneError, SceneHints, ShapeDesc, TriMesh};
pub use fingerprint::LightingFingerprint;
pub use prepare::Addition;

use crate::accel::layered::LayeredAccel;
use crate::image::Image;
use crate::math::{bary, offset_origin, Bounds3, Frame, Ray, RayDifferential};
use camera::Camera;
use glam::{Vec2, Vec3};
use lights::LightSet;
use material::{Material, TexCoord};
use std::f32::consts::PI;
use std::ops::Range;

/// An analytic sphere of the prepared scene.
#[derive(Clone, Copy, Debug)]
pub struct SphereShape {
    pub center: Vec3,
    pub radius: f32,
    pub shape: u32,
}

/// Everything known about a ray–surface intersection.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceHit {
    pub p: Vec3,
    pub t: f32,
    /// Geometric normal (triangle winding / sphere outward, flipped by `flip_normals`).
    pub ng: Vec3,
    /// Shading frame; `frame.n` is the shading normal (interpolated vertex normals when present),
    /// perturbed by a `bumpmap` or `normalmap` material ([`material::bump`]).
    pub frame: Frame,
    /// The shading normal before any bump or normal map (`frame.n` when there is none), for
    /// [`SurfaceHit::shading_factor`].
    pub base_n: Vec3,
    /// Terminator-shadowing parameter `α²` of a bump or normal map (0 without one).
    pub terminator_alpha2: f32,
    /// Texture coordinates, with their screen-space partials at camera hits (zero elsewhere;
    /// see [`SurfaceHit::set_ray_differential`]).
    pub uv: TexCoord,
    /// Position derivatives with respect to uv (world units per unit of uv, not normalised),
    /// as Mitsuba 3 defines them: from the triangle's uvs (its edges `p1 - p0`, `p2 - p0` when
    /// the mesh has none, its uvs then being the barycentrics), analytic on spheres.
    pub dp_du: Vec3,
    pub dp_dv: Vec3,
    pub shape: u32,
    pub material: u32,
    /// Area light on this shape, if it emits.
    pub light: Option<u32>,
}

impl SurfaceHit {
    /// Origin for a ray leaving this surface in direction `d`.
    #[inline]
    pub fn spawn(&self, d: Vec3) -> Ray {
        Ray::new(offset_origin(self.p, self.ng, d), d)
    }
    /// Give `uv` the partials `∂uv/∂x`, `∂uv/∂y` implied by the camera ray's differential:
    /// Mitsuba 0.6's `Intersection::computePartials` — the offset rays meet the tangent plane
    /// (geometric normal), and the offsets of those points solve `dp = dp_du du + dp_dv dv` on
    /// the two axes where the normal is smallest. Zero partials when the plane is parallel to
    /// an offset ray or the uv parametrisation is degenerate.
    pub fn set_ray_differential(&mut self, rd: &RayDifferential) {
        self.uv.duv_dx = Vec2::ZERO;
        self.uv.duv_dy = Vec2::ZERO;
        if self.dp_du == Vec3::ZERO && self.dp_dv == Vec3::ZERO {
            return;
        }
        let n = self.ng;
        let pp = n.dot(self.p);
        let (prx, pry) = (n.dot(rd.d_x), n.dot(rd.d_y));
        if prx == 0.0 || pry == 0.0 {
            return;
        }
        let tx = (pp - n.dot(rd.o_x)) / prx;
        let ty = (pp - n.dot(rd.o_y)) / pry;
        let (px, py) = (rd.o_x + rd.d_x * tx, rd.o_y + rd.d_y * ty);
        let a = n.abs();
        let (i, j) = if a.x > a.y && a.x > a.z {
            (1, 2)
        } else if a.y > a.z {
            (0, 2)
        } else {
            (0, 1)
        };
        let (a00, a01, a10, a11) = (self.dp_du[i], self.dp_dv[i], self.dp_du[j], self.dp_dv[j]);
        let det = a00 * a11 - a01 * a10;
        if det == 0.0 || !det.is_finite() {
            return;
        }
        let solve = |b0: f32, b1: f32| Vec2::new((a11 * b0 - a01 * b1) / det, (a00 * b1 - a10 * b0) / det);
        let (dx, dy) = (px - self.p, py - self.p);
        let (ddx, ddy) = (solve(dx[i], dx[j]), solve(dy[i], dy[j]));
        if ddx.is_finite() && ddy.is_finite() {
            self.uv.duv_dx = ddx;
            self.uv.duv_dy = ddy;
        }
    }

    /// A segment from this surface towards the point at distance `dist` along unit `d`,
    /// stopping short of it by a thousandth (for shadow rays). As Mitsuba 3's `spawn_ray_to`,
    /// the segment aims from the offset origin at the end point itself: parallel to `d`, its
    /// end would be shifted by the origin's offset (`1e-4 (1 + max |p_i|)`, not relative to
    /// the scene), which in a scene a few centimetres across goes through the face of a thin
    /// emitter before the end and occludes most light samples (the random-scene property test,
    /// seed 165: direct light 50x too dark at 2 cm, right at 1 m).
    #[inline]
    pub fn spawn_to(&self, d: Vec3, dist: f32) -> Ray {
        let o = offset_origin(self.p, self.ng, d);
        if dist.is_finite() {
            let v = self.p + d * dist - o;
            let len = v.length();
            if len > 0.0 && len.is_finite() {
                return Ray::segment(o, v / len, len * (1.0 - 1e-3));
            }
        }
        Ray::segment(o, d, dist * (1.0 - 1e-3))
    }
    /// The factor Mitsuba 3's `bumpmap` and `normalmap` apply to the nested BSDF's value and
    /// sample weight for the unit world direction `w` (module [`material::bump`]): 0 when `w`
    /// lies on different sides of the perturbed and the unperturbed shading planes, else the
    /// terminator shadowing (1 without a perturbation). Integrators multiply `eval` and
    /// `sample` weights by it (not pdfs).
    #[inline]
    pub fn shading_factor(&self, w: Vec3) -> f32 {
        let c0 = w.dot(self.base_n);
        if !(c0 * w.dot(self.frame.n) > 0.0) {
            return 0.0;
        }
        material::bump::terminator_shadowing(self.terminator_alpha2, c0)
    }
}

/// Per-shape data needed at shading time.
#[derive(Clone, Debug)]
struct ShapeInfo {
    material: u32,
    flip: bool,
    has_normals: bool,
    has_uvs: bool,
    name: String,
}

/// A vertex's shading normal (not normalised) and uv.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct VertexShading {
    n: Vec3,
    uv: Vec2,
}

/// A scene's shapes as the prepared scene holds them (`prepare.rs` fills it): one list of
/// vertices and triangles, the analytic spheres, and what each shape is.
#[derive(Clone, Default)]
struct Flat {
    positions: Vec<Vec3>,
    /// Each vertex's shading normal and uv, side by side: a hit reads both from one place
    /// (zero where its shape has none, `ShapeInfo`).
    shading: Vec<VertexShading>,
    triangles: Vec<[u32; 3]>,
    /// Each triangle's shape, non-decreasing (a shape's triangles are contiguous, in shape order).
    tri_shape: Vec<u32>,
    spheres: Vec<SphereShape>,
    shapes: Vec<ShapeInfo>,
}

/// A scene ready for rendering.
pub struct Scene {
    pub materials: Vec<Material>,
    pub images: std::sync::Arc<Vec<Image>>,
    pub lights: LightSet,
    pub camera: Camera,
    pub film: FilmDesc,
    pub bounds: Bounds3,
    accel: LayeredAccel,
    /// The shapes: one list of vertices and triangles, the analytic spheres.
    flat: Flat,
    /// Finds the analytic spheres a ray meets (`spheres.rs`: a tree when there are many).
    sphere_bvh: spheres::SphereBvh,
    /// For each material that is a `mask`, the index (in `materials`) of a copy of its nested
    /// material, for [`Scene::resolve_mask`].
    mask_nested: Vec<Option<u32>>,
}

impl Scene {
    /// Resolve a `mask` at `hit` stochastically, as the cache integrators' camera walk does:
    /// with probability `1 - opacity` (`u ≥ opacity`) the ray passes (returns true, `hit`
    /// unchanged); otherwise `hit.material` becomes the mask's nested material. Other
    /// materials are left alone (false).
    pub fn resolve_mask(&self, hit: &mut SurfaceHit, u: f32) -> bool {
        let i = hit.material as usize;
        let (Some(Material::Mask { opacity, .. }), Some(Some(nested))) = (self.materials.get(i), self.mask_nested.get(i)) else {
            return false;
        };
        if u < material::mask::opacity(opacity, &self.images, hit.uv) {
            hit.material = *nested;
            false
        } else {
            true
        }
    }

    /// Apply the shading-frame wrappers (`bumpmap`, `normalmap`, also under a `mask`) of the
    /// hit's material to `hit.frame`, for the unit direction `wi` towards the viewer (module
    /// [`material::bump`]).
    #[inline]
    fn perturb_frame(&self, hit: &mut SurfaceHit, wi: Vec3) {
        // most materials have none: that test inlined, the wrappers' walk called
        let m = &self.materials[hit.material as usize];
        if matches!(m, Material::Mask { .. } | Material::BumpMap { .. } | Material::NormalMap { .. }) {
            self.perturb_frame_by(m, hit, wi);
        }
    }

    #[inline(never)]
    fn perturb_frame_by(&self, mut m: &Material, hit: &mut SurfaceHit, wi: Vec3) {
        loop {
            let (n, nested) = match m {
                Material::Mask { nested, .. } => {
                    m = nested;
                    continue;
                }
                Material::BumpMap { height, scale, nested } => {
                    let g = material::bump::luminance_gradient(height, &self.images, hit.uv.uv) * *scale;
                    let base = material::bump::frame_along(hit.frame.n, hit.dp_du);
                    (material::bump::bump_normal(g, &base, hit.ng, hit.dp_du, hit.dp_dv), nested)
                }
                Material::NormalMap { normals, nested } => (material::bump::normal_map_normal(normals.eval(&self.images, hit.uv)), nested),
                _ => return,
            };
            let base = material::bump::frame_along(hit.frame.n, hit.dp_du);
            let (frame, alpha2) = material::bump::perturbed_frame(n, base.to_local(wi), &base);
            hit.frame = frame;
            hit.terminator_alpha2 = alpha2;
            m = nested;
        }
    }

    /// Why the image will be black, when it will: no light, or lights that emit nothing (the
    /// warning every front end prints).
    pub fn light_warning(&self) -> Option<&'static str> {
        if self.lights.is_empty() {
            Some("the scene has no light; the image will be black")
        } else if !self.lights.emits() {
            Some("the scene's lights emit nothing (zero radiance, intensity or area); the image will be black")
        } else {
            None
        }
    }

    /// Name of the intersection backend in use.
    pub fn backend_name(&self) -> String {
        self.accel.base().name()
    }

    /// Why `--backend auto` chose the backend in use, in words ([`crate::accel::Accel::choice`]).
    pub fn backend_choice(&self) -> Option<&str> {
        self.accel.base().choice()
    }

    pub fn triangle_count(&self) -> usize {
        self.flat.triangles.len()
    }

    /// World-space triangles of the shapes whose material passes `keep` (spheres tessellated),
    /// e.g. for geometry-area estimates.
    pub fn world_triangles_where(&self, keep: impl Fn(&Material) -> bool) -> Vec<[Vec3; 3]> {
        let kept = |shape: u32| keep(&self.materials[self.flat.shapes[shape as usize].material as usize]);
        let mut out: Vec<[Vec3; 3]> = self
            .flat
            .triangles
            .iter()
            .zip(&self.flat.tri_shape)
            .filter(|(_, &s)| kept(s))
            .map(|(t, _)| [self.flat.positions[t[0] as usize], self.flat.positions[t[1] as usize], self.flat.positions[t[2] as usize]])
            .collect();
        for s in self.flat.spheres.iter().filter(|s| kept(s.shape)) {
            let (nt, np) = (24usize, 48usize);
            let pt = |i: usize, j: usize| {
                let th = PI * i as f32 / nt as f32;
                let ph = 2.0 * PI * j as f32 / np as f32;
                s.center + s.radius * Vec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos())
            };
            for i in 0..nt {
                for j in 0..np {
                    out.push([pt(i, j), pt(i + 1, j), pt(i + 1, j + 1)]);
                    out.push([pt(i, j), pt(i + 1, j + 1), pt(i, j + 1)]);
                }
            }
        }
        out
    }

    /// World-space triangles and analytic spheres (centre, radius) of the shapes `shapes`.
    pub fn shapes_geometry(&self, shapes: &std::ops::Range<u32>) -> (Vec<[Vec3; 3]>, Vec<(Vec3, f32)>) {
        let tris = self
            .flat
            .triangles
            .iter()
            .zip(&self.flat.tri_shape)
            .filter(|(_, s)| shapes.contains(s))
            .map(|(t, _)| t.map(|k| self.flat.positions[k as usize]))
            .collect();
        let spheres = self.flat.spheres.iter().filter(|s| shapes.contains(&s.shape)).map(|s| (s.center, s.radius)).collect();
        (tris, spheres)
    }

    /// World-space triangles of the meshes whose material passes `keep` (no sphere), wound
    /// so that their winding normal is the shape's front side (`flip_normals` honoured).
    pub fn mesh_triangles_where(&self, keep: impl Fn(&Material) -> bool) -> Vec<[Vec3; 3]> {
        let mut out = Vec::new();
        self.mesh_triangles_into(0..u32::MAX, keep, &mut out);
        out
    }

    /// [`Scene::mesh_triangles_where`] of the shapes in `shapes` only, appended to `out` (in
    /// the scene's order; a shape's triangles are contiguous and in shape order).
    pub fn mesh_triangles_into(&self, shapes: Range<u32>, keep: impl Fn(&Material) -> bool, out: &mut Vec<[Vec3; 3]>) {
        let (a, b) = (self.flat.tri_shape.partition_point(|&s| s < shapes.start), self.flat.tri_shape.partition_point(|&s| s < shapes.end));
        let tris = self.flat.triangles[a..b].iter().zip(&self.flat.tri_shape[a..b]);
        out.extend(tris.filter(|(_, &s)| keep(&self.materials[self.flat.shapes[s as usize].material as usize])).map(|(t, &s)| {
            let p = |k: usize| self.flat.positions[t[k] as usize];
            if self.flat.shapes[s as usize].flip {
                [p(0), p(2), p(1)]
            } else {
                [p(0), p(1), p(2)]
            }
        }));
    }

    /// The analytic spheres whose material passes `keep`: `(centre, radius, flip_normals)`.
    pub fn analytic_spheres_where(&self, keep: impl Fn(&Material) -> bool) -> Vec<(Vec3, f32, bool)> {
        self.flat
            .spheres
            .iter()
            .filter(|s| keep(&self.materials[self.flat.shapes[s.shape as usize].material as usize]))
            .map(|s| (s.center, s.radius, self.flat.shapes[s.shape as usize].flip))
            .collect()
    }

    /// Closest hit along the ray.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<SurfaceHit> {
        let mut out = None;
        self.intersect_into(ray, &mut out);
        out
    }

    /// [`Scene::intersect`] written into `out`: the path loop keeps one record for all its
    /// bounces, which are then built in place (returned, the 160-byte record was copied,
    /// `memcpy`, 1-2% of a path's work).
    #[inline]
    pub fn intersect_into(&self, ray: &Ray, out: &mut Option<SurfaceHit>) {
        let tri = self.accel.intersect(ray);
        let sphere_hit = self.sphere_bvh.closest(ray, &self.flat.spheres, tri.map_or(ray.tmax, |h| h.t));
        *out = match (sphere_hit, tri) {
            (Some((i, t)), _) => Some(self.sphere_hit(ray, &self.flat.spheres[i], t)),
            (None, Some(h)) => Some(self.triangle_hit(ray, h.prim, h.t, Vec2::new(h.u, h.v))),
            (None, None) => None,
        };
        if let Some(hit) = out.as_mut() {
            self.perturb_frame(hit, -ray.d);
        }
    }

    /// True when nothing blocks the segment from `a` to `b` (scene units); a segment not
    /// longer than `min_len` is clear without a ray.
    #[inline]
    pub fn sees(&self, a: Vec3, b: Vec3, min_len: f32) -> bool {
        let d = b - a;
        let len = d.length();
        !(len > min_len) || !self.occluded(&Ray::segment(a, d / len, len))
    }

    /// True when anything blocks the segment `[tmin, tmax]` of the ray.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.sphere_bvh.any(ray, &self.flat.spheres) || self.accel.occluded(ray)
    }

    // Inlined into `intersect` (and so into its callers) so that the record is built in place:
    // returned from a call, the 160-byte record was copied (`memmove`, 1-3% of the path tracer).
    #[inline]
    fn triangle_hit(&self, ray: &Ray, prim: u32, t: f32, b: Vec2) -> SurfaceHit {
        let tri = self.flat.triangles[prim as usize];
        let shape = self.flat.tri_shape[prim as usize];
        let info = &self.flat.shapes[shape as usize];
        let (i0, i1, i2) = (tri[0] as usize, tri[1] as usize, tri[2] as usize);
        let (p0, p1, p2) = (self.flat.positions[i0], self.flat.positions[i1], self.flat.positions[i2]);
        let (a0, a1, a2) = (self.flat.shading[i0], self.flat.shading[i1], self.flat.shading[i2]);
        let mut ng = (p1 - p0).cross(p2 - p0).normalize();
        let mut n = if info.has_normals {
            let n = bary(a0.n, a1.n, a2.n, b).normalize_or_zero();
            if n == Vec3::ZERO {
                ng
            } else {
                n
            }
        } else {
            ng
        };
        if info.flip {
            ng = -ng;
            n = -n;
        }
        let uv = if info.has_uvs { bary(a0.uv, a1.uv, a2.uv, b) } else { b };
        // Mitsuba 3's mesh differentials (mesh.cpp): from the uvs when they are not degenerate.
        let (mut dp_du, mut dp_dv) = (p1 - p0, p2 - p0);
        if info.has_uvs {
            let (duv0, duv1) = (a1.uv - a0.uv, a2.uv - a0.uv);
            let det = duv0.x * duv1.y - duv0.y * duv1.x;
            if det != 0.0 && det.is_finite() {
                let inv = 1.0 / det;
                (dp_du, dp_dv) = ((dp_du * duv1.y - dp_dv * duv0.y) * inv, (dp_dv * duv0.x - dp_du * duv1.x) * inv);
            } else {
                let f = Frame::from_normal(n);
                (dp_du, dp_dv) = (f.s, f.t);
            }
        }
        SurfaceHit {
            p: ray.at(t),
            t,
            ng,
            frame: Frame::from_normal(n),
            base_n: n,
            terminator_alpha2: 0.0,
            uv: TexCoord::at(uv),
            dp_du,
            dp_dv,
            shape,
            material: info.material,
            light: self.lights.shape_light(shape),
        }
    }

    fn sphere_hit(&self, ray: &Ray, s: &SphereShape, t: f32) -> SurfaceHit {
        let info = &self.flat.shapes[s.shape as usize];
        let local = (ray.at(t) - s.center) / s.radius;
        let local = local.normalize();
        // Re-project onto the sphere to remove the error of the quadratic solve.
        let p = s.center + local * s.radius;
        let mut n = local;
        let phi = local.y.atan2(local.x);
        let phi = if phi < 0.0 { phi + 2.0 * PI } else { phi };
        let uv = Vec2::new(phi / (2.0 * PI), local.z.clamp(-1.0, 1.0).acos() / PI);
        // Mitsuba 3's sphere.cpp differentials of (φ / 2π, θ / π).
        let dp_du = Vec3::new(-local.y, local.x, 0.0) * (2.0 * PI * s.radius);
        let rxy = (local.x * local.x + local.y * local.y).sqrt();
        let (cos_phi, sin_phi) = if rxy > 0.0 { (local.x / rxy, local.y / rxy) } else { (1.0, 0.0) };
        let dp_dv = Vec3::new(local.z * cos_phi, local.z * sin_phi, -rxy) * (PI * s.radius);
        if info.flip {
            n = -n;
        }
        SurfaceHit {
            p,
            t,
            ng: n,
            frame: Frame::from_normal(n),
            base_n: n,
            terminator_alpha2: 0.0,
            uv: TexCoord::at(uv),
            dp_du,
            dp_dv,
            shape: s.shape,
            material: info.material,
            light: self.lights.shape_light(s.shape),
        }
    }

    /// Name of a shape (for messages).
    pub fn shape_name(&self, shape: u32) -> &str {
        &self.flat.shapes[shape as usize].name
    }
}

/// Nearest sphere intersection with `t` in `[ray.tmin, tmax)`.
#[inline]
pub fn intersect_sphere(ray: &Ray, c: Vec3, r: f32, tmax: f32) -> Option<f32> {
    // Numerically robust form (Ray Tracing Gems, ch. 7): work relative to the centre.
    let f = ray.o - c;
    let a = ray.d.length_squared();
    let b = -f.dot(ray.d);
    let l = f + (b / a) * ray.d;
    let disc = r * r - l.length_squared();
    if disc < 0.0 {
        return None;
    }
    let cc = f.length_squared() - r * r;
    let q = b + b.signum() * (a * disc).sqrt();
    let (t0, t1) = if q == 0.0 { (0.0, 0.0) } else { (cc / q, q / a) };
    let (t0, t1) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
    if t0 >= ray.tmin && t0 < tmax {
        Some(t0)
    } else if t1 >= ray.tmin && t1 < tmax {
        Some(t1)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_intersection_from_outside_and_inside() {
        let r = Ray::new(Vec3::new(0.0, 0.0, -5.0), Vec3::Z);
        let t = intersect_sphere(&r, Vec3::ZERO, 1.0, f32::INFINITY).unwrap();
        assert!((t - 4.0).abs() < 1e-5);
        let r = Ray::new(Vec3::ZERO, Vec3::Z);
        let t = intersect_sphere(&r, Vec3::ZERO, 2.0, f32::INFINITY).unwrap();
        assert!((t - 2.0).abs() < 1e-5);
        assert!(intersect_sphere(&r, Vec3::ZERO, 2.0, 1.5).is_none());
        let miss = Ray::new(Vec3::new(0.0, 3.0, -5.0), Vec3::Z);
        assert!(intersect_sphere(&miss, Vec3::ZERO, 1.0, f32::INFINITY).is_none());
    }
}
