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
//! Transport is adjoint (importance-like) for photons: a refraction sampled by a radiance-mode
//! BSDF carries the `1/η²` radiance scaling, which flux must not have, so it is undone here.

use crate::math::{max_component, Ray};
use crate::photon::Photon;
use crate::sampling::Sampler;
use crate::scene::material::Lobe;
use crate::scene::Scene;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Stream index separating photon random numbers from pixel random numbers.
const PHOTON_STREAM: u64 = 0x5048_4f54_4f4e; // "PHOTON"

/// Settings of the photon pass.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default)]
pub struct PhotonSettings {
    /// Photon paths emitted from the lights.
    pub photons: u64,
    pub seed: u64,
    /// Longest photon path in bounces (safety net; Russian roulette ends most paths earlier).
    pub max_bounces: u32,
    /// Also store photons on purely specular surfaces (mirror, smooth glass), as the paper
    /// stores every hit. Off by default: nothing reads them, and near the diffuse surfaces
    /// they touch they bias the density estimates.
    pub store_on_specular: bool,
}

impl Default for PhotonSettings {
    fn default() -> Self {
        PhotonSettings { photons: 1_000_000, seed: 0, max_bounces: 32, store_on_specular: false }
    }
}

/// Errors of the photon pass.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum PhotonError {
    #[error("the photon count must be at least 1 (got {0})")]
    NoPhotons(u64),
    #[error("the scene has no light to emit photons from")]
    NoLight,
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
    /// Wall time of the pass in seconds.
    pub time_s: f64,
}

/// Trace `settings.photons` photon paths through `scene`.
pub fn trace_photons(scene: &Scene, settings: &PhotonSettings) -> Result<PhotonMaps, PhotonError> {
    if settings.photons == 0 {
        return Err(PhotonError::NoPhotons(0));
    }
    if scene.lights.is_empty() {
        return Err(PhotonError::NoLight);
    }
    let start = std::time::Instant::now();
    let n = settings.photons;
    let inv_n = 1.0 / n as f32;
    const CHUNK: u64 = 4096;
    let chunks: Vec<(Vec<Photon>, Vec<Photon>)> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut global = Vec::new();
            let mut caustic = Vec::new();
            for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
                trace_one(scene, settings, i, inv_n, &mut global, &mut caustic);
            }
            (global, caustic)
        })
        .collect();
    let mut maps = PhotonMaps { emitted: n, ..Default::default() };
    maps.global.reserve(chunks.iter().map(|c| c.0.len()).sum());
    maps.caustic.reserve(chunks.iter().map(|c| c.1.len()).sum());
    for (g, c) in chunks {
        maps.global.extend(g);
        maps.caustic.extend(c);
    }
    maps.time_s = start.elapsed().as_secs_f64();
    Ok(maps)
}

fn trace_one(scene: &Scene, settings: &PhotonSettings, index: u64, inv_n: f32, global: &mut Vec<Photon>, caustic: &mut Vec<Photon>) {
    let mut sampler = Sampler::new(settings.seed, index, PHOTON_STREAM);
    let u_sel = sampler.next_1d();
    let u_pos = sampler.next_2d();
    let u_dir = sampler.next_2d();
    let Some(em) = scene.lights.sample_emission(u_sel, u_pos, u_dir) else { return };
    let mut power = em.power * inv_n;
    if !(power.is_finite() && max_component(power) > 0.0) {
        return;
    }
    let mut ray = Ray::new(em.p, em.dir);
    if em.n != glam::Vec3::ZERO {
        ray.o = crate::math::offset_origin(em.p, em.n, em.dir);
    }
    // Bounces so far, and whether all of them were specular.
    let mut bounces = 0u32;
    let mut all_specular = true;
    while let Some(hit) = scene.intersect(&ray) {
        let wi = -ray.d;
        let material = &scene.materials[hit.material as usize];
        // Purely specular surfaces are never shaded from a photon estimate (renderers follow
        // their delta lobes), and photons kept on them would leak into the estimates of the
        // diffuse surfaces they touch (the floor under a glass sphere: +43% there, measured).
        if bounces > 0 && (settings.store_on_specular || material.has_smooth_lobe()) {
            let ng = if hit.ng.dot(wi) >= 0.0 { hit.ng } else { -hit.ng };
            let photon = Photon { p: hit.p, wi, power, ng };
            if all_specular {
                caustic.push(photon);
            } else {
                global.push(photon);
            }
        }
        if bounces >= settings.max_bounces {
            break;
        }
        let wo_local = hit.frame.to_local(wi);
        let u_lobe = sampler.next_1d();
        let u = sampler.next_2d();
        let Some(bs) = material.sample(&scene.images, hit.uv, wo_local, u_lobe, u) else { break };
        let mut weight = bs.weight;
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
        all_specular &= bs.lobe == Lobe::Specular;
        let dir = hit.frame.to_world(bs.wi);
        ray = hit.spawn(dir);
        bounces += 1;
    }
}
