//! The settings reference (`octolux_io::settings::reference`): every key of every integrator's
//! defaults is listed once with a doc, every listed enum value is one the settings accept, and
//! docs/guide/settings.md is the generated page (this test fails when it is stale).

use octolux::integrators::IntegratorSettings;
use octolux_io::settings::reference::{keys, markdown};
use octolux_io::settings::{resolve, SettingsInput};
use serde_json::Value;

/// The dotted leaf keys of a settings value (objects opened all the way down).
fn leaves(v: &Value, prefix: &str, out: &mut Vec<String>) {
    match v {
        Value::Object(m) if !m.is_empty() => {
            for (k, v) in m {
                leaves(v, &if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") }, out);
            }
        }
        _ => out.push(prefix.to_string()),
    }
}

#[test]
fn every_key_is_listed_once_with_a_doc() {
    for &name in IntegratorSettings::NAMES {
        let listed = keys(name).expect(name);
        let defaults = serde_json::to_value(IntegratorSettings::default_for(name).unwrap()).unwrap();
        let mut all = Vec::new();
        leaves(&defaults, "", &mut all);
        all.retain(|k| k != "type");
        // each default leaf lies under exactly one listed key (an enum with data is one key)
        for leaf in &all {
            let under: Vec<&str> =
                listed.iter().map(|k| k.key.as_str()).filter(|k| leaf == k || leaf.starts_with(&format!("{k}."))).collect();
            assert_eq!(under.len(), 1, "{name}: {leaf} is under {under:?}");
        }
        for k in &listed {
            assert!(!k.doc.is_empty(), "{name}: {} has no doc", k.key);
            assert!(!k.ty.is_empty() && !k.ty.contains("Option<"), "{name}: {} has type {}", k.key, k.ty);
            assert_eq!(Some(&k.default), pointer(&defaults, &k.key), "{name}: {}", k.key);
        }
    }
}

fn pointer<'a>(v: &'a Value, key: &str) -> Option<&'a Value> {
    v.pointer(&format!("/{}", key.replace('.', "/")))
}

#[test]
fn every_listed_enum_value_is_accepted_by_the_settings() {
    let mut tried = 0;
    for &name in IntegratorSettings::NAMES {
        for k in keys(name).unwrap() {
            // values of unit variants: the ones a plain string names
            if !k.default.is_string() {
                continue;
            }
            for (value, _) in &k.values {
                let set = vec![format!("{}={value}", k.key)];
                let r =
                    resolve(&SettingsInput { integrator: Some(name), base: None, derived: vec![], file: None, flags: vec![], sets: &set });
                if let Err(e) = &r {
                    // a combination a validator refuses is fine; an unknown name is not
                    assert!(!e.to_string().contains("unknown variant"), "{name}: {set:?}: {e}");
                }
                let r = resolve(&SettingsInput {
                    integrator: Some(name),
                    base: None,
                    derived: vec![],
                    file: None,
                    flags: vec![],
                    sets: &[format!("{}={}", k.key, value.replace('_', "-"))],
                });
                if let Err(e) = &r {
                    assert!(!e.to_string().contains("unknown variant"), "{name}: the `-` spelling of {value}: {e}");
                }
                tried += 1;
            }
        }
    }
    assert!(tried > 30, "only {tried} enum values were tried");
}

#[test]
fn the_settings_page_is_the_generated_one() {
    let page = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/guide/settings.md");
    let text = std::fs::read_to_string(&page).unwrap_or_default();
    assert!(
        text == markdown(),
        "docs/guide/settings.md is stale: regenerate it with `cargo run -p octolux-cli -- settings --markdown > docs/guide/settings.md`"
    );
}
