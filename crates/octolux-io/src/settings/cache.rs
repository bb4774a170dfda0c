//! A lighting cache's settings against a render's (`octolux_io::cache`): the cache's settings
//! as the render's base layer, and the refusal of a setting that shaped its octrees.

use super::{defaults, Result, SettingsError};
use crate::cache::LoadedCache;
use octolux::integrators::IntegratorSettings;
use serde_json::Value;
use std::path::Path;

/// A lighting cache's settings as the base layer of a render's ([`super::SettingsInput::base`]: an
/// object without `type`). The render-time `view` starts from the integrator's default, not
/// the bake's (a bake made with `--view leaves` made every later render write the leaves).
pub fn cache_base(c: &LoadedCache) -> Result<Value> {
    let mut v = serde_json::to_value(c.integrator.settings())?;
    let view = defaults(c.integrator.name())?.get("view").cloned();
    if let Value::Object(m) = &mut v {
        m.remove("type");
        if let (Some(view), Some(slot)) = (view, m.get_mut("view")) {
            *slot = view;
        }
    }
    Ok(v)
}

/// Refuse resolved settings that differ from the cache's in a key that shaped its octrees
/// (`IntegratorSettings::baked_keys`), naming each dotted key with both values.
pub fn check_cache_settings(path: &Path, c: &LoadedCache, resolved: &IntegratorSettings) -> Result<()> {
    if let (octolux::integrators::Integrator::Octree(o), IntegratorSettings::Octree(s)) = (&c.integrator, resolved) {
        if let Some(why) = o.missing_leak_samples(s, false) {
            bail!("lighting cache {}: {why}", path.display());
        }
    }
    let settings = c.integrator.settings();
    let keys = settings.baked_keys();
    let (baked, now) = (serde_json::to_value(&settings)?, serde_json::to_value(resolved)?);
    let mut changed = Vec::new();
    for k in &keys {
        differing_leaves(baked.get(*k), now.get(*k), k, &mut changed);
    }
    if changed.is_empty() {
        return Ok(());
    }
    let free: Vec<&str> = match &baked {
        Value::Object(m) => m.keys().map(String::as_str).filter(|k| *k != "type" && !keys.contains(k)).collect(),
        _ => vec![],
    };
    let names: Vec<&str> = changed.iter().map(|(k, _, _)| k.as_str()).collect();
    let values: Vec<String> = changed.iter().map(|(k, now, baked)| format!("{k} = {now} here, {baked} in the bake")).collect();
    bail!(
        "lighting cache {}: the settings {} differ from the bake's ({}); they shaped its octrees: re-bake with them, or leave \
         them out (with --cache only {} may change)",
        path.display(),
        names.join(", "),
        values.join("; "),
        free.join(", ")
    )
}

/// The dotted leaf keys under `key` whose values differ, with the value now and the baked one.
fn differing_leaves(baked: Option<&Value>, now: Option<&Value>, key: &str, out: &mut Vec<(String, String, String)>) {
    let show = |v: Option<&Value>| v.map_or("nothing".to_string(), |v| v.to_string());
    match (baked, now) {
        (Some(Value::Object(b)), Some(Value::Object(n))) => {
            let mut keys: Vec<&String> = b.keys().chain(n.keys()).collect();
            keys.sort();
            keys.dedup();
            for k in keys {
                differing_leaves(b.get(k), n.get(k), &format!("{key}.{k}"), out);
            }
        }
        (b, n) if b != n => out.push((key.to_string(), show(n), show(b))),
        _ => {}
    }
}
