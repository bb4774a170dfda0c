//! TEMPORARY stand-in for the library's `IntegratorSettings`, `build`, `build_report` and
//! `render_report` (issue 9, item 3), written against the integrators' existing settings
//! structs until the library has them; removed when it does.

use anyhow::{Context, Result};
use octolux::integrators::christensen::{ChristensenIntegrator, ChristensenSettings};
use octolux::integrators::octree::{OctreeIntegrator, OctreeIntegratorSettings};
use octolux::integrators::photonmap::{PhotonMapIntegrator, PhotonMapSettings};
use octolux::integrators::ward::{WardIntegrator, WardSettings};
use octolux::integrators::{path::PathSettings, Integrator};
use octolux::prepared::Scene;
use serde::{Deserialize, Serialize};
use serde_json::{json, Value};

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
    pub const NAMES: &'static [&'static str] = &["path", "octree", "photonmap", "ward", "christensen"];

    pub fn default_for(name: &str) -> Option<IntegratorSettings> {
        Some(match name {
            "path" => IntegratorSettings::Path(Default::default()),
            "octree" => IntegratorSettings::Octree(Default::default()),
            "photonmap" => IntegratorSettings::Photonmap(Default::default()),
            "ward" => IntegratorSettings::Ward(Default::default()),
            "christensen" => IntegratorSettings::Christensen(Default::default()),
            _ => return None,
        })
    }

    #[cfg_attr(not(test), allow(dead_code))]
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

pub fn build(settings: &IntegratorSettings, scene: &Scene) -> Result<Integrator> {
    Ok(match settings.clone() {
        IntegratorSettings::Path(s) => Integrator::Path(s),
        IntegratorSettings::Octree(s) => Integrator::Octree(Box::new(OctreeIntegrator::build(scene, s)?)),
        IntegratorSettings::Photonmap(s) => Integrator::PhotonMap(Box::new(PhotonMapIntegrator::build(scene, s)?)),
        IntegratorSettings::Ward(s) => Integrator::Ward(Box::new(WardIntegrator::build(scene, s)?)),
        IntegratorSettings::Christensen(s) => Integrator::Christensen(Box::new(ChristensenIntegrator::build(scene, s)?)),
    })
}

pub trait Reports {
    fn build_report(&self) -> Value;
    fn render_report(&self) -> Value;
}

impl Reports for Integrator {
    fn build_report(&self) -> Value {
        let v = match self {
            Integrator::Path(_) => return Value::Null,
            Integrator::Octree(o) => serde_json::to_value(&o.stats),
            Integrator::PhotonMap(o) => serde_json::to_value(&o.stats),
            Integrator::Ward(o) => serde_json::to_value(&o.stats),
            Integrator::Christensen(o) => serde_json::to_value(&o.stats),
        };
        v.context("stats").unwrap_or(Value::Null)
    }

    fn render_report(&self) -> Value {
        match self {
            Integrator::Ward(o) => json!({ "temporaries": o.temporary_samples() }),
            Integrator::Christensen(o) => json!({ "misses": o.misses() }),
            _ => json!({}),
        }
    }
}
