//! The paper's renderer (Pacanowski, Granier & Schlick 2005, §8): a ray tracer whose indirect
//! light comes from a global octree and whose caustics come from a caustic octree.
//!
//! Per primary ray: follow specular chains (mirror reflection, refraction) recursively; at
//! the first vertex with a non-delta lobe
//! - direct light by next-event estimation with shadow rays (area lights sampled by area),
//! - indirect light from the octrees, from their blended incident-radiance matrix `M(N)`.
//!
//! **How the cache shades a surface.** Column `c` of `M(N)` is the irradiance vector `m_c`
//! of colour channel `c` (§4): its direction `d_c = m_c/|m_c|` is the mean incident direction
//! and `|m_c|` its strength. We treat each channel's incident light as arriving from `d_c`:
//! `L_o,c = f_c(wo, d_c) cos θ(d_c) |m_c|` — exactly what `Material::eval` returns times
//! `|m_c|`. For a Lambertian surface this is `ρ/π (m_c·N) = ρ E_c / π`, the paper's formula;
//! for glossy surfaces (rough conductor, rough plastic) it evaluates the lobe in the mean
//! incident direction, which the paper's representation allows and a pure irradiance cache
//! cannot. Global and caustic octrees are evaluated separately and summed.
//!
//! An emitter seen directly or through a specular chain adds its emission; emission reached
//! otherwise is already in the direct term.

use super::{direct_light, RayCounters};
use crate::caches::{Octree, OctreeError, OctreeSettings, OctreeStats};
use crate::math::{Color, Frame, Ray};
use crate::photon_pass::{trace_photons, PhotonError, PhotonSettings};
use crate::sampling::Sampler;
use crate::scene::material::{Lobe, Material};
use crate::scene::{Scene, SurfaceHit};
use glam::{Mat3, Vec3};
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// What the integrator writes into the image.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum OctreeView {
    /// The full render (direct + indirect from the octrees + caustics).
    #[default]
    Render,
    /// Irradiance `E` from the global octree at the first non-specular hit (paper fig. 2).
    Irradiance,
    /// Irradiance from global + caustic octrees at the first non-specular hit.
    IrradianceAll,
    /// Leaves as colours: depth as hue, atmospheric black, borders darkened.
    Leaves,
}

/// Settings of the `octree` integrator.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default)]
pub struct OctreeIntegratorSettings {
    pub photons: PhotonSettings,
    /// Octree of the global (indirect) photons.
    pub global: OctreeSettings,
    /// Octree of the caustic photons.
    pub caustic: OctreeSettings,
    /// Mitsuba's `max_depth` (path vertices; -1 = unbounded): it bounds the specular chain
    /// followed from the camera and, as `max_depth - 2`, the photons' bounces, so that a render
    /// compares with `path` at the same value. Unbounded chains stop after
    /// [`MAX_SPECULAR_CHAIN`] vertices.
    pub max_depth: i32,
    pub view: OctreeView,
    /// Gather the global octree one bounce away instead of reading it where the camera path
    /// lands (see [`OctreeIntegrator::gathered_global`]): one BSDF-sampled ray per sample, and
    /// the cache's bias is averaged over the hemisphere instead of showing directly.
    pub gather: bool,
}

/// One cache query in this many is timed (see `timed_query`).
const QUERY_TIMING_STRIDE: u64 = 16;

/// Safety bound on specular chains from the camera when `max_depth` is unbounded (a closed
/// mirror box would otherwise never end).
pub const MAX_SPECULAR_CHAIN: u32 = 64;

/// Caustics are sharp, so the caustic octree is finer than the global one. Measured on
/// cornell-spheres (128², 64 spp, 1M photons, relMSE vs Mitsuba 3): caustic (h_max, n_max) =
/// (6, 400) as the global tree 3.2e-2 — 95% of it in the 1% of pixels around the glass sphere's
/// caustic —, (8, 100) 4.0e-3, (10, 50) 2.9e-3, (10, 20) 3.1e-3 (noisier).
pub const CAUSTIC_H_MAX: u32 = 10;
/// See [`CAUSTIC_H_MAX`].
pub const CAUSTIC_N_MAX: u32 = 50;

impl Default for OctreeIntegratorSettings {
    /// The paper's octree configuration, except the estimator: `GeometryArea` (the paper's own
    /// proposed fix) is the default because it measured closest to the path-traced reference
    /// (cornell-box 128², 64 spp, 1M photons, relMSE vs Mitsuba 3: paper 8.2e-3 — 8% too dark —,
    /// cosine 1.4e-3, geometry-area 8.5e-4; `--estimator paper` restores the paper's).
    fn default() -> Self {
        let tree = OctreeSettings {
            estimator: crate::caches::Estimator::GeometryArea,
            split: crate::caches::Split::Normal,
            ..OctreeSettings::default()
        };
        OctreeIntegratorSettings {
            photons: PhotonSettings::default(),
            global: tree.clone(),
            caustic: OctreeSettings { h_max: CAUSTIC_H_MAX, n_max: CAUSTIC_N_MAX, ..tree },
            max_depth: -1,
            view: OctreeView::Render,
            gather: false,
        }
    }
}

/// Errors while building the octrees.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    #[error(transparent)]
    Photons(#[from] PhotonError),
    #[error("global octree: {0}")]
    Global(OctreeError),
    #[error("caustic octree: {0}")]
    Caustic(OctreeError),
}

/// Statistics of the build (the paper's tables 1 and 3).
#[derive(Clone, Debug, Serialize)]
pub struct OctreeBuildStats {
    pub photons_emitted: u64,
    pub global_photons: usize,
    pub caustic_photons: usize,
    /// Photon tracing time, seconds.
    pub t_photons_s: f64,
    /// Octree build time (both octrees), seconds.
    pub t_octree_s: f64,
    /// `t_c`: photon tracing + octree build, seconds.
    pub t_c_s: f64,
    /// Octree build rate, photons per second (both octrees).
    pub build_photons_per_s: f64,
    pub global: OctreeStats,
    pub caustic: Option<OctreeStats>,
    /// `F_m`: bytes of both octrees as stored.
    pub bytes: usize,
}

/// A built `octree` integrator: settings plus the two octrees (read-only while rendering).
pub struct OctreeIntegrator {
    pub settings: OctreeIntegratorSettings,
    pub global: Octree,
    pub caustic: Option<Octree>,
    pub stats: OctreeBuildStats,
}

impl OctreeIntegrator {
    /// Trace the photons and build both octrees over the scene's bounds.
    pub fn build(scene: &Scene, settings: OctreeIntegratorSettings) -> Result<OctreeIntegrator, BuildError> {
        settings.global.validate().map_err(BuildError::Global)?;
        settings.caustic.validate().map_err(BuildError::Caustic)?;
        // Honour max_depth as Mitsuba counts it, so renders stay comparable with `path` at the
        // same value: a path camera -> x1 -> y_b ... -> y_1 -> light has b + 1 surface
        // vertices and must have at most max_depth - 1, so photons stored at x1 may have
        // bounced at most max_depth - 2 times.
        let mut photon_settings = settings.photons;
        if settings.max_depth >= 0 {
            photon_settings.max_bounces = photon_settings.max_bounces.min((settings.max_depth - 2).max(0) as u32);
        }
        let maps = trace_photons(scene, &photon_settings)?;
        let t0 = Instant::now();
        let needs_geometry = |s: &OctreeSettings| s.estimator == crate::caches::Estimator::GeometryArea;
        let tris = if needs_geometry(&settings.global) || needs_geometry(&settings.caustic) {
            Some(scene.world_triangles_where(Material::has_smooth_lobe))
        } else {
            None
        };
        let global = Octree::build(&maps.global, scene.bounds, &settings.global, tris.as_deref()).map_err(BuildError::Global)?;
        let caustic = if maps.caustic.is_empty() {
            None
        } else {
            Some(Octree::build(&maps.caustic, scene.bounds, &settings.caustic, tris.as_deref()).map_err(BuildError::Caustic)?)
        };
        let t_octree_s = t0.elapsed().as_secs_f64();
        let n = maps.global.len() + maps.caustic.len();
        let stats = OctreeBuildStats {
            photons_emitted: maps.emitted,
            global_photons: maps.global.len(),
            caustic_photons: maps.caustic.len(),
            t_photons_s: maps.time_s,
            t_octree_s,
            t_c_s: maps.time_s + t_octree_s,
            build_photons_per_s: n as f64 / t_octree_s.max(1e-9),
            global: global.stats().clone(),
            caustic: caustic.as_ref().map(|c| c.stats().clone()),
            bytes: global.stats().bytes + caustic.as_ref().map_or(0, |c| c.stats().bytes),
        };
        Ok(OctreeIntegrator { settings, global, caustic, stats })
    }

    /// Radiance along a primary ray.
    pub fn li(&self, scene: &Scene, mut ray: Ray, sampler: &mut Sampler, counters: &mut RayCounters) -> Color {
        let max_depth = if self.settings.max_depth < 0 { MAX_SPECULAR_CHAIN } else { self.settings.max_depth as u32 };
        let mut result = Color::ZERO;
        let mut throughput = Color::ONE;
        let mut depth = 0u32;
        loop {
            counters.rays += 1;
            let Some(hit) = scene.intersect(&ray) else {
                if self.settings.view == OctreeView::Render {
                    result += throughput * scene.lights.env_le(ray.d);
                }
                break;
            };
            if self.settings.view == OctreeView::Leaves {
                return self.leaf_colour(&hit, ray.d);
            }
            if let (Some(light), OctreeView::Render) = (hit.light, self.settings.view) {
                result += throughput * scene.lights.area_le(light, hit.ng, -ray.d);
            }
            let material = &scene.materials[hit.material as usize];
            let wo = hit.frame.to_local(-ray.d);
            if material.has_smooth_lobe() {
                match self.settings.view {
                    OctreeView::Render if self.settings.gather => {
                        let mut l = direct_light(scene, &hit, material, wo, sampler, counters);
                        l += self.indirect_from(scene, &hit, material, wo, counters, false, true);
                        l += self.gathered_global(scene, &hit, material, wo, depth + 1, max_depth, sampler, counters);
                        result += throughput * l;
                    }
                    OctreeView::Render => {
                        result += throughput
                            * (direct_light(scene, &hit, material, wo, sampler, counters)
                                + self.indirect_from(scene, &hit, material, wo, counters, true, true));
                    }
                    OctreeView::Irradiance | OctreeView::IrradianceAll => {
                        let n = facing_normal(&hit, ray.d);
                        let mut e = self.query(&self.global, hit.p, n, counters).map_or(Color::ZERO, |m| m.transpose() * n);
                        if self.settings.view == OctreeView::IrradianceAll {
                            if let Some(c) = &self.caustic {
                                e += self.query(c, hit.p, n, counters).map_or(Color::ZERO, |m| m.transpose() * n);
                            }
                        }
                        result += throughput * e.max(Color::ZERO);
                    }
                    OctreeView::Leaves => unreachable!(),
                }
                break;
            }
            // Pure specular material: follow the sampled delta lobe.
            if depth + 1 >= max_depth {
                break;
            }
            let u_lobe = sampler.next_1d();
            let u = sampler.next_2d();
            let Some(bs) = material.sample(&scene.images, hit.uv, wo, u_lobe, u) else { break };
            if bs.lobe != Lobe::Specular || !bs.weight.is_finite() {
                break;
            }
            throughput *= bs.weight;
            if throughput == Color::ZERO {
                break;
            }
            ray = hit.spawn(hit.frame.to_world(bs.wi));
            depth += 1;
        }
        result
    }

    /// Reflected light from the global and/or the caustic octree at `hit` (see the module docs).
    #[allow(clippy::too_many_arguments)]
    fn indirect_from(
        &self,
        scene: &Scene,
        hit: &SurfaceHit,
        material: &Material,
        wo: Vec3,
        counters: &mut RayCounters,
        global: bool,
        caustic: bool,
    ) -> Color {
        // The octree stores incident light on the side the photons came from; query with the
        // shading normal on the side of the viewer.
        let n = if wo.z >= 0.0 { hit.frame.n } else { -hit.frame.n };
        let trees = global.then_some(&self.global).into_iter().chain(self.caustic.as_ref().filter(|_| caustic));
        let mut l = Color::ZERO;
        // Lambertian: ρ/π E(N) is what shade_matrix returns, from the cheaper irradiance query.
        let albedo = material.lambertian_albedo(&scene.images, hit.uv, wo);
        for tree in trees {
            match albedo {
                Some(rho) => {
                    if rho != Color::ZERO {
                        if let Some(e) = self.timed_query(counters, || tree.irradiance(hit.p, n)) {
                            l += rho * e * std::f32::consts::FRAC_1_PI;
                        }
                    }
                }
                None => {
                    if let Some(m) = self.timed_query(counters, || tree.incident_matrix(hit.p, n)) {
                        l += shade_matrix(scene, hit, material, wo, &m);
                    }
                }
            }
        }
        l
    }

    /// The global (indirect) light reflected at `hit`, gathered one bounce away: a BSDF-sampled
    /// ray follows specular vertices to the first vertex `z` with a non-delta lobe, where the
    /// light leaving `z` towards `hit` is direct (shadow ray) + global + caustic octrees.
    /// Emission met on the way is skipped: it is direct light at `hit` (next-event estimation)
    /// or a caustic at `hit` (caustic octree). The paths counted are therefore exactly those
    /// of the global photon map — light that met at least one non-specular surface before
    /// `hit` — so direct + caustic + gathered global still partition the light at `hit`.
    /// `vertex` is `hit`'s index along the camera path (1 = first surface).
    #[allow(clippy::too_many_arguments)]
    fn gathered_global(
        &self,
        scene: &Scene,
        hit: &SurfaceHit,
        material: &Material,
        wo: Vec3,
        vertex: u32,
        max_depth: u32,
        sampler: &mut Sampler,
        counters: &mut RayCounters,
    ) -> Color {
        // Surface vertices must stay below max_depth (Mitsuba's count, the light is the last).
        if vertex + 2 > max_depth {
            return Color::ZERO;
        }
        let u_lobe = sampler.next_1d();
        let u = sampler.next_2d();
        let Some(bs) = material.sample(&scene.images, hit.uv, wo, u_lobe, u) else { return Color::ZERO };
        if !bs.weight.is_finite() {
            return Color::ZERO;
        }
        let mut throughput = bs.weight;
        let mut ray = hit.spawn(hit.frame.to_world(bs.wi));
        let mut vertex = vertex + 1;
        loop {
            counters.rays += 1;
            let Some(z) = scene.intersect(&ray) else { return Color::ZERO };
            let mz = &scene.materials[z.material as usize];
            let wo_z = z.frame.to_local(-ray.d);
            if mz.has_smooth_lobe() {
                let mut l = self.indirect_from(scene, &z, mz, wo_z, counters, true, true);
                if vertex < max_depth {
                    l += direct_light(scene, &z, mz, wo_z, sampler, counters);
                }
                return throughput * l;
            }
            if vertex + 1 >= max_depth {
                return Color::ZERO;
            }
            let u_lobe = sampler.next_1d();
            let u = sampler.next_2d();
            let Some(bs) = mz.sample(&scene.images, z.uv, wo_z, u_lobe, u) else { return Color::ZERO };
            if bs.lobe != Lobe::Specular || !bs.weight.is_finite() {
                return Color::ZERO;
            }
            throughput *= bs.weight;
            if throughput == Color::ZERO {
                return Color::ZERO;
            }
            ray = z.spawn(z.frame.to_world(bs.wi));
            vertex += 1;
        }
    }

    #[inline]
    fn query(&self, tree: &Octree, p: Vec3, n: Vec3, counters: &mut RayCounters) -> Option<Mat3> {
        self.timed_query(counters, || tree.incident_matrix(p, n))
    }

    /// Count a cache query and time one in [`QUERY_TIMING_STRIDE`] (a clock read per query
    /// cost ~3% of an octree render); the timed ones stand for the rest in `cache_query_ns`.
    #[inline]
    fn timed_query<T>(&self, counters: &mut RayCounters, f: impl FnOnce() -> T) -> T {
        counters.cache_queries += 1;
        if !counters.cache_queries.is_multiple_of(QUERY_TIMING_STRIDE) {
            return f();
        }
        let t = Instant::now();
        let r = f();
        counters.cache_query_ns += t.elapsed().as_nanos() as u64 * QUERY_TIMING_STRIDE;
        r
    }

    fn leaf_colour(&self, hit: &SurfaceHit, d: Vec3) -> Color {
        let Some(leaf) = self.global.leaf_at(hit.p) else { return Color::ZERO };
        if !leaf.valid {
            return Color::splat(0.02);
        }
        let h_max = self.global.settings().h_max.max(1) as f32;
        let hue = leaf.depth as f32 / h_max;
        let base = hsv(hue * 0.8, 0.7, 0.9);
        // Darken near cell borders (in units of the cell edge).
        let e = leaf.bounds.extent().x.max(1e-12);
        let rel = ((hit.p - leaf.bounds.min) / e).clamp(Vec3::ZERO, Vec3::ONE);
        let edge = rel.min(Vec3::ONE - rel);
        // Ignore the axis the surface is flat along (the one most aligned with the normal).
        let n = facing_normal(hit, d).abs();
        let dist = if n.x >= n.y && n.x >= n.z {
            edge.y.min(edge.z)
        } else if n.y >= n.z {
            edge.x.min(edge.z)
        } else {
            edge.x.min(edge.y)
        };
        if dist < 0.02 {
            base * 0.15
        } else {
            base
        }
    }
}

/// Shading normal turned towards the incoming ray.
#[inline]
fn facing_normal(hit: &SurfaceHit, d: Vec3) -> Vec3 {
    if hit.frame.n.dot(d) < 0.0 {
        hit.frame.n
    } else {
        -hit.frame.n
    }
}

/// `Σ_c f_c(wo, d_c) cos θ(d_c) |m_c|` with `m_c` the columns of the blended matrix.
#[inline]
fn shade_matrix(scene: &Scene, hit: &SurfaceHit, material: &Material, wo: Vec3, m: &Mat3) -> Color {
    let frame: &Frame = &hit.frame;
    let mut out = Color::ZERO;
    for c in 0..3 {
        let col = m.col(c);
        let len = col.length();
        if !(len > 0.0) || !len.is_finite() {
            continue;
        }
        let wi = frame.to_local(col / len);
        let f = material.eval(&scene.images, hit.uv, wo, wi);
        out[c] += f[c] * len;
    }
    out
}

fn hsv(h: f32, s: f32, v: f32) -> Color {
    let h6 = (h.fract() * 6.0).max(0.0);
    let i = h6.floor() as i32;
    let f = h6 - i as f32;
    let (p, q, t) = (v * (1.0 - s), v * (1.0 - s * f), v * (1.0 - s * (1.0 - f)));
    match i % 6 {
        0 => Color::new(v, t, p),
        1 => Color::new(q, v, p),
        2 => Color::new(p, v, t),
        3 => Color::new(p, q, v),
        4 => Color::new(t, p, v),
        _ => Color::new(v, p, q),
    }
}
