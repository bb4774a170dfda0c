//! The photon pass of Pacanowski et al. §2: photons leave the lights in proportion to power,
//! bounce with Russian roulette by reflectance, and every surface hit with a non-delta lobe is
//! stored (diffuse and glossy ones, not only diffuse) with its position, incident direction
//! (towards the light), power and the geometric normal on the side the photon arrived from.
//! The paper stores hits on purely specular surfaces too (`store_on_specular`); by default we
//! do not, because no renderer reads them and they leak into neighbouring diffuse estimates.
//!
//! Two maps, classified by the path that brought the photon to the surface `x`
//! (`L X1 … Xk x`):
//! - `k = 0` (direct light): stored in **neither** map. The ray tracer computes direct light
//!   with shadow rays, so counting it in the global map would count it twice.
//! - `k ≥ 1`, all `Xi` specular: the **caustic** map (`L S+ x`).
//! - `k ≥ 1`, at least one `Xi` diffuse or glossy: the **global** (indirect) map.
//!   Direct + caustic + global therefore partition the light arriving at `x` exactly once.
//!
//! Photon `i` draws its random numbers from `Sampler::new(seed, i, PHOTON_STREAM)`, so the maps
//! are identical for any thread count (chunks are traced in parallel and concatenated in order).
//! Each photon carries `Φ_light_sample / N` where `N` is the number of emitted photons.
//!
//! Distant lights (sun, sky, environment, directional) emit from the scene's bounding disc;
//! unless `guide_disc` is off, a pilot pass first finds which part of that disc sends photons
//! to stored surfaces (through an interior's windows) and the disc positions are drawn from it,
//! each photon's power divided by that density ([`super::guide`]: unbiased, deterministic).
//!
//! Transport is adjoint (importance-like) for photons: a refraction sampled by a radiance-mode
//! BSDF carries the `1/η²` radiance scaling, which flux must not have, so it is undone here.

use super::guide::{self, DiscGuide};
use super::Photon;
use crate::math::{facing, max_component, Ray};
use crate::sampling::Sampler;
use crate::scene::material::Lobe;
use crate::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Stream index separating photon random numbers from pixel random numbers.
pub(super) const PHOTON_STREAM: u64 = 0x5048_4f54_4f4e; // "PHOTON"
/// Stream of the pilot photons of the disc guide.
const PILOT_STREAM: u64 = 0x0050_494c_4f54; // "PILOT"

/// Settings of the photon pass.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct PhotonSettings {
    /// Photon paths emitted from the lights.
    pub photons: u64,
    /// Seed of the photon pass; the front ends set it to the render's `--seed` unless it is
    /// given (so a render and its bake with one seed agree).
    pub seed: u64,
    /// Longest photon path in bounces (safety net; Russian roulette ends most paths earlier).
    pub max_bounces: u32,
    /// Also store photons on purely specular surfaces (mirror, smooth glass), as the paper
    /// stores every hit. Off by default: nothing reads them, and near the diffuse surfaces
    /// they touch they bias the density estimates.
    pub store_on_specular: bool,
    /// Draw distant-light photons from the part of the bounding disc that a pilot pass found
    /// to reach stored surfaces ([`super::guide`]); off: the whole disc, uniformly.
    pub guide_disc: bool,
}

impl Default for PhotonSettings {
    fn default() -> Self {
        PhotonSettings { photons: 1_000_000, seed: 0, max_bounces: 32, store_on_specular: false, guide_disc: true }
    }
}

/// Errors of the photon pass.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum PhotonError {
    #[error("the photon count must be at least 1 (got {0})")]
    NoPhotons(u64),
    #[error("the scene has no light to emit photons from")]
    NoLight,
    /// The photons (at most one stored per emitted path and bounce; counted as one per path)
    /// would not fit in the memory budget ([`crate::budget`]).
    #[error(transparent)]
    Budget(#[from] crate::budget::BudgetError),
    /// The path records of an update ([`super::paths::PhotonPaths`]) index photons and
    /// flight points with 32 bits.
    #[error("the photon paths hold more than 2^32 photons or flight points")]
    TooManyRecords,
}

/// Output of the photon pass.
#[derive(Clone, Debug, Default)]
pub struct PhotonMaps {
    /// Indirect photons (see the module doc).
    pub global: Vec<Photon>,
    /// Caustic photons (`L S+ x`).
    pub caustic: Vec<Photon>,
    /// Number of photon paths emitted.
    pub emitted: u64,
    /// Wall time of the pass in seconds (the guide's pilot included).
    pub time_s: f64,
    /// Pilot photon paths traced for the disc guide (0: no guide).
    pub pilot: u64,
    /// Direction bins whose disc positions the guide draws (of `guide::DIR_Z * guide::DIR_PHI`).
    pub guided_bins: usize,
}

/// Trace `settings.photons` photon paths through `scene`.
pub fn trace_photons(scene: &Scene, settings: &PhotonSettings) -> Result<PhotonMaps, PhotonError> {
    check_pass(scene, settings)?;
    let start = std::time::Instant::now();
    let n = settings.photons;
    let inv_n = 1.0 / n as f32;
    let (disc_guide, pilot) = disc_guide(scene, settings);
    let chunks: Vec<(Vec<Photon>, Vec<Photon>)> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut global = Vec::new();
            let mut caustic = Vec::new();
            for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
                trace_path(
                    scene,
                    settings,
                    i,
                    PHOTON_STREAM,
                    inv_n,
                    disc_guide.as_ref(),
                    |hit| store(&hit, &mut global, &mut caustic),
                    |_| {},
                );
            }
            (global, caustic)
        })
        .collect();
    let guided_bins = disc_guide.as_ref().map_or(0, DiscGuide::guided_bins);
    let mut maps = PhotonMaps { emitted: n, pilot, guided_bins, ..Default::default() };
    maps.global.reserve(chunks.iter().map(|c| c.0.len()).sum());
    maps.caustic.reserve(chunks.iter().map(|c| c.1.len()).sum());
    for (g, c) in chunks {
        maps.global.extend(g);
        maps.caustic.extend(c);
    }
    maps.time_s = start.elapsed().as_secs_f64();
    Ok(maps)
}

/// What a photon pass needs: at least one photon, a light, and room for the photons.
pub(super) fn check_pass(scene: &Scene, settings: &PhotonSettings) -> Result<(), PhotonError> {
    if settings.photons == 0 {
        return Err(PhotonError::NoPhotons(0));
    }
    if scene.lights.is_empty() {
        return Err(PhotonError::NoLight);
    }
    crate::budget::check_photons(settings.photons)?;
    Ok(())
}

/// The disc guide of the pass (`None` without a distant light or with `guide_disc` off) and
/// the pilot paths it took.
pub(super) fn disc_guide(scene: &Scene, settings: &PhotonSettings) -> (Option<DiscGuide>, u64) {
    if settings.guide_disc && scene.lights.lights.iter().any(guide::from_disc) {
        let (g, m) = pilot_guide(scene, settings, guide::pilot_cap(settings.photons));
        (Some(g), m)
    } else {
        (None, 0)
    }
}

/// Keep a path's hit in the map it belongs to (module docs): none for the light's own hit or
/// a surface that stores no photon.
#[inline]
pub(super) fn store(hit: &PathHit, global: &mut Vec<Photon>, caustic: &mut Vec<Photon>) {
    if hit.bounces > 0 && hit.storable {
        if hit.all_specular {
            caustic.push(hit.photon);
        } else {
            global.push(hit.photon);
        }
    }
}

/// Photon paths per parallel work item.
pub(super) const CHUNK: u64 = 4096;

/// The pilot pass of the disc guide: photons emitted like the main pass's (uniform disc), in
/// rounds of [`guide::PILOT_ROUND`] until their paths have stored [`guide::PILOT_STORED`]
/// photons or `cap` paths were traced (the decision depends on the counts only: deterministic),
/// counting per direction bin and disc cell the photons they store. Returns the guide and the
/// number of pilot paths.
fn pilot_guide(scene: &Scene, settings: &PhotonSettings, cap: u64) -> (DiscGuide, u64) {
    let mut counts = vec![0u32; guide::DIR_Z * guide::DIR_PHI * guide::GRID * guide::GRID];
    let (mut traced, mut stored_total) = (0u64, 0u64);
    while traced < cap && stored_total < guide::PILOT_STORED {
        let end = (traced + guide::PILOT_ROUND).min(cap);
        let per_chunk: Vec<Vec<(u32, u32)>> = (traced.div_ceil(CHUNK)..end.div_ceil(CHUNK))
            .into_par_iter()
            .map(|c| {
                let mut found = Vec::new();
                for i in (c * CHUNK).max(traced)..((c + 1) * CHUNK).min(end) {
                    let mut stored = 0u32;
                    let start = trace_path(
                        scene,
                        settings,
                        i,
                        PILOT_STREAM,
                        1.0,
                        None,
                        |hit| stored += (hit.bounces > 0 && hit.storable) as u32,
                        |_| {},
                    );
                    if let Some((dir, u_pos)) = start.filter(|_| stored > 0) {
                        found.push(((guide::dir_bin(dir) * guide::GRID * guide::GRID + guide::cell(u_pos)) as u32, stored));
                    }
                }
                found
            })
            .collect();
        for (k, stored) in per_chunk.into_iter().flatten() {
            counts[k as usize] = counts[k as usize].saturating_add(stored);
            stored_total += stored as u64;
        }
        traced = end;
    }
    (DiscGuide::from_counts(&counts), traced)
}

/// One flight of a photon path, from a light or a surface to the next surface.
#[derive(Clone, Copy, Debug)]
pub struct Flight {
    /// Where it starts (scene units).
    pub o: Vec3,
    /// Its direction of travel (unit).
    pub d: Vec3,
    /// Its length (scene units); infinite when it leaves the scene.
    pub t: f32,
    /// The power it carries (W, RGB, the photon's share).
    pub power: Vec3,
    /// Bounces before it (0: from the light).
    pub bounces: u32,
    /// Whether every bounce before it was specular (vacuously true from the light).
    pub all_specular: bool,
}

impl Flight {
    /// The light of the global map (module docs): reflected at least once, by at least one
    /// non-delta surface.
    pub fn is_global(&self) -> bool {
        self.bounces > 0 && !self.all_specular
    }
}

/// The flights of the photon pass of `settings`, the same paths as [`trace_photons`] traces
/// (the disc guide's pilot included), every flight of them: those that end on a mirror or
/// glass, and those that leave the scene, too. `map` sees the flights of one chunk of paths at a
/// time, in path order; the results come back in chunk order, so anything summed from them
/// in that order is the same for any thread count.
pub fn map_flights<R: Send>(scene: &Scene, settings: &PhotonSettings, map: impl Fn(&[Flight]) -> R + Sync) -> Result<Vec<R>, PhotonError> {
    check_pass(scene, settings)?;
    let n = settings.photons;
    let inv_n = 1.0 / n as f32;
    let disc_guide = disc_guide(scene, settings).0;
    Ok((0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut flights = Vec::new();
            for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
                trace_path(scene, settings, i, PHOTON_STREAM, inv_n, disc_guide.as_ref(), |_| {}, |f| flights.push(f));
            }
            map(&flights)
        })
        .collect())
}

/// The first surface hits of the photon pass of `settings` (its direct light, which neither
/// map stores): the same paths as [`trace_photons`], one photon per path that meets a surface
/// that may hold photons, in path order. `octolux view` builds a direct-light octree of them
/// (`OctreeIntegrator::direct_octree`).
pub fn direct_photons(scene: &Scene, settings: &PhotonSettings) -> Result<Vec<Photon>, PhotonError> {
    check_pass(scene, settings)?;
    let n = settings.photons;
    let inv_n = 1.0 / n as f32;
    let disc_guide = disc_guide(scene, settings).0;
    let chunks: Vec<Vec<Photon>> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut out = Vec::new();
            for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
                let keep = |h: PathHit| {
                    if h.bounces == 0 && h.storable {
                        out.push(h.photon);
                    }
                };
                trace_path(scene, settings, i, PHOTON_STREAM, inv_n, disc_guide.as_ref(), keep, |_| {});
            }
            out
        })
        .collect();
    Ok(chunks.concat())
}

/// One surface hit of a photon path, as [`trace_path`] reports it.
#[derive(Clone, Copy, Debug)]
pub(super) struct PathHit {
    pub photon: Photon,
    /// Bounces before this hit (0: the light's own ray).
    pub bounces: u32,
    /// Whether every bounce before this hit was specular (vacuously true for `bounces == 0`).
    pub all_specular: bool,
    /// The surface may hold photons (a non-delta lobe, or `store_on_specular`).
    pub storable: bool,
}

/// Trace photon path `index` of random stream `stream` and hand every surface hit to `visit`,
/// in path order; the photon pass keeps the hits after at least one bounce (module docs), tests
/// see them all. A distant-light photon takes its disc position from `disc_guide` when given.
/// Returns, for a distant-light photon emitted uniformly over the disc (no guide), its direction
/// and its point of the unit square (the pilot's record).
// the path's identity (index, stream), its power scale, its guide and the two sinks
#[allow(clippy::too_many_arguments)]
pub(super) fn trace_path(
    scene: &Scene,
    settings: &PhotonSettings,
    index: u64,
    stream: u64,
    inv_n: f32,
    disc_guide: Option<&DiscGuide>,
    mut visit: impl FnMut(PathHit),
    mut fly: impl FnMut(Flight),
) -> Option<(glam::Vec3, glam::Vec2)> {
    let mut sampler = Sampler::new(settings.seed, index, stream);
    let u_sel = sampler.next_1d();
    let u_pos = sampler.next_2d();
    let u_dir = sampler.next_2d();
    let mut em = scene.lights.sample_emission(u_sel, u_pos, u_dir)?;
    let distant = scene.lights.lights.get(em.light as usize).is_some_and(guide::from_disc);
    let mut power = em.power * inv_n;
    if let Some(g) = disc_guide.filter(|_| distant) {
        // For a distant light `u_pos` only placed the photon on the disc: redraw it.
        let (center, radius) = scene.lights.scene_sphere();
        let (u, w) = g.sample(em.dir, u_pos);
        em.p = crate::scene::lights::disk_origin(center, radius, em.dir, u);
        power *= w;
    }
    if !(power.is_finite() && max_component(power) > 0.0) {
        return None;
    }
    let start = (distant && disc_guide.is_none()).then_some((em.dir, u_pos));
    let mut ray = Ray::new(em.p, em.dir);
    if em.n != glam::Vec3::ZERO {
        ray.o = crate::math::offset_origin(em.p, em.n, em.dir);
    }
    // Bounces so far, and whether all of them were specular.
    let mut bounces = 0u32;
    let mut all_specular = true;
    // one hit record for every bounce (`Scene::intersect_into`)
    let mut found = None;
    loop {
        scene.intersect_into(&ray, &mut found);
        fly(Flight { o: ray.o, d: ray.d, t: found.as_ref().map_or(f32::INFINITY, |h| h.t), power, bounces, all_specular });
        let Some(hit) = found.as_ref() else { break };
        let wi = -ray.d;
        let material = &scene.materials[hit.material as usize];
        // Purely specular surfaces are never shaded from a photon estimate (renderers follow
        // their delta lobes), and photons kept on them would leak into the estimates of the
        // diffuse surfaces they touch (the floor under a glass sphere: +43% there, measured).
        // No photon where a mask is fully transparent: nothing is there to reflect it.
        let storable = (settings.store_on_specular || material.has_smooth_lobe()) && material.opacity(&scene.images, hit.uv) > 0.0;
        visit(PathHit { photon: Photon { p: hit.p, wi, power, ng: facing(hit.ng, wi) }, bounces, all_specular, storable });
        if bounces >= settings.max_bounces {
            break;
        }
        let wo_local = hit.frame.to_local(wi);
        let u_lobe = sampler.next_1d();
        let u = sampler.next_2d();
        let Some(bs) = material.sample(&scene.images, hit.uv, wo_local, u_lobe, u) else { break };
        let dir = hit.frame.to_world(bs.wi);
        // Bump and normal maps: side check and terminator shadowing (1 elsewhere).
        let mut weight = bs.weight * if bs.lobe == Lobe::Null { 1.0 } else { hit.shading_factor(dir) };
        if bs.eta != 1.0 {
            // Undo the radiance-mode 1/eta² scaling: flux is not compressed by refraction.
            weight *= bs.eta * bs.eta;
        }
        if !weight.is_finite() {
            break;
        }
        // Russian roulette by reflectance: keep the photon's power roughly constant.
        let q = max_component(weight).min(1.0);
        if q <= 0.0 || sampler.next_1d() >= q {
            break;
        }
        power *= weight / q;
        // A mask's pass-through is a delta vertex like a mirror (Mitsuba's depth count): light
        // reaching a diffuse surface only through it stays a caustic-map photon, which the
        // camera side needs since its shadow rays stop at masks.
        all_specular &= bs.lobe.is_delta();
        ray = hit.spawn(dir);
        bounces += 1;
    }
    start
}

#[cfg(test)]
mod tests;
