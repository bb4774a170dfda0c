//! Jensen's photon map with final gathering (Jensen 1996; "Realistic Image Synthesis Using
//! Photon Mapping", 2001, ch. 9), the reference point of the paper's baselines, plus the pieces
//! the three baselines (`photonmap`, `ward`, `christensen`) share.
//!
//! Structure, as the `octree` integrator: specular chains are followed from the camera; at the
//! first vertex with a non-delta lobe
//! - direct light by next-event estimation (one shadow ray, light sampling),
//! - caustics from the caustic map by the radiance estimate
//!   `L_c = Σ_p f(x, w_p, wo) Φ_p / (π r²)` (`n_max` photons within `r_max`, `w_p` on the
//!   viewer's side; `f = Material::eval / |cos θ_p|`, so a Lambertian surface gives `ρ E / π`),
//! - indirect light by **final gathering**: `gather_rays` directions sampled from the BSDF; each
//!   gather ray returns the radiance leaving its first non-delta hit `y` towards `x`:
//!   `L(y) = direct(y) (NEE) + L_global(y) + L_caustic(y)`, both estimates as above.
//!
//! Why NEE at `y`: the global map holds indirect photons only (direct light is not in the
//! maps, see `photon_pass`), so the light leaving `y` is direct (shadow ray) + indirect
//! (global map) + caustic (caustic map). Emission is never added at a gather hit: light from
//! an emitter reaching `x` directly is the direct term at `x`, and through a specular chain it
//! is a caustic at `x`. A gather ray meeting a specular surface follows the delta lobe (up to
//! `max_depth` vertices). Each gather ray draws from the pixel's sampler, so images are
//! identical for any thread count.
//!
//! Emitters seen from the camera directly or through specular chains add their emission.
//!
//! Views (paper fig. 2): `irradiance` shows the indirect irradiance at the first non-delta
//! hit, here the final gather over cosine-distributed directions `E = π/N Σ L_i`;
//! `irradiance_all` adds the caustic map's irradiance estimate.

use super::RayCounters;
use crate::caches::kdtree::{gather_photons, scene_size, Density, DensitySettings, Neighbor, PhotonTree, SettingsError};
use crate::math::{Color, Frame, Ray};
use crate::photon_pass::{trace_photons, PhotonError, PhotonMaps, PhotonSettings};
use crate::sampling::{square_to_cosine_hemisphere, Sampler};
use crate::scene::material::{Lobe, Material};
use crate::scene::{Scene, SurfaceHit};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::f32::consts::PI;
use std::time::Instant;

/// What the baselines write into the image (the octree integrator's views, minus leaves).
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum CacheView {
    /// Direct + indirect (from the method's cache) + caustics.
    #[default]
    Render,
    /// Indirect irradiance `E` at the first non-delta hit (paper fig. 2).
    Irradiance,
    /// Indirect + caustic irradiance at the first non-delta hit.
    IrradianceAll,
}

/// Errors while building a baseline integrator.
#[derive(Debug, thiserror::Error)]
pub enum BaselineError {
    #[error(transparent)]
    Settings(#[from] SettingsError),
    #[error(transparent)]
    Photons(#[from] PhotonError),
}

/// `max_depth` must be -1 (unbounded) or positive.
pub(crate) fn check_max_depth(max_depth: i32) -> Result<(), SettingsError> {
    if max_depth < -1 || max_depth == 0 {
        return Err(SettingsError::new("max_depth", format!("{max_depth} must be -1 (unbounded) or at least 1")));
    }
    Ok(())
}

/// Photon-pass statistics shared by the baselines.
#[derive(Clone, Debug, Default, Serialize)]
pub struct PhotonMapStats {
    pub photons_emitted: u64,
    pub global_photons: usize,
    pub caustic_photons: usize,
    /// Photon tracing, seconds.
    pub t_photons_s: f64,
    /// Both kd-trees, seconds.
    pub t_kdtree_s: f64,
    /// Bytes of the global map's kd-tree.
    pub global_bytes: usize,
    /// Bytes of the caustic map's kd-tree.
    pub caustic_bytes: usize,
}

/// Global and caustic photon maps as kd-trees plus the resolved estimate parameters, and the
/// shading the baselines share (read-only, `Sync`).
pub struct Shading {
    pub global: PhotonTree,
    pub caustic: PhotonTree,
    /// Global-map estimate parameters (scene units).
    pub global_density: Density,
    /// Caustic-map estimate parameters (scene units).
    pub caustic_density: Density,
    /// Longest specular chain (vertices), `u32::MAX` for unbounded.
    pub max_depth: u32,
    pub stats: PhotonMapStats,
}

impl Shading {
    /// Build both kd-trees from traced maps (the photons are copied: callers may still need
    /// them in emission order).
    pub fn new(scene: &Scene, maps: &PhotonMaps, global: &DensitySettings, caustic: &DensitySettings, max_depth: i32) -> Shading {
        let t0 = Instant::now();
        let (g, c) = rayon::join(|| PhotonTree::build(maps.global.clone()), || PhotonTree::build(maps.caustic.clone()));
        let size = scene_size(&scene.bounds);
        let stats = PhotonMapStats {
            photons_emitted: maps.emitted,
            global_photons: g.len(),
            caustic_photons: c.len(),
            t_photons_s: maps.time_s,
            t_kdtree_s: t0.elapsed().as_secs_f64(),
            global_bytes: g.bytes(),
            caustic_bytes: c.bytes(),
        };
        Shading {
            global: g,
            caustic: c,
            global_density: global.resolve(size),
            caustic_density: caustic.resolve(size),
            max_depth: if max_depth < 0 { u32::MAX } else { max_depth as u32 },
            stats,
        }
    }

    /// A scratch buffer sized for the estimates.
    pub fn scratch(&self) -> Vec<Neighbor> {
        Vec::with_capacity(self.global_density.n_max.max(self.caustic_density.n_max).min(4096))
    }

    /// Follow `ray` through specular vertices to the first vertex with a non-delta lobe. With
    /// `emission`, emitters met on the way (that one included) and the environment add
    /// `throughput · Le` to `result`.
    pub fn first_vertex(
        &self,
        scene: &Scene,
        mut ray: Ray,
        sampler: &mut Sampler,
        counters: &mut RayCounters,
        emission: bool,
        result: &mut Color,
    ) -> Option<Vertex> {
        let mut throughput = Color::ONE;
        let mut depth = 0u32;
        loop {
            counters.rays += 1;
            let Some(hit) = scene.intersect(&ray) else {
                if emission {
                    *result += throughput * scene.lights.env_le(ray.d);
                }
                return None;
            };
            if let (Some(light), true) = (hit.light, emission) {
                *result += throughput * scene.lights.area_le(light, hit.ng, -ray.d);
            }
            let material = &scene.materials[hit.material as usize];
            let wo = hit.frame.to_local(-ray.d);
            if material.has_smooth_lobe() {
                let n = if wo.z >= 0.0 { hit.frame.n } else { -hit.frame.n };
                return Some(Vertex { hit, wo, n, throughput });
            }
            if depth + 1 >= self.max_depth {
                return None;
            }
            let u_lobe = sampler.next_1d();
            let u = sampler.next_2d();
            let bs = material.sample(&scene.images, hit.uv, wo, u_lobe, u)?;
            if bs.lobe != Lobe::Specular || !bs.weight.is_finite() {
                return None;
            }
            throughput *= bs.weight;
            if throughput == Color::ZERO {
                return None;
            }
            ray = hit.spawn(hit.frame.to_world(bs.wi));
            depth += 1;
        }
    }

    /// Radiance estimate `Σ f Φ / (π r²)` from `tree` at `hit` towards `wo` (normal `n` on
    /// the viewer's side), timed into `counters`.
    #[allow(clippy::too_many_arguments)]
    pub fn radiance_estimate(
        &self,
        scene: &Scene,
        tree: &PhotonTree,
        d: Density,
        hit: &SurfaceHit,
        material: &Material,
        wo: Vec3,
        n: Vec3,
        scratch: &mut Vec<Neighbor>,
        counters: &mut RayCounters,
    ) -> Color {
        if tree.is_empty() {
            return Color::ZERO;
        }
        let t = Instant::now();
        let r2 = gather_photons(tree, hit.p, n, d, scratch);
        let mut sum = Color::ZERO;
        for nb in scratch.iter() {
            let ph = &tree.items()[nb.index as usize];
            let wi = hit.frame.to_local(ph.wi);
            let cos = wi.z.abs();
            if cos < 1e-4 {
                continue;
            }
            sum += material.eval(&scene.images, hit.uv, wo, wi) / cos * ph.power;
        }
        counters.cache_queries += 1;
        counters.cache_query_ns += t.elapsed().as_nanos() as u64;
        if scratch.is_empty() || !(r2 > 0.0) {
            Color::ZERO
        } else {
            sum / (PI * r2)
        }
    }

    /// Irradiance estimate from `tree` at `(x, n)`, timed into `counters`.
    pub fn irradiance_estimate(
        &self,
        tree: &PhotonTree,
        d: Density,
        x: Vec3,
        n: Vec3,
        scratch: &mut Vec<Neighbor>,
        counters: &mut RayCounters,
    ) -> crate::caches::kdtree::DensityEstimate {
        let t = Instant::now();
        let e = crate::caches::kdtree::photon_irradiance(tree, x, n, d, scratch);
        counters.cache_queries += 1;
        counters.cache_query_ns += t.elapsed().as_nanos() as u64;
        e
    }

    /// Radiance leaving the first non-delta surface along `ray` towards its origin, emission
    /// excluded (module docs), and the distance to the first surface hit (`INFINITY` on a miss).
    pub fn gather_radiance(
        &self,
        scene: &Scene,
        mut ray: Ray,
        sampler: &mut Sampler,
        counters: &mut RayCounters,
        scratch: &mut Vec<Neighbor>,
    ) -> (Color, f32) {
        let mut throughput = Color::ONE;
        let mut first_t = f32::INFINITY;
        let mut depth = 0u32;
        loop {
            counters.rays += 1;
            let Some(hit) = scene.intersect(&ray) else { return (Color::ZERO, first_t) };
            if depth == 0 {
                first_t = hit.t;
            }
            let material = &scene.materials[hit.material as usize];
            let wo = hit.frame.to_local(-ray.d);
            if material.has_smooth_lobe() {
                let n = if wo.z >= 0.0 { hit.frame.n } else { -hit.frame.n };
                let mut l = super::direct_light(scene, &hit, material, wo, sampler, counters);
                l += self.radiance_estimate(scene, &self.global, self.global_density, &hit, material, wo, n, scratch, counters);
                l += self.radiance_estimate(scene, &self.caustic, self.caustic_density, &hit, material, wo, n, scratch, counters);
                return (throughput * l, first_t);
            }
            if depth + 1 >= self.max_depth {
                return (Color::ZERO, first_t);
            }
            let u_lobe = sampler.next_1d();
            let u = sampler.next_2d();
            let Some(bs) = material.sample(&scene.images, hit.uv, wo, u_lobe, u) else { return (Color::ZERO, first_t) };
            if bs.lobe != Lobe::Specular || !bs.weight.is_finite() {
                return (Color::ZERO, first_t);
            }
            throughput *= bs.weight;
            if throughput == Color::ZERO {
                return (Color::ZERO, first_t);
            }
            ray = hit.spawn(hit.frame.to_world(bs.wi));
            depth += 1;
        }
    }

    /// Final-gather irradiance at `hit` on the side of `n`: `E = π/N Σ L_i` over `rays`
    /// cosine-distributed directions, and Ward's harmonic mean distance `N / Σ 1/t_i` of the
    /// gather hits (`INFINITY` when every ray escapes).
    #[allow(clippy::too_many_arguments)]
    pub fn gather_irradiance(
        &self,
        scene: &Scene,
        hit: &SurfaceHit,
        n: Vec3,
        rays: u32,
        sampler: &mut Sampler,
        counters: &mut RayCounters,
        scratch: &mut Vec<Neighbor>,
    ) -> (Color, f32) {
        let frame = Frame::from_normal(n);
        let mut sum = Color::ZERO;
        let mut inv_t = 0.0f64;
        for _ in 0..rays {
            let d = frame.to_world(square_to_cosine_hemisphere(sampler.next_2d()));
            let (l, t) = self.gather_radiance(scene, hit.spawn(d), sampler, counters, scratch);
            sum += l;
            if t.is_finite() && t > 0.0 {
                inv_t += 1.0 / t as f64;
            }
        }
        let rays = rays.max(1) as f32;
        let harmonic = if inv_t > 0.0 { (rays as f64 / inv_t) as f32 } else { f32::INFINITY };
        ((sum * (PI / rays)).max(Color::ZERO), harmonic)
    }

    /// Caustic radiance at a vertex.
    #[inline]
    pub fn caustics(
        &self,
        scene: &Scene,
        v: &Vertex,
        material: &Material,
        scratch: &mut Vec<Neighbor>,
        counters: &mut RayCounters,
    ) -> Color {
        self.radiance_estimate(scene, &self.caustic, self.caustic_density, &v.hit, material, v.wo, v.n, scratch, counters)
    }

    /// Caustic irradiance at a vertex (for [`CacheView::IrradianceAll`]).
    #[inline]
    pub fn caustic_irradiance(&self, v: &Vertex, scratch: &mut Vec<Neighbor>, counters: &mut RayCounters) -> Color {
        if self.caustic.is_empty() {
            return Color::ZERO;
        }
        self.irradiance_estimate(&self.caustic, self.caustic_density, v.hit.p, v.n, scratch, counters).e
    }
}

/// The first non-delta vertex of a camera path.
#[derive(Clone, Copy, Debug)]
pub struct Vertex {
    pub hit: SurfaceHit,
    /// Direction to the viewer, local shading frame.
    pub wo: Vec3,
    /// Shading normal on the viewer's side (world).
    pub n: Vec3,
    /// Product of the specular weights from the camera.
    pub throughput: Color,
}

/// Outgoing radiance of an irradiance `e` arriving along the normal on the viewer's side:
/// `f(wo, n) E`, i.e. `ρ E / π` for a Lambertian surface (exact for it; for glossy materials
/// an approximation: an irradiance cache keeps no direction).
#[inline]
pub fn shade_irradiance(scene: &Scene, hit: &SurfaceHit, material: &Material, wo: Vec3, e: Color) -> Color {
    if e == Color::ZERO {
        return Color::ZERO;
    }
    let wi = Vec3::new(0.0, 0.0, if wo.z >= 0.0 { 1.0 } else { -1.0 });
    material.eval(&scene.images, hit.uv, wo, wi) * e
}

/// Settings of the `photonmap` integrator.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default)]
pub struct PhotonMapSettings {
    pub photons: PhotonSettings,
    /// Global-map radiance estimate at the gather hits (paper's table 2: 205, 31).
    pub global: DensitySettings,
    /// Caustic-map radiance estimate.
    pub caustic: DensitySettings,
    /// Final-gather rays per camera sample at the first non-delta vertex (a pixel gets
    /// `spp × gather_rays`; each gather hit costs one shadow ray and two `n_max`-nearest
    /// searches, so this baseline is slow: ~140 s for `cornell-box` 128², 16 spp × 16 rays on
    /// two loaded cores).
    pub gather_rays: u32,
    /// Longest specular chain followed (vertices, Mitsuba-like; -1 unbounded).
    pub max_depth: i32,
    pub view: CacheView,
}

impl Default for PhotonMapSettings {
    fn default() -> Self {
        PhotonMapSettings {
            photons: PhotonSettings::default(),
            global: DensitySettings::default(),
            caustic: DensitySettings::default(),
            gather_rays: 4,
            max_depth: 16,
            view: CacheView::Render,
        }
    }
}

impl PhotonMapSettings {
    pub fn validate(&self) -> Result<(), SettingsError> {
        if self.photons.photons == 0 {
            return Err(SettingsError::new("photons.photons", "at least one photon must be emitted (got 0)"));
        }
        self.global.validate("global")?;
        self.caustic.validate("caustic")?;
        if self.gather_rays == 0 {
            return Err(SettingsError::new("gather_rays", "final gathering needs at least one ray (got 0)"));
        }
        check_max_depth(self.max_depth)
    }
}

/// Build statistics of the `photonmap` integrator.
#[derive(Clone, Debug, Default, Serialize)]
pub struct PhotonMapBuildStats {
    pub photons: PhotonMapStats,
    /// `t_c`: photon tracing + kd-trees, seconds.
    pub t_c_s: f64,
    /// `F_m`: bytes of both photon maps.
    pub bytes: usize,
}

/// A built `photonmap` integrator (read-only while rendering).
pub struct PhotonMapIntegrator {
    pub settings: PhotonMapSettings,
    pub shading: Shading,
    pub stats: PhotonMapBuildStats,
}

impl PhotonMapIntegrator {
    /// Trace the photons and build the two kd-trees.
    pub fn build(scene: &Scene, settings: PhotonMapSettings) -> Result<PhotonMapIntegrator, BaselineError> {
        settings.validate()?;
        let maps = trace_photons(scene, &settings.photons)?;
        let shading = Shading::new(scene, &maps, &settings.global, &settings.caustic, settings.max_depth);
        let p = shading.stats.clone();
        let stats = PhotonMapBuildStats { t_c_s: p.t_photons_s + p.t_kdtree_s, bytes: p.global_bytes + p.caustic_bytes, photons: p };
        Ok(PhotonMapIntegrator { settings, shading, stats })
    }

    /// Radiance along a primary ray.
    pub fn li(&self, scene: &Scene, ray: Ray, sampler: &mut Sampler, counters: &mut RayCounters) -> Color {
        let sh = &self.shading;
        let view = self.settings.view;
        let mut result = Color::ZERO;
        let Some(v) = sh.first_vertex(scene, ray, sampler, counters, view == CacheView::Render, &mut result) else { return result };
        let mut scratch = sh.scratch();
        let material = &scene.materials[v.hit.material as usize];
        match view {
            CacheView::Render => {
                let mut l = super::direct_light(scene, &v.hit, material, v.wo, sampler, counters);
                l += sh.caustics(scene, &v, material, &mut scratch, counters);
                let n = self.settings.gather_rays;
                let mut ind = Color::ZERO;
                for _ in 0..n {
                    let u_lobe = sampler.next_1d();
                    let u = sampler.next_2d();
                    let Some(bs) = material.sample(&scene.images, v.hit.uv, v.wo, u_lobe, u) else { continue };
                    if bs.lobe == Lobe::Specular || !bs.weight.is_finite() || bs.weight == Color::ZERO {
                        continue;
                    }
                    let ray = v.hit.spawn(v.hit.frame.to_world(bs.wi));
                    ind += bs.weight * sh.gather_radiance(scene, ray, sampler, counters, &mut scratch).0;
                }
                l += ind / n as f32;
                result += v.throughput * l;
            }
            CacheView::Irradiance | CacheView::IrradianceAll => {
                let mut e = sh.gather_irradiance(scene, &v.hit, v.n, self.settings.gather_rays, sampler, counters, &mut scratch).0;
                if view == CacheView::IrradianceAll {
                    e += sh.caustic_irradiance(&v, &mut scratch, counters);
                }
                result += v.throughput * e;
            }
        }
        result
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::accel::BackendKind;
    use crate::scene::camera::{look_at, CameraDesc, FovAxis};
    use crate::scene::material::Texture;
    use crate::scene::{FilmDesc, Geometry, PixelFilter, SceneDesc, ShapeDesc, TriMesh};
    use glam::Mat4;

    fn quad(name: &str, to_world: Mat4, material: u32, emission: Option<Color>) -> ShapeDesc {
        ShapeDesc { name: name.into(), geometry: Geometry::Mesh(TriMesh::rectangle(&to_world)), material, emission, flip_normals: false }
    }

    /// A closed unit-scale Cornell-like box (size 2, y up, inward normals) with a grey floor,
    /// red left and green right walls, a ceiling light, and a camera looking in from the front
    /// wall; `res`² pixels.
    pub(crate) fn box_scene(res: u32) -> Scene {
        use std::f32::consts::FRAC_PI_2;
        let t = Mat4::from_translation;
        let rx = Mat4::from_rotation_x;
        let ry = Mat4::from_rotation_y;
        let shapes = vec![
            quad("floor", t(Vec3::new(0.0, 0.0, 0.0)) * rx(-FRAC_PI_2), 0, None),
            quad("ceiling", t(Vec3::new(0.0, 2.0, 0.0)) * rx(FRAC_PI_2), 0, None),
            quad("back", t(Vec3::new(0.0, 1.0, -1.0)), 0, None),
            quad("front", t(Vec3::new(0.0, 1.0, 1.0)) * ry(std::f32::consts::PI), 0, None),
            quad("left", t(Vec3::new(-1.0, 1.0, 0.0)) * ry(FRAC_PI_2), 1, None),
            quad("right", t(Vec3::new(1.0, 1.0, 0.0)) * ry(-FRAC_PI_2), 2, None),
            quad("light", t(Vec3::new(0.0, 1.99, 0.0)) * rx(FRAC_PI_2) * Mat4::from_scale(Vec3::splat(0.3)), 0, Some(Color::splat(15.0))),
        ];
        let desc = SceneDesc {
            shapes,
            materials: vec![
                Material::Diffuse { reflectance: Texture::Const(Color::splat(0.7)) },
                Material::Diffuse { reflectance: Texture::Const(Color::new(0.7, 0.1, 0.1)) },
                Material::Diffuse { reflectance: Texture::Const(Color::new(0.1, 0.7, 0.1)) },
            ],
            camera: CameraDesc {
                to_world: look_at(Vec3::new(0.0, 1.0, 0.95), Vec3::new(0.0, 1.0, -1.0), Vec3::Y),
                fov_deg: 90.0,
                fov_axis: FovAxis::X,
                near_clip: 1e-3,
            },
            film: FilmDesc { width: res, height: res, filter: PixelFilter::Box },
            ..Default::default()
        };
        Scene::prepare(desc, BackendKind::Bvh).expect("valid test scene")
    }

    /// The inside of a sphere of radius 1 whose walls are Lambertian of albedo `rho` and emit
    /// `le` inwards, seen from the centre: radiance is `le / (1 - rho)` everywhere, of which
    /// `le` is emission and `rho le` reflected direct light, so the indirect irradiance is
    /// `π (le / (1 - rho) - le - rho le) / rho = π rho le / (1 - rho)`.
    pub(crate) fn furnace_scene(rho: f32, le: f32) -> Scene {
        let desc = SceneDesc {
            shapes: vec![ShapeDesc {
                name: "sphere".into(),
                geometry: Geometry::Sphere { center: Vec3::ZERO, radius: 1.0 },
                material: 0,
                emission: Some(Color::splat(le)),
                flip_normals: true,
            }],
            materials: vec![Material::Diffuse { reflectance: Texture::Const(Color::splat(rho)) }],
            camera: CameraDesc { to_world: look_at(Vec3::ZERO, -Vec3::Z, Vec3::Y), fov_deg: 60.0, fov_axis: FovAxis::X, near_clip: 1e-3 },
            film: FilmDesc { width: 16, height: 16, filter: PixelFilter::Box },
            ..Default::default()
        };
        Scene::prepare(desc, BackendKind::Bvh).expect("valid furnace scene")
    }

    /// Mean of an image over all pixels and channels.
    pub(crate) fn image_mean(img: &[Color]) -> f64 {
        img.iter().map(|c| c.element_sum() as f64 / 3.0).sum::<f64>() / img.len() as f64
    }

    /// Render `integrator` on the furnace (ρ = 0.5, Le = 1): the render is 2, the indirect
    /// irradiance π.
    pub(crate) fn check_furnace(render_mean: f64, irradiance_mean: f64, tolerance: f64, what: &str) {
        eprintln!("{what}: furnace render {render_mean:.4} (2), indirect irradiance {irradiance_mean:.4} (π)");
        assert!((render_mean - 2.0).abs() < 2.0 * tolerance, "{what}: render {render_mean}, expected 2");
        let pi = std::f64::consts::PI;
        assert!((irradiance_mean - pi).abs() < pi * tolerance, "{what}: indirect irradiance {irradiance_mean}, expected π");
    }

    #[test]
    fn furnace_is_analytic() {
        use crate::integrators::Integrator;
        use crate::render::{render, RenderSettings};
        let scene = furnace_scene(0.5, 1.0);
        let mut means = Vec::new();
        for view in [CacheView::Render, CacheView::Irradiance] {
            let mut s = PhotonMapSettings { view, gather_rays: 8, ..Default::default() };
            s.photons.photons = 100_000;
            s.global.n_max = 50;
            let pm = PhotonMapIntegrator::build(&scene, s).unwrap();
            assert_eq!(pm.stats.photons.caustic_photons, 0);
            let (img, st) =
                render(&scene, &Integrator::PhotonMap(Box::new(pm)), &RenderSettings { spp: 4, ..Default::default() }, &|_, _| {});
            assert!(st.counters.cache_queries > 0);
            means.push(image_mean(&img.data));
        }
        check_furnace(means[0], means[1], 0.03, "photonmap");
    }

    #[test]
    fn images_are_identical_for_one_and_two_threads() {
        use crate::integrators::Integrator;
        use crate::render::{render, RenderSettings};
        let scene = box_scene(12);
        let mut s = PhotonMapSettings { gather_rays: 4, ..Default::default() };
        s.photons.photons = 20_000;
        let run = |t| {
            rayon::ThreadPoolBuilder::new().num_threads(t).build().unwrap().install(|| {
                let pm = PhotonMapIntegrator::build(&scene, s.clone()).unwrap();
                render(&scene, &Integrator::PhotonMap(Box::new(pm)), &RenderSettings { spp: 2, ..Default::default() }, &|_, _| {}).0.data
            })
        };
        let a = run(1);
        assert_eq!(a, run(2));
        assert!(image_mean(&a) > 0.0);
    }

    #[test]
    fn rectangle_orientations_face_the_room() {
        // The box scene's walls must face inwards, or every other test is meaningless.
        let scene = box_scene(8);
        for (o, d) in [
            (Vec3::new(0.0, 1.0, 0.0), -Vec3::Y),
            (Vec3::new(0.0, 1.0, 0.0), Vec3::X),
            (Vec3::new(0.0, 1.0, 0.0), -Vec3::Z),
            (Vec3::new(0.0, 1.0, 0.0), Vec3::Z),
            (Vec3::new(0.0, 1.0, 0.0), -Vec3::X),
        ] {
            let h = scene.intersect(&Ray::new(o, d)).unwrap();
            assert!(h.ng.dot(d) < 0.0, "surface hit along {d} faces away from the room");
        }
        // the light quad faces down
        let h = scene.intersect(&Ray::new(Vec3::new(0.0, 1.0, 0.0), Vec3::Y)).unwrap();
        assert!(h.light.is_some() && h.ng.y < 0.0);
    }

    #[test]
    fn settings_errors_are_clear() {
        let bad = PhotonMapSettings { gather_rays: 0, ..Default::default() };
        assert!(bad.validate().unwrap_err().to_string().contains("gather_rays"));
        let bad = PhotonMapSettings { max_depth: 0, ..Default::default() };
        assert!(bad.validate().unwrap_err().to_string().contains("max_depth"));
        let mut bad = PhotonMapSettings::default();
        bad.photons.photons = 0;
        assert!(bad.validate().unwrap_err().to_string().contains("photons"));
        let mut bad = PhotonMapSettings::default();
        bad.caustic.r_max = crate::caches::kdtree::SceneLength::Absolute(-1.0);
        assert!(bad.validate().unwrap_err().to_string().contains("caustic.r_max"));
        let scene = box_scene(4);
        assert!(PhotonMapIntegrator::build(&scene, PhotonMapSettings { gather_rays: 0, ..Default::default() }).is_err());
        // serde: a partial JSON object fills the defaults
        let s: PhotonMapSettings = serde_json::from_str(r#"{"gather_rays": 3, "global": {"n_max": 50}}"#).unwrap();
        assert_eq!((s.gather_rays, s.global.n_max, s.global.r_max), (3, 50, DensitySettings::default().r_max));
    }
}
