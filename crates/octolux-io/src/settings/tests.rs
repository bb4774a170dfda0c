use super::*;
use serde_json::json;

fn input<'a>(integrator: &'a str, flags: Vec<FlagSetting>, sets: &'a [String]) -> SettingsInput<'a> {
    SettingsInput { integrator: Some(integrator), base: None, derived: vec![], file: None, flags, sets }
}

#[test]
fn keys_below_null_or_a_one_key_object_switch_it_and_others_do_not_exist() {
    let mut v = json!({ "a": { "relative": 0.5 }, "b": null, "c": { "x": 1, "y": 2 } });
    let mut created = HashSet::new();
    assert!(place(&mut v, &mut created, "a.absolute", json!(3)));
    assert!(place(&mut v, &mut created, "b.grid.columns", json!(8)));
    assert!(place(&mut v, &mut created, "b.grid.rows", json!(4)), "a switched value takes further keys");
    assert!(place(&mut v, &mut created, "c.x", json!(5)));
    assert!(!place(&mut v, &mut created, "c.z", json!(5)), "a struct has its fields only");
    assert!(!place(&mut v, &mut created, "d", json!(5)));
    assert!(!place(&mut v, &mut created, "c..x", json!(5)));
    assert_eq!(v, json!({ "a": { "absolute": 3 }, "b": { "grid": { "columns": 8, "rows": 4 } }, "c": { "x": 5, "y": 2 } }));
}

#[test]
fn python_spelling_names_the_dict_key_and_the_cli_keeps_its_own() {
    let sets = ["photons.bogus=true".to_string()];
    let err = |sp| resolve_spelt(&input("octree", vec![], &sets), sp).unwrap_err().to_string();
    let py = err(Spelling::Python);
    assert!(
        py.starts_with(
            r#"settings={"photons": {"bogus": True}}: no integrator has the setting `photons.bogus`; the keys of integrator='octree' are"#
        ),
        "{py}"
    );
    let cli = err(Spelling::Cli);
    assert!(
        cli.starts_with("--set photons.bogus=true: no integrator has the setting `photons.bogus`; the keys of --integrator octree are"),
        "{cli}"
    );
}

#[test]
fn flags_write_their_keys_and_set_wins() {
    let flag = |flag, keys: &[&str], value| FlagSetting {
        flag,
        only: None,
        keys: keys.iter().map(|k| k.to_string()).collect(),
        value,
        at_most: false,
    };
    let sets = vec!["global.h_max=3".to_string()];
    let r = resolve(&input("octree", vec![flag("--h-max", &["global.h_max", "caustic.h_max"], json!(7))], &sets)).unwrap();
    let v = serde_json::to_value(&r.settings).unwrap();
    assert_eq!((v["global"]["h_max"].clone(), v["caustic"]["h_max"].clone()), (json!(3), json!(7)));
    assert!(r.warnings.is_empty(), "{:?}", r.warnings);
    // the same flag for an integrator without those keys: a warning, nothing written
    let r = resolve(&input("path", vec![flag("--h-max", &["global.h_max", "caustic.h_max"], json!(7))], &[])).unwrap();
    assert_eq!(r.warnings, ["--h-max applies to --integrator octree only; ignored by --integrator path"]);
    assert_eq!(r.settings, IntegratorSettings::default_for("path").unwrap());
}

#[test]
fn at_most_only_lowers() {
    let lower = |v| FlagSetting { flag: "--x", only: None, keys: vec!["caustic.n_min".into()], value: json!(v), at_most: true };
    let n_min = |v| {
        let r = resolve(&input("octree", vec![lower(v)], &[])).unwrap();
        serde_json::to_value(&r.settings).unwrap()["caustic"]["n_min"].as_u64().unwrap()
    };
    let default = n_min(u32::MAX as u64);
    assert!(default > 3);
    assert_eq!(n_min(3), 3);
}
