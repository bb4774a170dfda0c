//! Bitmap textures as the files ask for them (`filter_type` nearest, bilinear, 0.6's
//! trilinear), and what the Bitterli collection says that Mitsuba ignores too (`gamma` of an
//! hdrfilm, a roughness on a smooth BSDF): a note, not a warning, while what octolux really
//! lacks stays a warning.

use octolux::image::Image;
use octolux::math::Color;
use octolux::scene::material::{Material, TexFilter, Texture};
use octolux_io::image_io::write_exr;
use octolux_io::mitsuba::load_str;
use std::path::{Path, PathBuf};

fn tmp_dir(test: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("mitsuba_textures").join(test);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Load `body` as a scene file in `dir` (with a sensor, so that no warning is about it).
fn load(dir: &Path, body: &str, version: &str) -> octolux_io::LoadedScene {
    let xml = format!("<scene version=\"{version}\">\n<sensor type=\"perspective\"/>\n{body}\n</scene>");
    load_str(&xml, &dir.join("scene.xml"), &[]).unwrap_or_else(|e| panic!("{e}"))
}

fn checker_file(dir: &Path) {
    let data = (0..16).map(|i| if (i % 4 + i / 4) % 2 == 0 { Color::ONE } else { Color::ZERO }).collect();
    write_exr(&dir.join("checker.exr"), &Image { width: 4, height: 4, data }).unwrap();
}

fn reflectance(m: &Material) -> &Texture {
    match m {
        Material::Diffuse { reflectance } => reflectance,
        other => panic!("{other:?}"),
    }
}

#[test]
fn filter_types_are_honoured_and_one_pyramid_is_built_per_image() {
    let dir = tmp_dir("filters");
    checker_file(&dir);
    let tex = |f: &str| {
        format!(
            r#"<bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="checker.exr"/>{f}</texture></bsdf>"#
        )
    };
    let body = [
        tex(""),
        tex(r#"<string name="filter_type" value="nearest"/>"#),
        tex(r#"<string name="filter_type" value="trilinear"/>"#),
        tex(r#"<string name="filter_type" value="trilinear"/>"#),
    ]
    .join("\n");
    let s = load(&dir, &body, "3.0.0");
    assert!(s.warnings.is_empty() && s.notes.is_empty(), "{:?} {:?}", s.warnings, s.notes);
    let m = &s.desc.materials;
    assert!(matches!(reflectance(&m[0]), Texture::Bitmap { image: 0, filter: TexFilter::Bilinear, .. }), "{:?}", m[0]);
    assert!(matches!(reflectance(&m[1]), Texture::Bitmap { image: 0, filter: TexFilter::Nearest, .. }), "{:?}", m[1]);
    // 4x4 → 2x2 → 1x1: two levels after the base, built once for both materials.
    let tri = TexFilter::Trilinear { first: 1, count: 2 };
    assert!(matches!(reflectance(&m[2]), Texture::Bitmap { image: 0, filter, .. } if *filter == tri), "{:?}", m[2]);
    assert_eq!(reflectance(&m[2]), reflectance(&m[3]));
    assert_eq!(s.desc.images.len(), 3);
    assert_eq!((s.desc.images[2].width, s.desc.images[2].height), (1, 1));
    assert!((s.desc.images[2].data[0] - Color::splat(0.5)).abs().max_element() < 1e-6);

    // The 0.6 spelling (filterType) of the Bitterli scenes loads without a warning.
    let s = load(
        &dir,
        r#"<bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="checker.exr"/><string name="filterType" value="trilinear"/></texture></bsdf>"#,
        "0.6.0",
    );
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert!(matches!(reflectance(&s.desc.materials[0]), Texture::Bitmap { filter: TexFilter::Trilinear { .. }, .. }));

    // 0.6's ewa: the nearest supported (trilinear), said; an unknown name: bilinear, said.
    let s = load(
        &dir,
        &[tex(r#"<string name="filter_type" value="ewa"/>"#), tex(r#"<string name="filter_type" value="cubic"/>"#)].join("\n"),
        "3.0.0",
    );
    assert_eq!(s.warnings.len(), 2, "{:?}", s.warnings);
    assert!(s.warnings[0].contains("filter_type \"ewa\" is not supported; using trilinear"), "{}", s.warnings[0]);
    assert!(s.warnings[1].contains("filter_type \"cubic\" is not supported; using bilinear"), "{}", s.warnings[1]);
    assert!(matches!(reflectance(&s.desc.materials[0]), Texture::Bitmap { filter: TexFilter::Trilinear { .. }, .. }));
}

#[test]
fn what_mitsuba_ignores_too_is_a_note_and_what_octolux_lacks_a_warning() {
    let dir = tmp_dir("notes");
    let body = r#"<bsdf type="conductor" id="metal"><string name="material" value="Al"/><float name="alpha" value="0.1"/></bsdf>
<bsdf type="dielectric" id="glass"><float name="intIOR" value="1.5"/><float name="extIOR" value="1.0"/><float name="alpha" value="0.05"/></bsdf>
<bsdf type="roughconductor" id="rough"><float name="alpha" value="0.1"/><float name="nosuch" value="1"/></bsdf>"#;
    let s = load(&dir, body, "0.6.0");
    assert_eq!(s.notes.len(), 2, "{:?}", s.notes);
    let file = dir.join("scene.xml");
    assert_eq!(
        s.notes[0],
        format!("{}:4: `alpha` is not a parameter of Mitsuba's smooth conductor (Mitsuba ignores it too); ignored", file.display())
    );
    assert!(
        s.notes[1].starts_with(&format!("{}:5: `alpha`", file.display())) && s.notes[1].contains("smooth dielectric"),
        "{}",
        s.notes[1]
    );
    // roughconductor reads its alpha; a parameter that exists nowhere stays a warning.
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(
        s.warnings[0].contains("parameter \"nosuch\"") && s.warnings[0].contains("is not supported and was ignored"),
        "{}",
        s.warnings[0]
    );

    // hdrfilm: gamma is a note (0.6's hdrfilm has none), highQualityEdges false is what octolux
    // does (silent), true is a warning.
    let film = |extra: &str| {
        format!(
            r#"<sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>{extra}</film></sensor>"#
        )
    };
    let xml = format!(
        "<scene version=\"0.6.0\">\n{}\n</scene>",
        film(r#"<float name="gamma" value="2.2"/><boolean name="highQualityEdges" value="false"/>"#)
    );
    let s = load_str(&xml, &file, &[]).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!(
        s.notes,
        [format!("{}:2: `gamma` is not a parameter of Mitsuba's hdrfilm (Mitsuba ignores it too); ignored", file.display())]
    );
    let xml = format!("<scene version=\"0.6.0\">\n{}\n</scene>", film(r#"<boolean name="highQualityEdges" value="true"/>"#));
    let s = load_str(&xml, &file, &[]).unwrap();
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(s.warnings[0].contains("high_quality_edges = true") && s.warnings[0].contains("not supported"), "{}", s.warnings[0]);
    // An ldrfilm's gamma is not claimed to be ignored by Mitsuba.
    let xml = "<scene version=\"0.6.0\">\n<sensor type=\"perspective\"><film type=\"ldrfilm\"><float name=\"gamma\" value=\"2.2\"/></film></sensor>\n</scene>";
    let s = load_str(xml, &file, &[]).unwrap();
    assert!(s.notes.is_empty(), "{:?}", s.notes);
}
