//! Mitsuba bsdf plugins mapped onto octolux materials with Mitsuba's meaning: microfacet
//! distributions (Beckmann by default), `roughdielectric`, smooth and `nonlinear` plastics,
//! Mitsuba 0.6's `ward` and `phong` (camelCase names, energy conservation), `extEta`; nothing
//! the file asks for is replaced silently.

use octolux::math::Color;
use octolux::scene::material::{Material, Microfacet, MicrofacetKind, Texture, WardVariant};
use octolux_io::mitsuba::load_str;
use std::path::Path;

fn load(body: &str, version: &str) -> octolux_io::LoadedScene {
    let xml = format!("<scene version=\"{version}\">\n{body}\n</scene>");
    let mut s = load_str(&xml, Path::new("/virtual/bsdfs.xml"), &[]).unwrap_or_else(|e| panic!("{e}"));
    // these scenes hold bsdfs only: drop the note about the missing sensor
    s.warnings.retain(|w| !w.contains("no usable sensor"));
    s
}

#[test]
fn microfacet_bsdfs_keep_their_distribution() {
    let s = load(
        r#"<bsdf type="roughconductor"><float name="alpha" value="0.2"/></bsdf>
<bsdf type="roughconductor"><string name="distribution" value="ggx"/><float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.3"/></bsdf>
<bsdf type="roughdielectric"><string name="distribution" value="beckmann"/><float name="alpha" value="0.25"/><float name="int_ior" value="1.5"/></bsdf>
<bsdf type="roughplastic"><string name="distribution" value="beckmann"/><float name="alpha" value="0.3"/><boolean name="nonlinear" value="true"/></bsdf>
<bsdf type="plastic"><float name="int_ior" value="1.6"/><rgb name="diffuse_reflectance" value="0.2 0.4 0.6"/></bsdf>"#,
        "3.0.0",
    );
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let m = &s.desc.materials;
    assert!(
        matches!(&m[0], Material::RoughConductor { distribution, .. }
        if *distribution == Microfacet::isotropic(MicrofacetKind::Beckmann, 0.2)),
        "Mitsuba's default is beckmann: {:?}",
        m[0]
    );
    assert!(
        matches!(&m[1], Material::RoughConductor { distribution, .. }
        if *distribution == Microfacet { kind: MicrofacetKind::Ggx, alpha_u: 0.1, alpha_v: 0.3 }),
        "{:?}",
        m[1]
    );
    match &m[2] {
        Material::RoughDielectric { distribution, eta, .. } => {
            assert_eq!(*distribution, Microfacet::isotropic(MicrofacetKind::Beckmann, 0.25));
            assert!((eta - 1.5 / 1.000277).abs() < 1e-6);
        }
        other => panic!("{other:?}"),
    }
    assert!(
        matches!(&m[3], Material::RoughPlastic { distribution, nonlinear: true, .. }
        if distribution.kind == MicrofacetKind::Beckmann),
        "{:?}",
        m[3]
    );
    assert!(
        matches!(&m[4], Material::Plastic { nonlinear: false, diffuse_reflectance: Texture::Const(c), .. }
        if *c == Color::new(0.2, 0.4, 0.6)),
        "{:?}",
        m[4]
    );
}

#[test]
fn mitsuba_06_ward_and_phong() {
    // veach-lamp's and sponza's definitions, plus the 0.6 defaults and energy conservation
    let s = load(
        r#"<bsdf type="ward" id="lamp">
    <spectrum name="diffuseReflectance" value="0"/>
    <rgb name="specularReflectance" value="0.61600 0.47520 0.35200"/>
    <float name="alpha" value="0.4"/>
</bsdf>
<bsdf type="ward"><string name="variant" value="ward-duer"/><float name="alphaU" value="0.1"/><float name="alphaV" value="0.3"/></bsdf>
<bsdf type="phong" id="sp_00_svod">
    <rgb name="diffuseReflectance" value="0.941177 0.866667 0.737255"/>
    <rgb name="specularReflectance" value="0.034039 0.032314 0.029333"/>
    <float name="exponent" value="1.07177"/>
</bsdf>
<bsdf type="phong"><rgb name="diffuseReflectance" value="0.9"/><rgb name="specularReflectance" value="0.3"/></bsdf>"#,
        "0.6.0",
    );
    let m = &s.desc.materials;
    assert_eq!(
        m[0],
        Material::Ward {
            variant: WardVariant::Balanced,
            alpha_u: 0.4,
            alpha_v: 0.4,
            diffuse_reflectance: Texture::Const(Color::ZERO),
            specular_reflectance: Texture::Const(Color::new(0.616, 0.4752, 0.352)),
        }
    );
    assert_eq!(
        m[1],
        Material::Ward {
            variant: WardVariant::WardDuer,
            alpha_u: 0.1,
            alpha_v: 0.3,
            diffuse_reflectance: Texture::Const(Color::splat(0.5)),
            specular_reflectance: Texture::Const(Color::splat(0.2)),
        },
        "0.6 defaults: diffuse 0.5, specular 0.2"
    );
    assert!(matches!(&m[2], Material::Phong { exponent, .. } if *exponent == 1.07177));
    // 0.9 + 0.3 > 1: both scaled by 0.99 / 1.2, with a warning saying so
    let scale = 0.99 / 1.2;
    match &m[3] {
        Material::Phong { exponent, diffuse_reflectance: Texture::Const(kd), specular_reflectance: Texture::Const(ks) } => {
            assert_eq!(*exponent, 30.0, "0.6's default exponent");
            assert!(
                (*kd - Color::splat(0.9 * scale)).abs().max_element() < 1e-6
                    && (*ks - Color::splat(0.3 * scale)).abs().max_element() < 1e-6
            );
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(s.warnings[0].contains("scaled by") && s.warnings[0].contains("ensureEnergyConservation"), "{:?}", s.warnings);
    // ... unless the file turns it off
    let s = load(
        r#"<bsdf type="phong"><rgb name="diffuseReflectance" value="0.9"/><rgb name="specularReflectance" value="0.3"/><boolean name="ensureEnergyConservation" value="false"/></bsdf>"#,
        "0.6.0",
    );
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert!(matches!(&s.desc.materials[0], Material::Phong { diffuse_reflectance: Texture::Const(kd), .. } if *kd == Color::splat(0.9)));
}

#[test]
fn conductor_ext_eta_and_what_is_not_supported() {
    let s = load(
        r#"<bsdf type="conductor"><float name="extEta" value="1.33"/><rgb name="eta" value="1.33 2.66 1.33"/><rgb name="k" value="2.66"/></bsdf>
<bsdf type="roughconductor"><boolean name="sample_visible" value="false"/></bsdf>"#,
        "0.6.0",
    );
    assert!(matches!(&s.desc.materials[0], Material::Conductor { eta, k, .. }
        if (*eta - Color::new(1.0, 2.0, 1.0)).abs().max_element() < 1e-6 && (*k - Color::splat(2.0)).abs().max_element() < 1e-6));
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert!(s.warnings[0].contains("sample_visible"), "{:?}", s.warnings);
    // errors name the file and line
    let xml = "<scene version=\"3.0.0\">\n<bsdf type=\"roughconductor\"><string name=\"distribution\" value=\"blinn\"/></bsdf>\n</scene>";
    let err = load_str(xml, Path::new("/virtual/bad.xml"), &[]).unwrap_err().to_string();
    assert!(err.starts_with("/virtual/bad.xml:2") && err.contains("blinn"), "{err}");
    let xml = "<scene version=\"3.0.0\">\n<bsdf type=\"roughplastic\"><float name=\"alpha_u\" value=\"0.1\"/><float name=\"alpha_v\" value=\"0.2\"/></bsdf>\n</scene>";
    let err = load_str(xml, Path::new("/virtual/bad.xml"), &[]).unwrap_err().to_string();
    assert!(err.contains("anisotropic"), "{err}");
    let xml = "<scene version=\"0.6.0\">\n<bsdf type=\"ward\"><string name=\"variant\" value=\"cook\"/></bsdf>\n</scene>";
    let err = load_str(xml, Path::new("/virtual/bad.xml"), &[]).unwrap_err().to_string();
    assert!(err.contains("cook"), "{err}");
}

#[test]
fn blendbsdf_blends_its_two_nested_bsdfs() {
    let s = load(
        r#"<bsdf type="blendbsdf"><float name="weight" value="0.25"/>
    <bsdf type="diffuse"/>
    <bsdf type="roughconductor"><string name="distribution" value="ggx"/></bsdf>
</bsdf>"#,
        "3.0.0",
    );
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    match &s.desc.materials[0] {
        Material::Blend { weight: Texture::Const(w), first, second } => {
            assert_eq!(*w, Color::splat(0.25));
            assert!(matches!(**first, Material::Diffuse { .. }) && matches!(**second, Material::RoughConductor { .. }));
        }
        other => panic!("{other:?}"),
    }
    let xml = "<scene version=\"3.0.0\">\n<bsdf type=\"blendbsdf\"><bsdf type=\"diffuse\"/><bsdf type=\"diffuse\"/></bsdf>\n</scene>";
    let err = load_str(xml, Path::new("/virtual/bad.xml"), &[]).unwrap_err().to_string();
    assert!(err.starts_with("/virtual/bad.xml:2") && err.contains("weight"), "{err}");
}

#[test]
fn mask_bumpmap_and_normalmap_wrap_their_nested_bsdf() {
    let maps = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/scenes/wrappers");
    let (height, normals) = (maps.join("height.hdr"), maps.join("normals.hdr"));
    // Mitsuba 3: a float opacity, a bump map texture of any name, a normal map.
    let s = load(
        &format!(
            r#"<bsdf type="mask"><float name="opacity" value="0.3"/><bsdf type="diffuse"/></bsdf>
<bsdf type="bumpmap"><texture type="bitmap" name="arbitrary"><string name="filename" value="{}"/><boolean name="raw" value="true"/></texture>
    <float name="scale" value="0.5"/><bsdf type="roughplastic"/></bsdf>
<bsdf type="normalmap"><texture type="bitmap" name="normalmap"><string name="filename" value="{}"/></texture><bsdf type="diffuse"/></bsdf>
<bsdf type="mask"><bsdf type="twosided"><bsdf type="diffuse"/></bsdf></bsdf>"#,
            height.display(),
            normals.display()
        ),
        "3.0.0",
    );
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let m = &s.desc.materials;
    assert!(
        matches!(&m[0], Material::Mask { opacity: Texture::Const(o), nested } if *o == Color::splat(0.3) && matches!(**nested, Material::Diffuse { .. })),
        "{:?}",
        m[0]
    );
    assert!(
        matches!(&m[1], Material::BumpMap { height: Texture::Bitmap { .. }, scale, nested } if *scale == 0.5 && matches!(**nested, Material::RoughPlastic { .. })),
        "{:?}",
        m[1]
    );
    assert!(matches!(&m[2], Material::NormalMap { normals: Texture::Bitmap { .. }, .. }), "{:?}", m[2]);
    assert!(
        matches!(&m[3], Material::Mask { opacity: Texture::Const(o), nested } if *o == Color::splat(0.5) && matches!(**nested, Material::TwoSided { .. })),
        "Mitsuba's default opacity is 0.5: {:?}",
        m[3]
    );
    // Mitsuba 0.6: an opacity spectrum, a nested texture and `scale` for the bump map.
    let s = load(
        &format!(
            r#"<bsdf type="mask"><spectrum name="opacity" value="0.25"/><bsdf type="diffuse"/></bsdf>
<bsdf type="bumpmap"><texture type="bitmap"><string name="filename" value="{}"/></texture><float name="scale" value="2"/><bsdf type="diffuse"/></bsdf>"#,
            height.display()
        ),
        "0.6.0",
    );
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert!(matches!(&s.desc.materials[0], Material::Mask { opacity: Texture::Const(o), .. } if *o == Color::splat(0.25)));
    assert!(matches!(&s.desc.materials[1], Material::BumpMap { scale, .. } if *scale == 2.0));
    // A bump map under twosided is evaluated unperturbed, and says so.
    let s = load(
        r#"<bsdf type="twosided"><bsdf type="normalmap"><rgb name="normalmap" value="0.5 0.5 1"/><bsdf type="diffuse"/></bsdf></bsdf>"#,
        "3.0.0",
    );
    assert!(s.warnings.len() == 1 && s.warnings[0].contains("unperturbed"), "{:?}", s.warnings);
    // Wrong structure: an error naming the file and line.
    for (body, what) in [
        (r#"<bsdf type="mask"><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf>"#, "one nested bsdf"),
        (r#"<bsdf type="bumpmap"><bsdf type="diffuse"/></bsdf>"#, "nested texture"),
        (r#"<bsdf type="normalmap"><bsdf type="diffuse"/></bsdf>"#, "normalmap"),
    ] {
        let xml = format!("<scene version=\"3.0.0\">\n{body}\n</scene>");
        let err = load_str(&xml, Path::new("/virtual/bad.xml"), &[]).unwrap_err().to_string();
        assert!(err.starts_with("/virtual/bad.xml:2") && err.contains(what), "{err}");
    }
}

#[test]
fn bump_map_gradient_matches_mitsuba_on_the_test_map() {
    // Mitsuba 3.9.1 (llvm_ad_rgb), bitmap texture of tests/scenes/wrappers/height.hdr:
    // eval_1 and eval_1_grad at two uvs, printed by its Python bindings.
    let maps = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/scenes/wrappers");
    let img = octolux_io::image_io::read_image(&maps.join("height.hdr")).unwrap();
    let images = vec![img];
    let t = Texture::bitmap(0, glam::Vec2::ONE);
    for (uv, value, grad) in [((0.3, 0.4), 0.223994, (4.27187, 2.77813)), ((0.71, 0.2), 0.656719, (2.625, -3.125))] {
        let uv = glam::Vec2::new(uv.0, uv.1);
        let v = octolux::math::luminance(t.eval(&images, uv));
        let g = octolux::scene::material::bump::luminance_gradient(&t, &images, uv);
        assert!((v - value).abs() < 1e-4, "value at {uv}: {v} vs Mitsuba {value}");
        assert!((g.x - grad.0).abs() < 1e-3 && (g.y - grad.1).abs() < 1e-3, "gradient at {uv}: {g} vs Mitsuba {grad:?}");
    }
}
