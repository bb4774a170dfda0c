//! The integrator settings of one render, from four layers (later wins):
//! Shared by the CLI and the Python module (one path from settings to an integrator).
//!
//! 1. the library's defaults for the chosen integrator (`IntegratorSettings::default_for`),
//!    with what the CLI derives from the scene and the render (the scene's `max_depth`, the
//!    render's seed for the photons), where the integrator has such a key;
//! 2. `--settings FILE.json|FILE.toml`;
//! 3. the flags (`--photons`, `--h-max`, ...: each knows its key paths, [`FlagSetting`]);
//! 4. `--set KEY=VALUE`, dotted keys into the settings.
//!
//! The layers are merged as JSON values, then deserialized into the library's serde-tagged
//! `IntegratorSettings`: nothing here knows an integrator by name, so adding one touches only
//! the library. A key of the settings file or of `--set` is
//! - written where it exists in the chosen integrator's settings;
//! - a warning when another integrator has it (a shared settings file, a wrong `--integrator`);
//! - otherwise an error naming it and listing the valid keys.
//!
//! A key below a value that is `null` (an `Option` left unset) or an object of one key (an
//! enum variant, e.g. `density.r_max.relative`) switches that value: `--set
//! density.r_max.absolute=30` replaces `{"relative": ...}` by `{"absolute": 30}`. The
//! deserialization then decides, and a key it drops is reported as unknown too.

pub mod reference;

pub use cache::{cache_base, check_cache_settings};

use crate::mitsuba::{PATH_TRACERS, SAME_IMAGE};
use octolux::integrators::IntegratorSettings;
use serde_json::{Map, Value};
use std::collections::HashSet;
use std::path::Path;

/// Key paths the front ends (CLI, Python) write or read in the settings.
pub mod keys {
    pub const PHOTON_COUNT: &str = "photons.photons";
    pub const PHOTON_SEED: &str = "photons.seed";
    pub const MAX_DEPTH: &str = "max_depth";
}

/// A settings error; the message names the layer (settings file, flag, `--set`) and the key.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct SettingsError(pub String);

type Result<T, E = SettingsError> = std::result::Result<T, E>;

impl From<serde_json::Error> for SettingsError {
    fn from(e: serde_json::Error) -> Self {
        SettingsError(e.to_string())
    }
}

macro_rules! bail {
    ($($t:tt)*) => { return Err(SettingsError(format!($($t)*))) };
}

/// `anyhow`'s `with_context` for this module: the context, then the cause after a colon.
trait Context<T> {
    fn with_context(self, f: impl FnOnce() -> String) -> Result<T>;
}

impl<T, E: std::fmt::Display> Context<T> for std::result::Result<T, E> {
    fn with_context(self, f: impl FnOnce() -> String) -> Result<T> {
        self.map_err(|e| SettingsError(format!("{}: {e}", f())))
    }
}

impl<T> Context<T> for Option<T> {
    fn with_context(self, f: impl FnOnce() -> String) -> Result<T> {
        self.ok_or_else(|| SettingsError(f()))
    }
}

/// What one command-line flag writes into the settings.
#[derive(Clone, Debug)]
pub struct FlagSetting {
    /// The flag as typed (`--h-max`), for messages.
    pub flag: &'static str,
    /// The one integrator the flag is meant for, if it is scoped to one (its keys may exist,
    /// with another meaning, in other integrators: `n_max` of a photon map's estimate).
    pub only: Option<&'static str>,
    /// Dotted key paths written with `value`; those the integrator lacks are skipped, and the
    /// flag warns when it lacks them all.
    pub keys: Vec<String>,
    pub value: Value,
    /// Lower the (numeric) value at the keys to at most `value` instead of replacing it.
    pub at_most: bool,
}

/// What `--max-depth D` writes (render and bake alike).
pub fn max_depth_flag(d: i32) -> FlagSetting {
    FlagSetting { flag: "--max-depth", only: None, keys: vec![keys::MAX_DEPTH.into()], value: serde_json::json!(d), at_most: false }
}

/// Everything the settings of one render come from.
pub struct SettingsInput<'a> {
    /// `--integrator`, if given.
    pub integrator: Option<&'a str>,
    /// Replaces the library's defaults as layer 1 (a lighting cache's settings, which the
    /// other layers may then change), as a settings object without `type`.
    pub base: Option<Value>,
    /// Values the CLI derives (layer 1): written silently where the integrator has the key.
    pub derived: Vec<(&'static str, Value)>,
    pub file: Option<&'a Path>,
    pub flags: Vec<FlagSetting>,
    /// The `--set` arguments as typed (`KEY=VALUE`).
    pub sets: &'a [String],
}

/// `max_depth` (Mitsuba's, in path vertices): -1 (unbounded) or at least 0. The one check of
/// the value, for the flag, `--set`, settings files, caches and `export` alike (the baselines
/// refuse 0 besides, when they are built).
pub fn check_max_depth(d: i64) -> std::result::Result<(), String> {
    if d < -1 {
        return Err(format!("{d} must be -1 (unbounded) or at least 0"));
    }
    Ok(())
}

/// The one check of an integrator's values, whatever layer they come from (flags, `--set`,
/// a settings file, a lighting cache, the Python module): run by [`resolve`] on the merged
/// settings and by [`crate::cache`] on a cache's, before any long work. It calls the library's
/// own validators (the octree settings', each baseline's), so that a value refused when the
/// integrator is built is refused here first, naming its source. This is the single hook for
/// validators that live with an integrator's settings.
pub fn check_values(s: &IntegratorSettings) -> std::result::Result<(), String> {
    let depth = |d: i32| check_max_depth(d as i64).map_err(|e| format!("max_depth {e}"));
    match s {
        IntegratorSettings::Path(p) => depth(p.max_depth).and_then(|()| p.validate().map_err(|e| e.to_string())),
        IntegratorSettings::Octree(o) => {
            depth(o.max_depth)?;
            if o.photons.photons == 0 {
                return Err("photons.photons must be at least 1".into());
            }
            o.global.validate().map_err(|e| format!("global: {e}"))?;
            o.caustic.validate().map_err(|e| format!("caustic: {e}"))
        }
        IntegratorSettings::Photonmap(p) => depth(p.max_depth).and_then(|()| p.validate().map_err(|e| e.to_string())),
        IntegratorSettings::Ward(w) => depth(w.max_depth).and_then(|()| w.validate().map_err(|e| e.to_string())),
        IntegratorSettings::Christensen(c) => depth(c.max_depth).and_then(|()| c.validate().map_err(|e| e.to_string())),
    }
}

/// How a front end spells what its user typed, for the messages of [`resolve_spelt`]: the
/// command line's `--set KEY=VALUE` and `--integrator NAME`, or Python's settings dict and
/// `integrator=` argument (`settings={"photons": {"bogus": 1}}`, `integrator='path'`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Spelling {
    #[default]
    Cli,
    Python,
}

impl Spelling {
    /// The write `KEY=VALUE` (a dotted key, a JSON value) as the user gave it.
    fn set(self, s: &str) -> String {
        match self {
            Spelling::Cli => format!("--set {s}"),
            Spelling::Python => {
                let (key, raw) = s.split_once('=').unwrap_or((s, ""));
                let mut out = python_literal(raw.trim());
                for part in key.trim().rsplit('.') {
                    out = format!("{{{}: {out}}}", Value::String(part.to_string()));
                }
                format!("settings={out}")
            }
        }
    }

    /// The choice of integrator `name`.
    fn integrator(self, name: &str) -> String {
        self.integrators(&[name])
    }

    /// The choice of one of the integrators `names` (`--integrator a, b`, `integrator 'a', 'b'`).
    fn integrators(self, names: &[&str]) -> String {
        match (self, names) {
            (Spelling::Cli, []) => "--integrator none".into(),
            (Spelling::Cli, _) => format!("--integrator {}", names.join(", ")),
            (Spelling::Python, []) => "no integrator".into(),
            (Spelling::Python, [one]) => format!("integrator='{one}'"),
            (Spelling::Python, _) => format!("integrator {}", names.iter().map(|n| format!("'{n}'")).collect::<Vec<_>>().join(", ")),
        }
    }
}

/// A JSON value as Python writes it (`true` -> `True`, `null` -> `None`; the rest reads alike).
fn python_literal(raw: &str) -> String {
    match raw {
        "true" => "True".into(),
        "false" => "False".into(),
        "null" => "None".into(),
        _ => raw.to_string(),
    }
}

/// The merged settings and the warnings met on the way.
#[derive(Debug)]
pub struct Resolved {
    pub settings: IntegratorSettings,
    pub warnings: Vec<String>,
}

/// One key written by the file or by `--set`, with its origin for messages.
#[derive(Clone, Debug)]
struct Write {
    source: String,
    key: String,
    value: Value,
}

/// Merges the layers (module docs) into the settings of one integrator.
pub fn resolve(input: &SettingsInput) -> Result<Resolved> {
    resolve_spelt(input, Spelling::Cli)
}

/// [`resolve`], its messages naming what the user typed as `spelling` spells it.
pub fn resolve_spelt(input: &SettingsInput, spelling: Spelling) -> Result<Resolved> {
    let file = input.file.map(read_settings_file).transpose()?;
    resolve_with(input, file, spelling)
}

/// The settings a settings file's text gives alone (no flag, no `--set`), as if read from
/// `path` (whose extension gives the format): the fuzz target's entry ([`crate::fuzzing`]).
pub fn resolve_file_text(path: &Path, text: &str) -> Result<Resolved> {
    let file = parse_settings_file(path, text)?;
    resolve_with(
        &SettingsInput { integrator: None, base: None, derived: vec![], file: Some(path), flags: vec![], sets: &[] },
        Some(file),
        Spelling::Cli,
    )
}

fn resolve_with(input: &SettingsInput, file: Option<SettingsFile>, sp: Spelling) -> Result<Resolved> {
    let int = |n: &str| sp.integrator(n);
    let name = match (input.integrator, file.as_ref().and_then(|f| f.integrator.as_deref())) {
        (Some(flag), Some(ty)) if flag != ty => {
            bail!("settings file {} is for {}, but {} was given", input.file.unwrap_or(Path::new("")).display(), int(ty), int(flag))
        }
        (Some(flag), _) => flag.to_string(),
        (None, Some(ty)) => ty.to_string(),
        (None, None) => "path".to_string(),
    };
    let mut base = match &input.base {
        Some(b) => b.clone(),
        None => defaults(&name)?,
    };
    for (key, value) in &input.derived {
        if let Some(slot) = lookup_mut(&mut base, key) {
            *slot = value.clone();
        }
    }
    let others: Vec<(&str, Value)> =
        IntegratorSettings::NAMES.iter().filter(|&&n| n != name).map(|&n| Ok((n, defaults(n)?))).collect::<Result<_>>()?;
    let mut warnings = Vec::new();
    let mut merged = base.clone();
    let mut created = HashSet::new();
    let mut writes = Vec::new();

    // layer 2: the file
    if let (Some(f), Some(path)) = (file, input.file) {
        let source = format!("settings file {}", path.display());
        let mut leaves = Vec::new();
        flatten(&f.values, String::new(), &mut leaves);
        // an empty file (`{}`, an empty .toml) sets nothing
        for (key, value) in leaves.into_iter().filter(|(k, _)| !k.is_empty()) {
            let value = enum_spelling(lookup(&base, &key), &value);
            writes.push(Write { source: source.clone(), key, value });
        }
    }
    let file_writes = writes.len();
    for w in &writes[..file_writes] {
        place_checked(&mut merged, &mut created, w, &name, &others, &mut warnings, sp)?;
    }
    // layer 3: the flags
    for f in &input.flags {
        if let Some(only) = f.only.filter(|&o| o != name) {
            warnings.push(format!("{} applies to {} only; ignored by {}", f.flag, int(only), int(&name)));
            continue;
        }
        let present: Vec<&String> = f.keys.iter().filter(|k| lookup(&merged, k).is_some()).collect();
        if present.is_empty() {
            let users: Vec<&str> = others.iter().filter(|(_, d)| f.keys.iter().any(|k| lookup(d, k).is_some())).map(|(n, _)| *n).collect();
            warnings.push(format!("{} applies to {} only; ignored by {}", f.flag, sp.integrators(&users), int(&name)));
            continue;
        }
        for key in present {
            let slot = lookup_mut(&mut merged, key).expect("present");
            match (f.at_most, slot.as_f64(), f.value.as_f64()) {
                (true, Some(cur), Some(v)) if cur <= v => {}
                _ => *slot = enum_spelling(Some(slot), &f.value),
            }
            // kept to name the flag in a deserialization error
            writes.push(Write { source: f.flag.to_string(), key: key.clone(), value: f.value.clone() });
        }
    }
    let set_writes = writes.len();
    // layer 4: --set
    for s in input.sets {
        let (key, raw) = s.split_once('=').with_context(|| format!("{}: expected KEY=VALUE (e.g. photons.photons=2000000)", sp.set(s)))?;
        let key = key.trim();
        if key == "type" {
            let how = match sp {
                Spelling::Cli => "--integrator",
                Spelling::Python => "integrator=",
            };
            bail!("{}: the integrator is chosen with {how} (or the settings file's `type`)", sp.set(s));
        }
        let value = match serde_json::from_str(raw) {
            Ok(v) => v,
            // JSON has no NaN or infinity: said so, not "invalid type: string"
            Err(_) if is_non_finite_word(raw) => bail!("{}: {} is not a finite number", sp.set(s), raw.trim()),
            // `1e999` and `{"epsilon": 1e999}`: said so, not "invalid type: string" or "not an object"
            Err(e) if e.to_string().starts_with("number out of range") => {
                bail!("{}: {} is not a finite number ({e})", sp.set(s), raw.trim())
            }
            Err(e) if raw.trim_start().starts_with(['{', '[']) => bail!("{}: {} is not valid JSON: {e}", sp.set(s), raw.trim()),
            Err(_) => Value::String(raw.to_string()),
        };
        let value = enum_spelling(lookup(&base, key), &value);
        writes.push(Write { source: sp.set(s), key: key.to_string(), value });
    }
    for w in &writes[set_writes..] {
        place_checked(&mut merged, &mut created, w, &name, &others, &mut warnings, sp)?;
    }

    let settings = deserialize(&name, &merged).map_err(|e| attribute(e, &name, &base, &writes, sp))?;
    if let Err(msg) = check_values(&settings) {
        // named after the first write that fails the check alone
        for w in &writes {
            let mut alone = base.clone();
            let fails = place(&mut alone, &mut HashSet::new(), &w.key, w.value.clone())
                && deserialize(&name, &alone).is_ok_and(|s| check_values(&s).is_err());
            if fails {
                bail!("{}: {msg}", w.source);
            }
        }
        bail!("the settings of {}: {msg}", int(&name));
    }
    // a key the deserialization dropped (a field of an enum variant it does not know, say)
    let round = serde_json::to_value(&settings)?;
    for w in &writes {
        let parts: Vec<&str> = w.key.split('.').collect();
        let (Some(m), r) = (lookup_parts(&merged, &parts), lookup_parts(&round, &parts)) else { continue };
        let mut missing = Vec::new();
        match r {
            Some(r) => dropped_keys(m, r, &w.key, &mut missing),
            None => missing.push(w.key.clone()),
        }
        if let Some(k) = missing.first() {
            bail!("{}: `{k}` is not a setting of {}; valid keys: {}", w.source, int(&name), valid_keys(&base));
        }
    }
    Ok(Resolved { settings, warnings })
}

/// What to say when the scene's `<integrator type>` is not what is rendered.
#[derive(Debug, PartialEq)]
pub enum IntegratorRemark {
    /// Another method converging to the same image ([`SAME_IMAGE`]).
    Note(String),
    /// An unknown type, or one whose image differs: it would otherwise render `used` silently.
    Warning(String),
}

/// The remark due when the scene's `<integrator type>` is not what is rendered and nothing on
/// the command line chose the integrator (`chosen`: `--integrator`, `--settings` or `--cache`).
pub fn scene_integrator_remark(scene_type: Option<&str>, scene: &str, used: &str, chosen: bool) -> Option<IntegratorRemark> {
    let ty = scene_type?;
    if chosen || ty == used || (used == "path" && PATH_TRACERS.contains(&ty)) {
        return None;
    }
    let names = IntegratorSettings::NAMES.join(", ");
    Some(if used == "path" && SAME_IMAGE.contains(&ty) {
        IntegratorRemark::Note(format!(
            "scene '{scene}': <integrator type=\"{ty}\"> converges to the image a path tracer converges to; \
             rendering with path (choose another with --integrator: {names})"
        ))
    } else {
        IntegratorRemark::Warning(format!(
            "scene '{scene}': <integrator type=\"{ty}\"> is not an octolux integrator; rendering with {used} (choose one with --integrator: {names})"
        ))
    })
}

/// A settings file: the integrator it names (`type`) and its other keys.
struct SettingsFile {
    integrator: Option<String>,
    values: Value,
}

fn read_settings_file(path: &Path) -> Result<SettingsFile> {
    let text = crate::files::read_to_string(path).map_err(|e| SettingsError(format!("cannot read settings file {e}")))?;
    parse_settings_file(path, &text)
}

fn parse_settings_file(path: &Path, text: &str) -> Result<SettingsFile> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    // both errors say the line and column of a syntax error
    let value: Value = match ext.as_str() {
        "json" => serde_json::from_str(text).with_context(|| format!("settings file {} is not valid JSON", path.display()))?,
        "toml" => {
            let t: toml::Value = toml::from_str(text).with_context(|| format!("settings file {} is not valid TOML", path.display()))?;
            // NaN and infinity became JSON null ("invalid type: null"): refused by name first
            if let Some((key, v)) = non_finite_float(&t, String::new()) {
                bail!("settings file {}: `{key}` = {v} is not a finite number", path.display());
            }
            serde_json::to_value(t)?
        }
        _ => bail!("settings file {}: expected a .json or .toml file", path.display()),
    };
    let Value::Object(mut map) = value else { bail!("settings file {}: expected a table of settings at the top", path.display()) };
    let integrator = match map.remove("type") {
        None => None,
        Some(Value::String(t)) if IntegratorSettings::NAMES.contains(&t.as_str()) => Some(t),
        Some(t) => bail!("settings file {}: `type` = {t} is not an integrator ({})", path.display(), IntegratorSettings::NAMES.join(", ")),
    };
    Ok(SettingsFile { integrator, values: Value::Object(map) })
}

/// `nan`, `inf`, `-infinity`, ... (any case): a number JSON cannot write.
fn is_non_finite_word(raw: &str) -> bool {
    let w = raw.trim().trim_start_matches(['+', '-']).to_ascii_lowercase();
    matches!(w.as_str(), "nan" | "inf" | "infinity")
}

/// The first float of a TOML value that is NaN or infinite, with its dotted key.
fn non_finite_float(v: &toml::Value, key: String) -> Option<(String, f64)> {
    match v {
        toml::Value::Float(f) if !f.is_finite() => Some((key, *f)),
        toml::Value::Table(t) => {
            t.iter().find_map(|(k, v)| non_finite_float(v, if key.is_empty() { k.clone() } else { format!("{key}.{k}") }))
        }
        toml::Value::Array(a) => a.iter().enumerate().find_map(|(i, v)| non_finite_float(v, format!("{key}[{i}]"))),
        _ => None,
    }
}

/// The defaults of integrator `name` as a JSON object without its `type` tag.
fn defaults(name: &str) -> Result<Value> {
    let s = IntegratorSettings::default_for(name).ok_or_else(|| SettingsError(format!("unknown integrator '{name}'")))?;
    let mut v = serde_json::to_value(s)?;
    if let Value::Object(m) = &mut v {
        m.remove("type");
    }
    Ok(v)
}

fn deserialize(name: &str, merged: &Value) -> serde_json::Result<IntegratorSettings> {
    let mut tagged = Map::new();
    tagged.insert("type".into(), Value::String(name.into()));
    if let Value::Object(m) = merged {
        tagged.extend(m.clone());
    }
    serde_json::from_value(Value::Object(tagged))
}

/// Names the write a deserialization error comes from: the first that fails alone.
fn attribute(e: serde_json::Error, name: &str, base: &Value, writes: &[Write], sp: Spelling) -> SettingsError {
    for w in writes {
        let mut alone = base.clone();
        if place(&mut alone, &mut HashSet::new(), &w.key, w.value.clone()) && deserialize(name, &alone).is_err() {
            return SettingsError(format!("{}: {e}", w.source));
        }
    }
    SettingsError(format!("the settings of {} do not hold together: {e}", sp.integrator(name)))
}

/// [`place`], with the warning or error of a key the integrator lacks.
fn place_checked(
    merged: &mut Value,
    created: &mut HashSet<String>,
    w: &Write,
    name: &str,
    others: &[(&str, Value)],
    warnings: &mut Vec<String>,
    sp: Spelling,
) -> Result<()> {
    // A table of settings (an object of several keys) takes an object, key by key (`{}`
    // changes nothing; it reset the fields to their struct defaults, which are not the
    // integrator's); any other value is refused (an array filled the fields by position).
    if let Some(Value::Object(m)) = lookup(merged, &w.key).filter(|v| v.as_object().is_some_and(|m| m.len() > 1)) {
        let Value::Object(given) = &w.value else {
            let keys: Vec<&str> = m.keys().map(String::as_str).collect();
            bail!(
                "{}: `{}` is a table of settings ({}), not a value: set its keys (`{}.{}=...`) or give an object",
                w.source,
                w.key,
                keys.join(", "),
                w.key,
                keys[0]
            );
        };
        let mut leaves = Vec::new();
        flatten(&Value::Object(given.clone()), String::new(), &mut leaves);
        for (k, v) in leaves.into_iter().filter(|(k, _)| !k.is_empty()) {
            let sub = Write { source: w.source.clone(), key: format!("{}.{k}", w.key), value: v };
            place_checked(merged, created, &sub, name, others, warnings, sp)?;
        }
        return Ok(());
    }
    let value = enum_spelling(lookup(merged, &w.key), &w.value);
    if place(merged, created, &w.key, value) {
        return Ok(());
    }
    let users: Vec<&str> = others.iter().filter(|(_, d)| accepts(d, &w.key)).map(|(n, _)| *n).collect();
    if users.is_empty() {
        bail!("{}: no integrator has the setting `{}`; the keys of {} are: {}", w.source, w.key, sp.integrator(name), valid_keys(merged));
    }
    let not_of = match sp {
        Spelling::Cli => name.to_string(),
        Spelling::Python => format!("'{name}'"),
    };
    warnings.push(format!("{}: `{}` is a setting of {}, not of {not_of}; ignored", w.source, w.key, sp.integrators(&users)));
    Ok(())
}

/// The leaf keys of a settings value, comma-separated.
pub fn valid_keys(v: &Value) -> String {
    let mut leaves = Vec::new();
    flatten(v, String::new(), &mut leaves);
    leaves.into_iter().map(|(k, _)| k).collect::<Vec<_>>().join(", ")
}

/// The value at a dotted key of the settings (e.g. the photon count for the log).
pub fn get(settings: &IntegratorSettings, key: &str) -> Option<Value> {
    lookup(&serde_json::to_value(settings).ok()?, key).cloned()
}

/// One spelling for every value: an enum value may be written with `-` for `_`
/// (`geometry-area`, as a command-line value would be) wherever the settings hold a string:
/// the flag, `--set`, a settings file and Python alike. Returns the value to write.
fn enum_spelling(current: Option<&Value>, value: &Value) -> Value {
    match (current, value) {
        (Some(Value::String(_)), Value::String(s))
            if s.contains('-') && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_') =>
        {
            Value::String(s.replace('-', "_"))
        }
        _ => value.clone(),
    }
}

// after `bail!`, which it uses
mod cache;
mod json;
use json::{accepts, dropped_keys, flatten, lookup, lookup_mut, lookup_parts, place};
#[cfg(test)]
mod tests;
