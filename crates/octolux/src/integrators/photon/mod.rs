//! The paper's three baselines (§9) as one family: Jensen's photon map with final gathering
//! ([`photonmap`]), Ward's irradiance cache with photon-computed samples ([`ward`]) and
//! Christensen's precomputed irradiance photons ([`christensen`]).
//!
//! All three use the ray tracer of the `octree` integrator (§8): specular chains followed from
//! the camera ([`walk_specular`]); at the first vertex with a non-delta lobe, direct light by
//! next-event estimation, caustics from the caustic photon map, and indirect light from the
//! method's cache. What they share lives here and in [`super::common`], never in one sibling
//! borrowed by another:
//! - [`Shading`]: the global and caustic photon maps as kd-trees, the density and radiance
//!   estimates, final gathering;
//! - [`ShadeCtx`]: what a camera sample's shading carries from call to call (scene, sampler,
//!   counters, scratch buffer), in place of four arguments to every call;
//! - `render_vertex`: the camera path of the two irradiance caches;
//! - [`priming`]: the deterministic priming pass and the Ward-cache settings that `ward` and
//!   `christensen`'s configuration C share;
//! - [`CacheView`], [`BaselineError`], `validate_common`, [`PhotonMapStats`].
//!
//! Photon maps come from the photon pass ([`crate::photon::trace`]): the global map holds
//! indirect photons only, the caustic map `L S+ x` photons; direct light is never in a map.

pub mod christensen;
pub mod photonmap;
pub mod priming;
pub mod ward;

pub use super::common::Vertex;

use super::common::{direct_light, walk_specular, RayCounters};
use crate::caches::kdtree::{
    gather_photons, photon_irradiance, scene_size, Density, DensityEstimate, DensitySettings, Neighbor, PhotonTree, SettingsError,
};
use crate::math::{Color, Frame, Ray, RayDifferential};
use crate::photon::trace::{PhotonError, PhotonMaps, PhotonSettings};
use crate::sampling::{square_to_cosine_hemisphere, Sampler};
use crate::scene::material::Material;
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

/// The checks every baseline's settings start with: at least one photon, then each named
/// density estimate (`(prefix, settings)`, in order). `max_depth` is checked last, by
/// [`check_max_depth`], after the method's own fields.
pub(crate) fn validate_common(photons: &PhotonSettings, densities: &[(&str, &DensitySettings)]) -> Result<(), SettingsError> {
    if photons.photons == 0 {
        return Err(SettingsError::new("photons.photons", "at least one photon must be emitted (got 0)"));
    }
    for (prefix, d) in densities {
        d.validate(prefix)?;
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

    /// Radiance estimate `Σ f Φ / (π r²)` from `tree` at vertex `v` towards `v.wo`, one timed
    /// cache query.
    pub fn radiance_estimate(&self, cx: &mut ShadeCtx, tree: &PhotonTree, d: Density, v: &Vertex, material: &Material) -> Color {
        if tree.is_empty() {
            return Color::ZERO;
        }
        let hit = &v.hit;
        let (scene, scratch) = (cx.scene, &mut *cx.scratch);
        let (r2, sum) = cx.counters.time_query(|| {
            let r2 = gather_photons(tree, hit.p, v.n, d, scratch);
            let mut sum = Color::ZERO;
            for nb in scratch.iter() {
                let ph = &tree.items()[nb.index as usize];
                let wi = hit.frame.to_local(ph.wi);
                let cos = wi.z.abs();
                if cos < 1e-4 {
                    continue;
                }
                sum += material.eval(&scene.images, hit.uv, v.wo, wi) / cos * ph.power;
            }
            (r2, sum)
        });
        if cx.scratch.is_empty() || !(r2 > 0.0) {
            Color::ZERO
        } else {
            sum / (PI * r2)
        }
    }

    /// Irradiance estimate from `tree` at `(x, n)`, one timed cache query.
    pub fn irradiance_estimate(
        &self,
        tree: &PhotonTree,
        d: Density,
        x: Vec3,
        n: Vec3,
        scratch: &mut Vec<Neighbor>,
        counters: &mut RayCounters,
    ) -> DensityEstimate {
        counters.time_query(|| photon_irradiance(tree, x, n, d, scratch))
    }

    /// Radiance leaving the first non-delta surface along `ray` towards its origin, emission
    /// excluded (see `photonmap`), and the distance to the first surface hit (`INFINITY` on a
    /// miss).
    pub fn gather_radiance(&self, cx: &mut ShadeCtx, ray: Ray) -> (Color, f32) {
        let scene = cx.scene;
        let walk = walk_specular(scene, ray, None, self.max_depth, false, cx.sampler, cx.counters);
        let Some(v) = walk.vertex else { return (Color::ZERO, walk.first_t) };
        let material = &scene.materials[v.hit.material as usize];
        let mut l = direct_light(scene, &v.hit, material, v.wo, cx.sampler, cx.counters);
        l += self.radiance_estimate(cx, &self.global, self.global_density, &v, material);
        l += self.radiance_estimate(cx, &self.caustic, self.caustic_density, &v, material);
        (v.throughput * l, walk.first_t)
    }

    /// Final-gather irradiance at `hit` on the side of `n`: `E = π/N Σ L_i` over `rays`
    /// cosine-distributed directions, and Ward's harmonic mean distance `N / Σ 1/t_i` of the
    /// gather hits (`INFINITY` when every ray escapes).
    pub fn gather_irradiance(&self, cx: &mut ShadeCtx, hit: &SurfaceHit, n: Vec3, rays: u32) -> (Color, f32) {
        let frame = Frame::from_normal(n);
        let mut sum = Color::ZERO;
        let mut inv_t = 0.0f64;
        for _ in 0..rays {
            let d = frame.to_world(square_to_cosine_hemisphere(cx.sampler.next_2d()));
            let (l, t) = self.gather_radiance(cx, hit.spawn(d));
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
    pub fn caustics(&self, cx: &mut ShadeCtx, v: &Vertex, material: &Material) -> Color {
        self.radiance_estimate(cx, &self.caustic, self.caustic_density, v, material)
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

/// What the shading of one camera sample (or one priming point) carries from call to call:
/// the scene, the sample's numbers, its counters and the scratch buffer of photon neighbours
/// the estimates reuse.
pub struct ShadeCtx<'a> {
    pub scene: &'a Scene,
    pub sampler: &'a mut Sampler,
    pub counters: &'a mut RayCounters,
    /// Left empty until a vertex needs an estimate ([`Shading::scratch`] sizes it then).
    pub scratch: &'a mut Vec<Neighbor>,
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

/// The common camera path of the irradiance-cache baselines: emission on the way, then at the
/// first non-delta vertex direct (NEE) + `f(wo, n) E` + caustics, or the irradiance views.
pub(crate) fn render_vertex(
    sh: &Shading,
    view: CacheView,
    cx: &mut ShadeCtx,
    ray: Ray,
    diff: Option<&RayDifferential>,
    irradiance: impl FnOnce(&Vertex, &mut ShadeCtx) -> Color,
) -> Color {
    let scene = cx.scene;
    let walk = walk_specular(scene, ray, diff, sh.max_depth, view == CacheView::Render, cx.sampler, cx.counters);
    let mut result = walk.emitted;
    let Some(v) = walk.vertex else { return result };
    if cx.scratch.capacity() == 0 {
        *cx.scratch = sh.scratch();
    }
    let material = &scene.materials[v.hit.material as usize];
    match view {
        CacheView::Render => {
            let mut l = direct_light(scene, &v.hit, material, v.wo, cx.sampler, cx.counters);
            let e = irradiance(&v, cx);
            l += shade_irradiance(scene, &v.hit, material, v.wo, e);
            l += sh.caustics(cx, &v, material);
            result += v.throughput * l;
        }
        CacheView::Irradiance | CacheView::IrradianceAll => {
            let mut e = irradiance(&v, cx);
            if view == CacheView::IrradianceAll {
                e += sh.caustic_irradiance(&v, cx.scratch, cx.counters);
            }
            result += v.throughput * e;
        }
    }
    result
}
