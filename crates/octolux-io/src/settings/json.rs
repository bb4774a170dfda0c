//! The settings as a JSON value: dotted keys placed, looked up and flattened (`settings.rs`).

use serde_json::{Map, Value};
use std::collections::HashSet;

/// Writes `value` at the dotted `key`; false when the settings have no such key (module docs:
/// keys below `null` or a one-key object switch it; `created` remembers the switched values,
/// whose new fields then extend them).
pub(super) fn place(merged: &mut Value, created: &mut HashSet<String>, key: &str, value: Value) -> bool {
    let parts: Vec<&str> = key.split('.').collect();
    if parts.iter().any(|p| p.is_empty()) {
        return false;
    }
    // the longest prefix that exists (the whole key first)
    let Some(i) = (1..=parts.len()).rev().find(|&i| lookup_parts(merged, &parts[..i]).is_some()) else { return false };
    let slot = lookup_parts_mut(merged, &parts[..i]).expect("exists");
    if i == parts.len() {
        *slot = value;
        return true;
    }
    let prefix = parts[..i].join(".");
    let in_created = (1..=i).any(|j| created.contains(&parts[..j].join(".")));
    match slot {
        Value::Object(m) if in_created => {
            insert_nested(m, &parts[i..], value);
        }
        Value::Null => {
            *slot = nested(&parts[i..], value);
            created.insert(prefix);
        }
        Value::Object(m) if m.len() == 1 => {
            *slot = nested(&parts[i..], value);
            created.insert(prefix);
        }
        _ => return false,
    }
    true
}

/// Whether [`place`] would take `key` in `defaults`.
pub(super) fn accepts(defaults: &Value, key: &str) -> bool {
    place(&mut defaults.clone(), &mut HashSet::new(), key, Value::Null)
}

pub(super) fn nested(parts: &[&str], value: Value) -> Value {
    let mut m = Map::new();
    insert_nested(&mut m, parts, value);
    Value::Object(m)
}

pub(super) fn insert_nested(m: &mut Map<String, Value>, parts: &[&str], value: Value) {
    match parts {
        [] => {}
        [last] => {
            m.insert(last.to_string(), value);
        }
        [first, rest @ ..] => match m.get_mut(*first) {
            Some(Value::Object(inner)) => insert_nested(inner, rest, value),
            _ => {
                m.insert(first.to_string(), nested(rest, value));
            }
        },
    }
}

pub(super) fn lookup<'v>(v: &'v Value, key: &str) -> Option<&'v Value> {
    lookup_parts(v, &key.split('.').collect::<Vec<_>>())
}

pub(super) fn lookup_mut<'v>(v: &'v mut Value, key: &str) -> Option<&'v mut Value> {
    lookup_parts_mut(v, &key.split('.').collect::<Vec<_>>())
}

pub(super) fn lookup_parts<'v>(v: &'v Value, parts: &[&str]) -> Option<&'v Value> {
    parts.iter().try_fold(v, |v, p| v.as_object()?.get(*p))
}

pub(super) fn lookup_parts_mut<'v>(v: &'v mut Value, parts: &[&str]) -> Option<&'v mut Value> {
    parts.iter().try_fold(v, |v, p| v.as_object_mut()?.get_mut(*p))
}

/// The leaves of a settings file as (dotted key, value); an empty table is a leaf.
pub(super) fn flatten(v: &Value, prefix: String, out: &mut Vec<(String, Value)>) {
    match v {
        Value::Object(m) if !m.is_empty() => {
            for (k, v) in m {
                let key = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
                flatten(v, key, out);
            }
        }
        _ => out.push((prefix, v.clone())),
    }
}

/// Keys of `merged` that `round` (the deserialized settings, serialized again) lacks.
pub(super) fn dropped_keys(merged: &Value, round: &Value, prefix: &str, out: &mut Vec<String>) {
    if let (Value::Object(m), Value::Object(r)) = (merged, round) {
        for (k, v) in m {
            let key = format!("{prefix}.{k}");
            match r.get(k) {
                Some(rv) => dropped_keys(v, rv, &key, out),
                None => out.push(key),
            }
        }
    }
}
