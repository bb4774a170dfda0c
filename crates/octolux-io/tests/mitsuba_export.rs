//! Export to Mitsuba 3 XML, then load the file back with the Mitsuba loader: the scene
//! description must come back the same (within float tolerance), with no warning.

use glam::{Mat4, Vec2, Vec3};
use octolux::image::Image;
use octolux::math::{Color, Frame};
use octolux::scene::camera::{look_at, CameraDesc, FovAxis};
use octolux::scene::material::{Material, Microfacet, MicrofacetKind, Texture};
use octolux::scene::Light;
use octolux::scene::{FilmDesc, Geometry, PixelFilter, SceneDesc, ShapeDesc, TriMesh};
use octolux_io::export::{to_mitsuba_xml, write_mitsuba_scene};
use octolux_io::mitsuba::load;
use std::path::PathBuf;

/// A fresh temporary folder for one test.
fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("octolux-export-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn image(w: u32, h: u32, seed: f32) -> Image {
    let data = (0..w * h).map(|i| Color::new(i as f32 * 0.1 + seed, 0.5 - seed, (i % 3) as f32 * 0.25)).collect();
    Image { width: w, height: h, data }
}

fn scene() -> SceneDesc {
    let images = vec![image(3, 2, 0.0), image(2, 2, 0.3)];
    let materials = vec![
        Material::Diffuse { reflectance: Texture::Const(Color::new(0.7, 0.2, 0.1)) },
        Material::Diffuse { reflectance: Texture::bitmap(1, Vec2::new(2.0, 3.5)) },
        Material::Conductor {
            eta: Color::new(0.143036, 0.375307, 1.442045),
            k: Color::new(3.982997, 2.385556, 1.603359),
            specular_reflectance: Color::ONE,
        },
        Material::Conductor { eta: Color::ZERO, k: Color::ZERO, specular_reflectance: Color::splat(0.8) },
        Material::RoughConductor {
            distribution: Microfacet { kind: MicrofacetKind::Beckmann, alpha_u: 0.2, alpha_v: 0.35 }.into(),
            eta: Color::new(0.2, 0.9, 1.1),
            k: Color::new(3.9, 2.4, 2.1),
            specular_reflectance: Color::new(1.0, 0.9, 0.8),
        },
        Material::Dielectric { eta: 1.5046, specular_reflectance: Color::ONE, specular_transmittance: Color::new(0.9, 1.0, 0.95) },
        Material::ThinDielectric { eta: 1.333, specular_reflectance: Color::splat(0.5), specular_transmittance: Color::ONE },
        Material::RoughPlastic {
            diffuse_reflectance: Texture::bitmap(0, Vec2::ONE),
            specular_reflectance: Color::ONE,
            distribution: Microfacet::isotropic(MicrofacetKind::Ggx, 0.15),
            eta: 1.49,
            nonlinear: true,
        },
        Material::RoughDielectric {
            distribution: Microfacet::isotropic(MicrofacetKind::Beckmann, 0.3).into(),
            eta: 1.33,
            specular_reflectance: Color::ONE,
            specular_transmittance: Color::splat(0.9),
        },
        Material::Blend {
            weight: Texture::Const(Color::splat(0.3)),
            first: Box::new(Material::Diffuse { reflectance: Texture::Const(Color::splat(0.2)) }),
            second: Box::new(Material::Conductor { eta: Color::ZERO, k: Color::ZERO, specular_reflectance: Color::ONE }),
        },
        Material::Plastic {
            diffuse_reflectance: Texture::Const(Color::new(0.5, 0.4, 0.3)),
            specular_reflectance: Color::splat(0.8),
            eta: 1.6,
            nonlinear: false,
        },
        Material::TwoSided {
            front: Box::new(Material::Diffuse { reflectance: Texture::Const(Color::splat(0.3)) }),
            back: Box::new(Material::Conductor { eta: Color::ZERO, k: Color::ZERO, specular_reflectance: Color::ONE }),
        },
        Material::TwoSided {
            front: Box::new(Material::Diffuse { reflectance: Texture::Const(Color::splat(0.6)) }),
            back: Box::new(Material::Diffuse { reflectance: Texture::Const(Color::splat(0.6)) }),
        },
        Material::Mask {
            opacity: Texture::Const(Color::splat(0.4)),
            nested: Box::new(Material::Diffuse { reflectance: Texture::Const(Color::splat(0.5)) }),
        },
        Material::BumpMap {
            height: Texture::bitmap(0, Vec2::ONE),
            scale: 0.25,
            nested: Box::new(Material::Diffuse { reflectance: Texture::Const(Color::splat(0.5)) }),
        },
        Material::NormalMap {
            normals: Texture::Const(Color::new(0.6, 0.5, 0.9)),
            nested: Box::new(Material::Diffuse { reflectance: Texture::Const(Color::splat(0.5)) }),
        },
    ];
    let mut smooth = TriMesh::cube(&Mat4::from_scale_rotation_translation(
        Vec3::new(0.5, 1.0, 2.0),
        glam::Quat::from_rotation_y(0.3),
        Vec3::new(1.0, -2.0, 0.5),
    ));
    smooth.normals = Some(smooth.positions.iter().map(|p| p.normalize()).collect());
    let mut flat = TriMesh::rectangle(&Mat4::from_translation(Vec3::Y * 3.0));
    flat.normals = None;
    flat.uvs = None;
    let light = TriMesh::disk(&Mat4::from_translation(Vec3::new(0.0, 5.0, 0.0)), 16);
    let shape = |name: &str, geometry, material, emission, flip_normals| ShapeDesc {
        name: name.into(),
        geometry,
        material,
        emission,
        flip_normals,
    };
    let mut shapes: Vec<ShapeDesc> = (0..materials.len() as u32)
        .map(|m| {
            shape(
                &format!("ball {m}"),
                Geometry::Sphere { center: Vec3::new(m as f32, 0.25, -1.0), radius: 0.2 + m as f32 * 0.01 },
                m,
                None,
                false,
            )
        })
        .collect();
    shapes.push(shape("smooth/cube", Geometry::Mesh(smooth), 1, None, false));
    shapes.push(shape("flat", Geometry::Mesh(flat), 7, None, true));
    shapes.push(shape("lamp", Geometry::Mesh(light), 0, Some(Color::new(10.0, 8.0, 6.0)), false));
    let spot_dir = Vec3::new(0.2, -1.0, 0.1).normalize();
    let lights = vec![
        Light::Point { position: Vec3::new(1.0, 2.0, 3.0), intensity: Color::new(5.0, 4.0, 3.0) },
        Light::Spot {
            position: Vec3::new(-1.0, 4.0, 0.0),
            frame: Frame::from_normal(spot_dir),
            intensity: Color::splat(20.0),
            cos_cutoff: 25f32.to_radians().cos(),
            cos_falloff_start: 15f32.to_radians().cos(),
        },
        Light::Directional { direction: Vec3::new(1.0, -3.0, 0.5).normalize(), irradiance: Color::new(2.0, 2.0, 1.5) },
        Light::Constant { radiance: Color::new(0.1, 0.2, 0.3) },
    ];
    let camera = CameraDesc {
        to_world: look_at(Vec3::new(0.0, 1.0, 8.0), Vec3::new(0.5, 0.0, 0.0), Vec3::Y),
        fov_deg: 33.0,
        fov_axis: FovAxis::Y,
        near_clip: 0.05,
    };
    let film = FilmDesc { width: 300, height: 200, filter: PixelFilter::Gaussian { stddev: 0.7 }, sample_border: false };
    SceneDesc { shapes, materials, images, lights, camera, film, hints: Default::default() }
}

fn tex_eq(a: &Texture, ai: &[Image], b: &Texture, bi: &[Image]) -> bool {
    match (a, b) {
        (Texture::Const(x), Texture::Const(y)) => x.abs_diff_eq(*y, 1e-6),
        (Texture::Bitmap { image: i, uv_scale: s, .. }, Texture::Bitmap { image: j, uv_scale: t, .. }) => {
            let (p, q) = (&ai[*i as usize], &bi[*j as usize]);
            s == t && p.width == q.width && p.height == q.height && p.data == q.data
        }
        _ => false,
    }
}

fn mat_eq(a: &Material, ai: &[Image], b: &Material, bi: &[Image]) -> bool {
    use Material::*;
    let c = |x: &Color, y: &Color| x.abs_diff_eq(*y, 1e-6);
    match (a, b) {
        (Diffuse { reflectance: x }, Diffuse { reflectance: y }) => tex_eq(x, ai, y, bi),
        (Conductor { eta: e1, k: k1, specular_reflectance: s1 }, Conductor { eta: e2, k: k2, specular_reflectance: s2 }) => {
            c(e1, e2) && c(k1, k2) && c(s1, s2)
        }
        (
            RoughConductor { distribution: a1, eta: e1, k: k1, specular_reflectance: s1 },
            RoughConductor { distribution: a2, eta: e2, k: k2, specular_reflectance: s2 },
        ) => a1 == a2 && c(e1, e2) && c(k1, k2) && c(s1, s2),
        (
            Dielectric { eta: e1, specular_reflectance: r1, specular_transmittance: t1 },
            Dielectric { eta: e2, specular_reflectance: r2, specular_transmittance: t2 },
        )
        | (
            ThinDielectric { eta: e1, specular_reflectance: r1, specular_transmittance: t1 },
            ThinDielectric { eta: e2, specular_reflectance: r2, specular_transmittance: t2 },
        ) => e1 == e2 && c(r1, r2) && c(t1, t2),
        (
            RoughPlastic { diffuse_reflectance: d1, specular_reflectance: s1, distribution: a1, eta: e1, nonlinear: n1 },
            RoughPlastic { diffuse_reflectance: d2, specular_reflectance: s2, distribution: a2, eta: e2, nonlinear: n2 },
        ) => tex_eq(d1, ai, d2, bi) && c(s1, s2) && a1 == a2 && e1 == e2 && n1 == n2,
        (
            RoughDielectric { distribution: a1, eta: e1, specular_reflectance: r1, specular_transmittance: t1 },
            RoughDielectric { distribution: a2, eta: e2, specular_reflectance: r2, specular_transmittance: t2 },
        ) => a1 == a2 && e1 == e2 && c(r1, r2) && c(t1, t2),
        (
            Plastic { diffuse_reflectance: d1, specular_reflectance: s1, eta: e1, nonlinear: n1 },
            Plastic { diffuse_reflectance: d2, specular_reflectance: s2, eta: e2, nonlinear: n2 },
        ) => tex_eq(d1, ai, d2, bi) && c(s1, s2) && e1 == e2 && n1 == n2,
        (TwoSided { front: f1, back: b1 }, TwoSided { front: f2, back: b2 }) => mat_eq(f1, ai, f2, bi) && mat_eq(b1, ai, b2, bi),
        (Blend { weight: w1, first: f1, second: s1 }, Blend { weight: w2, first: f2, second: s2 }) => {
            tex_eq(w1, ai, w2, bi) && mat_eq(f1, ai, f2, bi) && mat_eq(s1, ai, s2, bi)
        }
        (Mask { opacity: o1, nested: n1 }, Mask { opacity: o2, nested: n2 })
        | (NormalMap { normals: o1, nested: n1 }, NormalMap { normals: o2, nested: n2 }) => {
            tex_eq(o1, ai, o2, bi) && mat_eq(n1, ai, n2, bi)
        }
        (BumpMap { height: h1, scale: s1, nested: n1 }, BumpMap { height: h2, scale: s2, nested: n2 }) => {
            tex_eq(h1, ai, h2, bi) && s1 == s2 && mat_eq(n1, ai, n2, bi)
        }
        _ => false,
    }
}

fn mesh_eq(a: &TriMesh, b: &TriMesh) -> bool {
    a.indices == b.indices
        && a.positions == b.positions
        && a.normals.is_some() == b.normals.is_some()
        && a.normals.iter().zip(&b.normals).all(|(x, y)| x.iter().zip(y).all(|(p, q)| p.abs_diff_eq(*q, 1e-6)))
        && a.uvs == b.uvs
}

#[test]
fn export_then_load_gives_the_same_scene() {
    let dir = temp_dir("roundtrip");
    let xml_path = dir.join("scene.xml");
    let a = scene();
    a.validate().unwrap();
    write_mitsuba_scene(&a, 48, 7, &xml_path).unwrap();
    let loaded = load(&xml_path, &[]).unwrap();
    assert!(loaded.warnings.is_empty(), "{:#?}", loaded.warnings);
    let b = &loaded.desc;
    b.validate().unwrap();

    assert_eq!(b.hints.spp, Some(48));
    assert_eq!(b.hints.max_depth, Some(7));
    assert_eq!(b.film, a.film);
    assert!(b.camera.to_world.abs_diff_eq(a.camera.to_world, 1e-6));
    assert_eq!((b.camera.fov_deg, b.camera.fov_axis, b.camera.near_clip), (a.camera.fov_deg, a.camera.fov_axis, a.camera.near_clip));

    assert_eq!(b.materials.len(), a.materials.len(), "every material, in index order");
    for (i, (x, y)) in a.materials.iter().zip(&b.materials).enumerate() {
        assert!(mat_eq(x, &a.images, y, &b.images), "material {i}:\n{x:?}\n{y:?}");
    }
    assert_eq!(b.shapes.len(), a.shapes.len());
    for (x, y) in a.shapes.iter().zip(&b.shapes) {
        assert_eq!(x.material, y.material, "{}", x.name);
        assert_eq!((x.emission, x.flip_normals), (y.emission, y.flip_normals), "{}", x.name);
        match (&x.geometry, &y.geometry) {
            (Geometry::Sphere { center: c1, radius: r1 }, Geometry::Sphere { center: c2, radius: r2 }) => {
                assert!(c1.abs_diff_eq(*c2, 1e-6) && (r1 - r2).abs() < 1e-6, "{}", x.name)
            }
            (Geometry::Mesh(m1), Geometry::Mesh(m2)) => assert!(mesh_eq(m1, m2), "{}:\n{m1:?}\n{m2:?}", x.name),
            _ => panic!("{}: geometry kind changed", x.name),
        }
    }

    assert_eq!(b.lights.len(), a.lights.len());
    for (x, y) in a.lights.iter().zip(&b.lights) {
        match (x, y) {
            (
                Light::Spot { position: p1, frame: f1, intensity: i1, cos_cutoff: c1, cos_falloff_start: s1 },
                Light::Spot { position: p2, frame: f2, intensity: i2, cos_cutoff: c2, cos_falloff_start: s2 },
            ) => {
                assert!(p1.abs_diff_eq(*p2, 1e-6) && i1 == i2);
                assert!(f1.n.abs_diff_eq(f2.n, 1e-6) && f1.s.abs_diff_eq(f2.s, 1e-6) && f1.t.abs_diff_eq(f2.t, 1e-6));
                assert!((c1 - c2).abs() < 1e-6 && (s1 - s2).abs() < 1e-6);
            }
            (Light::Directional { direction: d1, irradiance: e1 }, Light::Directional { direction: d2, irradiance: e2 }) => {
                assert!(d1.abs_diff_eq(*d2, 1e-6) && e1 == e2)
            }
            _ => assert_eq!(x, y),
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn area_lights_in_the_light_list_become_shape_emission() {
    let dir = temp_dir("area");
    let mut a = SceneDesc::default();
    a.materials.push(Material::Diffuse { reflectance: Texture::Const(Color::splat(0.5)) });
    a.shapes.push(ShapeDesc {
        name: "quad".into(),
        geometry: Geometry::Mesh(TriMesh::rectangle(&Mat4::IDENTITY)),
        material: 0,
        emission: None,
        flip_normals: false,
    });
    a.lights.push(Light::Area { shape: 0, radiance: Color::new(1.0, 2.0, 3.0) });
    let xml = to_mitsuba_xml(&a, 4, -1, &dir, "").unwrap();
    assert!(xml.contains("<emitter type=\"area\">") && xml.contains("value=\"1, 2, 3\""), "{xml}");
    assert!(xml.contains("<integer name=\"max_depth\" value=\"-1\"/>"));
    let path = dir.join("scene.xml");
    std::fs::write(&path, &xml).unwrap();
    let b = load(&path, &[]).unwrap();
    assert_eq!(b.desc.shapes[0].emission, Some(Color::new(1.0, 2.0, 3.0)));
    assert!(b.desc.lights.is_empty());

    // A light naming a shape that does not exist is an error, not a panic.
    a.lights.push(Light::Area { shape: 9, radiance: Color::ONE });
    assert!(to_mitsuba_xml(&a, 4, -1, &dir, "").is_err());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
#[cfg_attr(
    missing = "scenes/mitsuba-tutorials-cbox",
    ignore = "needs ../shared/scenes/mitsuba-tutorials-cbox (or $OCTOLUX_SHARED): see docs/guide/scenes.md"
)]
fn shared_cornell_box_survives_export() {
    let Some(src) = octolux_io::shared::shared_scene("mitsuba-tutorials-cbox/cbox.xml") else { return };
    let a = load(&src, &[]).unwrap().desc;
    let dir = temp_dir("cbox");
    let xml_path = dir.join("cbox_export.xml");
    write_mitsuba_scene(&a, 16, 6, &xml_path).unwrap();
    if std::env::var_os("OCTOLUX_SHOW_EXPORT").is_some() {
        println!("{}", std::fs::read_to_string(&xml_path).unwrap());
    }
    let b = load(&xml_path, &[]).unwrap();
    assert!(b.warnings.is_empty(), "{:#?}", b.warnings);
    let b = b.desc;
    assert_eq!((b.shapes.len(), b.materials.len(), b.film), (a.shapes.len(), a.materials.len(), a.film));
    for (x, y) in a.shapes.iter().zip(&b.shapes) {
        assert_eq!((x.material, x.emission), (y.material, y.emission), "{}", x.name);
        assert!(mat_eq(&a.materials[x.material as usize], &a.images, &b.materials[y.material as usize], &b.images), "{}", x.name);
        if let (Geometry::Mesh(m1), Geometry::Mesh(m2)) = (&x.geometry, &y.geometry) {
            assert!(mesh_eq(m1, m2), "{}", x.name);
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
