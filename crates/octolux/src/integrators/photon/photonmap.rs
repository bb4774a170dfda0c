//! Jensen's photon map with final gathering (Jensen 1996; "Realistic Image Synthesis Using
//! Photon Mapping", 2001, ch. 9), the reference point of the paper's baselines (§9); the pieces
//! the three baselines share are in the family module ([`super`]).
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
//! maps, see `crate::photon::trace`), so the light leaving `y` is direct (shadow ray) + indirect
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

use super::{check_max_depth, validate_common, BaselineError, PhotonMapStats, ShadeCtx, Shading};

use super::CacheView;
use crate::caches::kdtree::{DensitySettings, SettingsError};
use crate::integrators::common::{direct_light, walk_specular, RayCounters};
use crate::math::{Color, Ray, RayDifferential};
use crate::photon::trace::{trace_photons, PhotonSettings};
use crate::sampling::Sampler;
use crate::scene::Scene;
use serde::{Deserialize, Serialize};

/// Settings of the `photonmap` integrator.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
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
        validate_common(&self.photons, &[("global", &self.global), ("caustic", &self.caustic)])?;
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
    pub fn li(&self, scene: &Scene, ray: Ray, diff: Option<&RayDifferential>, sampler: &mut Sampler, counters: &mut RayCounters) -> Color {
        let sh = &self.shading;
        let view = self.settings.view;
        let walk = walk_specular(scene, ray, diff, sh.max_depth, view == CacheView::Render, sampler, counters);
        let mut result = walk.emitted;
        let Some(v) = walk.vertex else { return result };
        let mut scratch = sh.scratch();
        let cx = &mut ShadeCtx { scene, sampler, counters, scratch: &mut scratch };
        let material = &scene.materials[v.hit.material as usize];
        match view {
            CacheView::Render => {
                let mut l = direct_light(scene, &v.hit, material, v.wo, cx.sampler, cx.counters);
                l += sh.caustics(cx, &v, material);
                let n = self.settings.gather_rays;
                let mut ind = Color::ZERO;
                for _ in 0..n {
                    let u_lobe = cx.sampler.next_1d();
                    let u = cx.sampler.next_2d();
                    let Some(bs) = material.sample(&scene.images, v.hit.uv, v.wo, u_lobe, u) else { continue };
                    if bs.lobe.is_delta() || !bs.weight.is_finite() || bs.weight == Color::ZERO {
                        continue;
                    }
                    let ray = v.hit.spawn(v.hit.frame.to_world(bs.wi));
                    ind += bs.weight * sh.gather_radiance(cx, ray).0;
                }
                l += ind / n as f32;
                result += v.throughput * l;
            }
            CacheView::Irradiance | CacheView::IrradianceAll => {
                let mut e = sh.gather_irradiance(cx, &v.hit, v.n, self.settings.gather_rays).0;
                if view == CacheView::IrradianceAll {
                    e += sh.caustic_irradiance(&v, cx.scratch, cx.counters);
                }
                result += v.throughput * e;
            }
        }
        result
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrators::test_scenes::{box_scene, check_furnace, furnace_scene, image_mean};
    use glam::Vec3;

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
