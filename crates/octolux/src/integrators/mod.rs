//! Integrators: the closed set of rendering methods, each with one serde settings struct that
//! serves the CLI, settings files and tests, gathered in [`IntegratorSettings`] and built by
//! [`build`]. Adding an integrator touches only this folder: a variant in
//! [`IntegratorSettings`] and [`Integrator`], its name in [`IntegratorSettings::NAMES`], and the
//! arms of the `match`es below.
//!
//! Every integrator estimates the radiance arriving at the camera along a primary ray; the
//! render loop ([`crate::render`]) handles pixels, samples and the reconstruction filter.
//! - [`pathloop`]: the one path loop, with a policy that may end paths in a cache;
//! - [`path`]: the unidirectional path tracer (the loop, no cache), ground truth;
//! - [`octree`]: the loop ending paths in the incident-radiance octrees (§8);
//! - [`photon`]: the paper's baselines (§9) as one family: `photonmap`, `ward`, `christensen`;
//! - [`common`]: what they share (direct light, MIS, the specular-chain walk, counters).

pub mod common;
#[cfg(test)]
mod furnaces;
pub mod octree;
pub mod path;
pub mod pathloop;
pub mod photon;
#[cfg(test)]
pub(crate) mod test_scenes;

pub use common::RayCounters;

use crate::math::{Color, Ray, RayDifferential};
use crate::sampling::Sampler;
use crate::scene::Scene;
use octree::{OctreeIntegrator, OctreeIntegratorParts, OctreeIntegratorSettings};
use path::PathSettings;
use photon::christensen::{ChristensenIntegrator, ChristensenSettings};
use photon::photonmap::{PhotonMapIntegrator, PhotonMapSettings};
use photon::ward::{WardIntegrator, WardSettings};
use serde::{Deserialize, Serialize};

/// The settings of one integrator, tagged by its name (`{"type": "ward", ...}`); every field
/// of the inner struct is optional (defaults) and unknown fields are refused.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum IntegratorSettings {
    Path(PathSettings),
    Octree(OctreeIntegratorSettings),
    Photonmap(PhotonMapSettings),
    Ward(WardSettings),
    Christensen(ChristensenSettings),
}

impl IntegratorSettings {
    /// The integrators' names, as [`IntegratorSettings::name`] spells them.
    pub const NAMES: &'static [&'static str] = &["path", "octree", "photonmap", "ward", "christensen"];

    /// The default settings of the integrator called `name` (one of [`Self::NAMES`]).
    pub fn default_for(name: &str) -> Option<IntegratorSettings> {
        Some(match name {
            "path" => IntegratorSettings::Path(PathSettings::default()),
            "octree" => IntegratorSettings::Octree(OctreeIntegratorSettings::default()),
            "photonmap" => IntegratorSettings::Photonmap(PhotonMapSettings::default()),
            "ward" => IntegratorSettings::Ward(WardSettings::default()),
            "christensen" => IntegratorSettings::Christensen(ChristensenSettings::default()),
            _ => return None,
        })
    }

    /// The keys whose values a lighting cache fixes (the `octree` integrator's, docs/guide/
    /// baking.md): the photon pass, both octrees, `max_depth`, and `mode` when `max_depth` is
    /// bounded (the photons' bounces then depend on the vertex at which the mode reads the
    /// cache). A render from a cache may change every other key. Empty for the integrators
    /// that have no cache file.
    pub fn baked_keys(&self) -> Vec<&'static str> {
        match self {
            IntegratorSettings::Octree(o) => {
                let mut keys = vec!["photons", "global", "caustic", "max_depth"];
                if o.max_depth >= 0 {
                    keys.push("mode");
                }
                keys
            }
            _ => vec![],
        }
    }

    /// The integrator's name (the serde tag).
    pub fn name(&self) -> &'static str {
        match self {
            IntegratorSettings::Path(_) => "path",
            IntegratorSettings::Octree(_) => "octree",
            IntegratorSettings::Photonmap(_) => "photonmap",
            IntegratorSettings::Ward(_) => "ward",
            IntegratorSettings::Christensen(_) => "christensen",
        }
    }
}

/// Errors while building an integrator; the message starts with the integrator's name.
#[derive(Debug, thiserror::Error)]
pub enum IntegratorError {
    // The inner errors are in the messages, not chained as sources: a chain printed with
    // `{:#}` would say each cause twice.
    #[error("path: {0}")]
    Path(crate::caches::kdtree::SettingsError),
    #[error("octree: {0}")]
    Octree(octree::BuildError),
    #[error("{name}: {error}")]
    Baseline { name: &'static str, error: photon::BaselineError },
}

impl From<octree::BuildError> for IntegratorError {
    fn from(e: octree::BuildError) -> Self {
        IntegratorError::Octree(e)
    }
}

/// Build the integrator `settings` describe over `scene` (photon pass, caches, priming: the
/// work before rendering). The settings are validated first, before any long work.
pub fn build(settings: &IntegratorSettings, scene: &Scene) -> Result<Integrator, IntegratorError> {
    let baseline = |name: &'static str| move |error| IntegratorError::Baseline { name, error };
    Ok(match settings {
        IntegratorSettings::Path(s) => {
            s.validate().map_err(IntegratorError::Path)?;
            Integrator::Path(*s)
        }
        IntegratorSettings::Octree(s) => Integrator::Octree(Box::new(OctreeIntegrator::build(scene, s.clone())?)),
        IntegratorSettings::Photonmap(s) => {
            Integrator::PhotonMap(Box::new(PhotonMapIntegrator::build(scene, s.clone()).map_err(baseline("photonmap"))?))
        }
        IntegratorSettings::Ward(s) => Integrator::Ward(Box::new(WardIntegrator::build(scene, s.clone()).map_err(baseline("ward"))?)),
        IntegratorSettings::Christensen(s) => {
            Integrator::Christensen(Box::new(ChristensenIntegrator::build(scene, s.clone()).map_err(baseline("christensen"))?))
        }
    })
}

/// The `octree` integrator from prebuilt octrees (a cache file, docs/guide/baking.md): no photon is
/// traced; the parts are checked ([`OctreeIntegrator::from_parts`]). The CLI, tests (and
/// later Python) share this one path, as they share [`build`].
pub fn build_from_parts(parts: OctreeIntegratorParts) -> Result<Integrator, IntegratorError> {
    Ok(Integrator::Octree(Box::new(OctreeIntegrator::from_parts(parts)?)))
}

/// A prepared integrator.
pub enum Integrator {
    Path(PathSettings),
    /// The paper's ray tracer over a built global + caustic octree.
    Octree(Box<OctreeIntegrator>),
    /// Jensen's photon map with final gathering (baseline).
    PhotonMap(Box<PhotonMapIntegrator>),
    /// Ward's irradiance cache with photon-computed samples (baseline).
    Ward(Box<WardIntegrator>),
    /// Christensen's precomputed irradiance photons, optionally with a Ward cache (baseline).
    Christensen(Box<ChristensenIntegrator>),
}

impl Integrator {
    /// Short name used in stats and the CLI (the settings' tag).
    pub fn name(&self) -> &'static str {
        match self {
            Integrator::Path(_) => "path",
            Integrator::Octree(_) => "octree",
            Integrator::PhotonMap(_) => "photonmap",
            Integrator::Ward(_) => "ward",
            Integrator::Christensen(_) => "christensen",
        }
    }

    /// The settings the integrator was built with.
    pub fn settings(&self) -> IntegratorSettings {
        match self {
            Integrator::Path(s) => IntegratorSettings::Path(*s),
            Integrator::Octree(o) => IntegratorSettings::Octree(o.settings.clone()),
            Integrator::PhotonMap(o) => IntegratorSettings::Photonmap(o.settings.clone()),
            Integrator::Ward(o) => IntegratorSettings::Ward(o.settings.clone()),
            Integrator::Christensen(o) => IntegratorSettings::Christensen(o.settings.clone()),
        }
    }

    /// Build-time statistics (photon counts, cache sizes, timings) as JSON for out.json;
    /// `null` for the path tracer, which builds nothing.
    pub fn build_report(&self) -> serde_json::Value {
        let v = match self {
            Integrator::Path(_) => return serde_json::Value::Null,
            Integrator::Octree(o) => serde_json::to_value(&o.stats),
            Integrator::PhotonMap(o) => serde_json::to_value(&o.stats),
            Integrator::Ward(o) => serde_json::to_value(&o.stats),
            Integrator::Christensen(o) => serde_json::to_value(&o.stats),
        };
        // The stats are plain numbers and strings: serialising them cannot fail.
        v.unwrap_or(serde_json::Value::Null)
    }

    /// Render-time counters that are not in [`RayCounters`] (Ward's temporary samples,
    /// Christensen's lookups that fell back to the photon map), accumulated over every render
    /// with this integrator, as a JSON object (empty when the method has none).
    pub fn render_report(&self) -> serde_json::Value {
        match self {
            Integrator::Ward(o) => serde_json::json!({ "temporaries": o.temporary_samples() }),
            Integrator::Christensen(o) => serde_json::json!({ "misses": o.misses() }),
            Integrator::Octree(o) => o.leak_report(),
            Integrator::Path(_) | Integrator::PhotonMap(_) => serde_json::json!({}),
        }
    }

    /// Derive what rendering `scene` needs from it, after the integrator was made from a cache
    /// ([`build_from_parts`]) or its settings changed: the octree's leak-test planes
    /// ([`OctreeIntegrator::prepare`]). [`build`] does it; the other integrators need nothing.
    pub fn prepare(&mut self, scene: &Scene) {
        if let Integrator::Octree(o) = self {
            o.prepare(scene);
        }
    }

    /// Radiance along a primary ray; `diff`, its differential, gives texture lookups at the
    /// first hit their footprint (see `scene::material::texture`).
    #[inline]
    pub fn li(&self, scene: &Scene, ray: Ray, diff: Option<&RayDifferential>, sampler: &mut Sampler, counters: &mut RayCounters) -> Color {
        match self {
            Integrator::Path(s) => path::li(s, scene, ray, diff, sampler, counters),
            Integrator::Octree(o) => o.li(scene, ray, diff, sampler, counters),
            Integrator::PhotonMap(o) => o.li(scene, ray, diff, sampler, counters),
            Integrator::Ward(o) => o.li(scene, ray, diff, sampler, counters),
            Integrator::Christensen(o) => o.li(scene, ray, diff, sampler, counters),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrators::test_scenes::box_scene;

    #[test]
    fn names_defaults_and_tags_agree() {
        for &name in IntegratorSettings::NAMES {
            let s = IntegratorSettings::default_for(name).expect(name);
            assert_eq!(s.name(), name);
            let json = serde_json::to_value(&s).unwrap();
            assert_eq!(json["type"], name);
            let back: IntegratorSettings = serde_json::from_value(json).unwrap();
            assert_eq!(back, s, "{name}: round trip");
        }
        assert!(IntegratorSettings::default_for("bdpt").is_none());
    }

    #[test]
    fn partial_settings_fill_the_defaults_and_unknown_fields_are_refused() {
        let s: IntegratorSettings = serde_json::from_str(r#"{"type": "ward", "gather_rays": 3, "density": {"n_max": 50}}"#).unwrap();
        let IntegratorSettings::Ward(w) = &s else { panic!("{s:?}") };
        assert_eq!((w.gather_rays, w.density.n_max, w.max_depth), (3, 50, WardSettings::default().max_depth));
        let s: IntegratorSettings = serde_json::from_str(r#"{"type": "path"}"#).unwrap();
        assert_eq!(s, IntegratorSettings::Path(PathSettings::default()));
        for (bad, word) in [
            (r#"{"type": "ward", "gather_ray": 3}"#, "gather_ray"),
            (r#"{"type": "octree", "global": {"h_maxx": 3}}"#, "h_maxx"),
            (r#"{"type": "christensen", "photons": {"count": 3}}"#, "count"),
            (r#"{"type": "photonmap", "caustic": {"nmax": 3}}"#, "nmax"),
            (r#"{"type": "ward", "cache": {"prime": {"grid": {"cols": 3}}}}"#, "cols"),
            (r#"{"type": "bdpt"}"#, "bdpt"),
            (r#"{"max_depth": 3}"#, "type"),
        ] {
            let e = serde_json::from_str::<IntegratorSettings>(bad).err().unwrap_or_else(|| panic!("{bad} accepted"));
            assert!(e.to_string().contains(word), "{bad}: {e}");
        }
    }

    #[test]
    fn build_validates_first_and_names_the_integrator() {
        let scene = box_scene(4);
        let mut s = WardSettings::default();
        s.photons.photons = 0;
        let e = build(&IntegratorSettings::Ward(s), &scene).err().expect("refused");
        assert!(e.to_string().starts_with("ward: ") && e.to_string().contains("photons"), "{e}");
        let mut s = OctreeIntegratorSettings::default();
        s.global.n_max = 0;
        let e = build(&IntegratorSettings::Octree(s), &scene).err().expect("refused");
        assert!(e.to_string().starts_with("octree: "), "{e}");
        let i = build(&IntegratorSettings::Path(PathSettings::default()), &scene).unwrap();
        assert_eq!((i.name(), i.build_report(), i.render_report()), ("path", serde_json::Value::Null, serde_json::json!({})));
        let mut s = ChristensenSettings::default();
        s.photons.photons = 2000;
        let i = build(&IntegratorSettings::Christensen(s.clone()), &scene).unwrap();
        assert_eq!(i.settings(), IntegratorSettings::Christensen(s));
        assert!(i.build_report()["m_e"].as_u64().is_some_and(|m| m > 0), "{}", i.build_report());
        assert_eq!(i.render_report(), serde_json::json!({ "misses": 0 }));
    }
}
