//! Bitmap textures as the files ask for them (`filter_type` nearest, bilinear, 0.6's
//! trilinear), and what the Bitterli collection says that Mitsuba ignores too (`gamma` of an
//! hdrfilm, a roughness on a smooth BSDF): a note, not a warning, while what octolux really
//! lacks stays a warning.

use octolux::image::Image;
use octolux::math::Color;
use octolux::scene::material::{Material, Microfacet, MicrofacetKind, TexFilter, Texture};
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
        format!("{}:3: `alpha` is not a parameter of Mitsuba's smooth conductor (Mitsuba ignores it too); ignored", file.display())
    );
    assert!(
        s.notes[1].starts_with(&format!("{}:4: `alpha`", file.display())) && s.notes[1].contains("smooth dielectric"),
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
    // does by default (silent).
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
    assert!(!s.desc.film.sample_border);
    // highQualityEdges true (Mitsuba 3's sample_border) is honoured: the band outside the film
    // is sampled too (octolux::render).
    for (version, param) in [("0.6.0", "highQualityEdges"), ("3.0.0", "sample_border")] {
        let xml = format!("<scene version=\"{version}\">\n{}\n</scene>", film(&format!(r#"<boolean name="{param}" value="true"/>"#)));
        let s = load_str(&xml, &file, &[]).unwrap();
        assert!(s.warnings.is_empty(), "{:?}", s.warnings);
        assert!(s.desc.film.sample_border, "{param}");
    }
    // An ldrfilm's gamma is not claimed to be ignored by Mitsuba.
    let xml = "<scene version=\"0.6.0\">\n<sensor type=\"perspective\"><film type=\"ldrfilm\"><float name=\"gamma\" value=\"2.2\"/></film></sensor>\n</scene>";
    let s = load_str(xml, &file, &[]).unwrap();
    assert!(s.notes.is_empty(), "{:?}", s.notes);
}

#[test]
fn roughness_textures_load_for_roughconductor_and_roughdielectric() {
    let dir = tmp_dir("roughness");
    let data = vec![Color::splat(0.1), Color::splat(0.3), Color::splat(0.5), Color::splat(0.7)];
    write_exr(&dir.join("alpha.exr"), &Image { width: 2, height: 2, data }).unwrap();
    let bitmap = |name: &str| format!(r#"<texture type="bitmap" name="{name}"><string name="filename" value="alpha.exr"/></texture>"#);
    let body = format!(
        r#"<bsdf type="roughconductor"><string name="distribution" value="ggx"/>{}</bsdf>
<bsdf type="roughdielectric">{}<float name="alpha_v" value="0.2"/></bsdf>
<bsdf type="roughconductor"><float name="alpha" value="0.2"/></bsdf>
<bsdf type="roughdielectric"><texture type="bitmap" name="alpha"><string name="filename" value="alpha.exr"/><string name="filter_type" value="trilinear"/></texture></bsdf>"#,
        bitmap("alpha"),
        bitmap("alpha_u"),
    );
    let s = load(&dir, &body, "3.0.0");
    assert!(s.warnings.is_empty() && s.notes.is_empty(), "{:?} {:?}", s.warnings, s.notes);
    let m = &s.desc.materials;
    let Material::RoughConductor { distribution: r, .. } = &m[0] else { panic!("{:?}", m[0]) };
    assert_eq!(r.kind, MicrofacetKind::Ggx);
    assert!(matches!(r.alpha_u, Texture::Bitmap { image: 0, .. }) && r.alpha_u == r.alpha_v, "{r:?}");
    assert!(r.constant().is_none());
    // The alpha at a texel centre is that texel's value (EXR: linear, no decoding).
    let at = r.at(&s.desc.images, glam::Vec2::new(0.75, 0.25).into());
    assert!((at.alpha_u - 0.3).abs() < 1e-6, "{at:?}");
    let Material::RoughDielectric { distribution: r, .. } = &m[1] else { panic!("{:?}", m[1]) };
    assert_eq!(r.kind, MicrofacetKind::Beckmann, "Mitsuba's default distribution");
    assert!(matches!(r.alpha_u, Texture::Bitmap { .. }) && r.alpha_v == Texture::Const(Color::splat(0.2)), "{r:?}");
    let Material::RoughConductor { distribution: r, .. } = &m[2] else { panic!("{:?}", m[2]) };
    assert_eq!(*r, Microfacet::isotropic(MicrofacetKind::Beckmann, 0.2), "a number stays a constant distribution");
    let Material::RoughDielectric { distribution: r, .. } = &m[3] else { panic!("{:?}", m[3]) };
    assert!(matches!(r.alpha_u, Texture::Bitmap { filter: TexFilter::Trilinear { .. }, .. }), "{r:?}");
    // alpha together with alpha_u is refused, naming the file.
    let xml = format!(
        "<scene version=\"3.0.0\">\n<bsdf type=\"roughconductor\">{}<float name=\"alpha_u\" value=\"0.1\"/></bsdf>\n</scene>",
        bitmap("alpha")
    );
    let e = load_str(&xml, &dir.join("bad.xml"), &[]).unwrap_err().to_string();
    assert!(e.contains("bad.xml:2") && e.contains("give either alpha or both alpha_u and alpha_v"), "{e}");
}

#[test]
fn raw_bitmaps_keep_their_stored_values() {
    let dir = tmp_dir("raw");
    // One 8-bit texel: sRGB code 128 (linear 0.2158).
    let linear = octolux_io::image_io::srgb_to_linear(128.0 / 255.0);
    octolux_io::image_io::write_png(&dir.join("grey.png"), &Image { width: 1, height: 1, data: vec![Color::splat(linear)] }).unwrap();
    let tex = |raw: &str| {
        format!(
            r#"<bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="grey.png"/>{raw}</texture></bsdf>"#
        )
    };
    let body = [tex(""), tex(r#"<boolean name="raw" value="true"/>"#), tex(r#"<boolean name="raw" value="false"/>"#)].join("\n");
    let s = load(&dir, &body, "3.0.0");
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let value = |i: usize| reflectance(&s.desc.materials[i]).eval(&s.desc.images, glam::Vec2::splat(0.5)).x;
    assert!((value(0) - linear).abs() < 1e-6, "decoded from sRGB: {}", value(0));
    assert!((value(1) - 128.0 / 255.0).abs() < 1e-6, "raw: the stored value, {}", value(1));
    assert_eq!(value(2), value(0));
    assert_eq!(s.desc.images.len(), 2, "one image per (file, raw)");
}

/// Mitsuba 3.9.1 refuses a scene whose scene-level bitmap texture names a missing file, used
/// or not ("At scene.xml (line 2, col 4): failed to instantiate texture plugin of type
/// \"bitmap\": ... No such file or directory"); so does octolux, naming file and line, while an
/// unused texture whose file exists loads without reading it into the scene.
#[test]
fn an_unused_bitmap_with_a_missing_file_is_refused_like_mitsuba() {
    let dir = tmp_dir("unused");
    checker_file(&dir);
    let body = "<texture type=\"bitmap\" id=\"unused\">\n  <string name=\"filename\" value=\"missing.png\"/>\n</texture>\n\
                <shape type=\"sphere\"/>";
    let xml = format!("<scene version=\"3.0.0\">\n<sensor type=\"perspective\"/>\n{body}\n</scene>");
    let e = load_str(&xml, &dir.join("scene.xml"), &[]).err().unwrap_or_else(|| panic!("accepted")).to_string();
    assert!(e.contains("scene.xml:3") && e.contains("image file \"missing.png\" not found"), "{e}");
    let s = load(&dir, "<texture type=\"bitmap\" id=\"unused\">\n  <string name=\"filename\" value=\"checker.exr\"/>\n</texture>\n<shape type=\"sphere\"/>", "3.0.0");
    assert!(s.desc.images.is_empty(), "an unused texture's image is not loaded");
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

/// Mitsuba 0.6's bitmap `gamma` overrides the file's encoding: 1 is linear (bump maps and other
/// data use it), -1 sRGB, another value a power law. A height map stored linearly with gamma 1
/// and the same heights stored sRGB-encoded (gamma -1, or the 8-bit default) decode to the same
/// heights, to within 8-bit quantization, and so give the same bump map.
#[test]
fn bitmap_gamma_decodes_a_linear_bump_map_like_an_srgb_one() {
    use octolux_io::image_io::{linear_to_srgb, srgb_to_linear, write_png};
    let dir = tmp_dir("gamma");
    let (w, h) = (16u32, 8u32);
    let height = |x: u32, y: u32| 0.5 + 0.3 * ((x as f32 * 0.7).sin() * (y as f32 * 0.9).cos());
    // `write_png` encodes linear values to sRGB bytes: give it what makes the wanted bytes
    let png = |name: &str, byte: &dyn Fn(f32) -> f32| {
        let data =
            (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).map(|(x, y)| Color::splat(srgb_to_linear(byte(height(x, y))))).collect();
        write_png(&dir.join(name), &Image { width: w, height: h, data }).unwrap();
    };
    png("linear.png", &|v| (v * 255.0).round() / 255.0); // the heights themselves as bytes
    png("srgb.png", &|v| (linear_to_srgb(v) * 255.0).round() / 255.0); // sRGB-encoded heights
    let bump = |file: &str, gamma: &str| {
        format!(
            r#"<bsdf type="bumpmap"><texture type="bitmap"><string name="filename" value="{file}"/>{gamma}</texture><float name="scale" value="0.1"/><bsdf type="diffuse"/></bsdf>"#
        )
    };
    let body = [
        bump("linear.png", r#"<float name="gamma" value="1"/>"#),
        bump("srgb.png", r#"<float name="gamma" value="-1"/>"#),
        bump("srgb.png", ""),
        bump("linear.png", ""),
        bump("linear.png", r#"<float name="gamma" value="2.2"/>"#),
    ]
    .join("\n");
    let s = load(&dir, &body, "0.6.0");
    assert!(s.warnings.is_empty() && s.notes.is_empty(), "{:?} {:?}", s.warnings, s.notes);
    let image = |i: usize| match &s.desc.materials[i] {
        Material::BumpMap { height: Texture::Bitmap { image, .. }, .. } => &s.desc.images[*image as usize],
        other => panic!("{other:?}"),
    };
    let (linear, srgb, default, misread, power) = (image(0), image(1), image(2), image(3), image(4));
    assert_eq!(srgb.data, default.data, "gamma -1 is what an 8-bit file gets by default");
    for (i, (a, b)) in linear.data.iter().zip(&srgb.data).enumerate() {
        let want = height(i as u32 % w, i as u32 / w);
        assert!((a.x - want).abs() <= 0.5 / 255.0 + 1e-6, "texel {i}: linear map {} vs height {want}", a.x);
        // sRGB codes are at most about 1/255 x 1.6 apart in linear terms above 0.2
        assert!((b.x - want).abs() <= 1.0 / 255.0, "texel {i}: sRGB map {} vs height {want}", b.x);
    }
    // read as sRGB (no gamma), the linear file's heights come out darker and wrong
    let worst = linear.data.iter().zip(&misread.data).map(|(a, b)| (a.x - b.x).abs()).fold(0.0f32, f32::max);
    assert!(worst > 0.15, "a linear map misread as sRGB differs by {worst}");
    for (a, p) in linear.data.iter().zip(&power.data) {
        assert!((p.x - a.x.powf(2.2)).abs() < 1e-5, "power law: {} vs {}", p.x, a.x.powf(2.2));
    }
    // a gamma that is no encoding, and raw contradicting gamma, are refused naming the line
    for (extra, what) in [
        (r#"<float name="gamma" value="-2"/>"#, "gamma -2 must be 1 (linear), -1 (sRGB) or another positive exponent"),
        (r#"<float name="gamma" value="0"/>"#, "gamma 0 must be"),
        (r#"<float name="gamma" value="-1"/><boolean name="raw" value="true"/>"#, "raw and gamma -1 disagree"),
    ] {
        let xml = format!("<scene version=\"0.6.0\">\n<sensor type=\"perspective\"/>\n{}\n</scene>", bump("linear.png", extra));
        let e = load_str(&xml, &dir.join("bad.xml"), &[]).err().unwrap_or_else(|| panic!("accepted {extra}")).to_string();
        assert!(e.contains("bad.xml:3") && e.contains(what), "{e}");
    }
}
