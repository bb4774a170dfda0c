//! Tests of the wrappers `mask`, `bumpmap` and `normalmap`: limits that reduce them to the
//! nested BSDF, the null lobe, chi² of the mask's sampling, and the perturbed frames the
//! prepared scene builds (against hand-computed normals).

use super::tests::{dir, white};
use super::*;
use crate::accel::BackendKind;
use crate::math::Ray;
use crate::sampling::Sampler;
use crate::scene::camera::{look_at, CameraDesc, FovAxis};
use crate::scene::{FilmDesc, Geometry, PixelFilter, Scene, SceneDesc, ShapeDesc, SurfaceHit, TriMesh};
use crate::testing::{check_bsdf, Chi2Config};
use glam::Mat4;

fn plastic() -> Material {
    Material::RoughPlastic {
        diffuse_reflectance: Texture::Const(Color::new(0.6, 0.3, 0.2)),
        specular_reflectance: white(1.0),
        distribution: Microfacet::isotropic(MicrofacetKind::Ggx, 0.3),
        eta: 1.49,
        nonlinear: false,
    }
}

fn mask(o: f32) -> Material {
    Material::Mask { opacity: Texture::Const(white(o)), nested: Box::new(plastic()) }
}

fn close(a: Color, b: Color) -> bool {
    (a - b).abs().max_element() <= 1e-6 * (1.0 + a.abs().max_element())
}

#[test]
fn mask_with_opacity_one_is_the_nested_bsdf() {
    let (m, inner) = (mask(1.0), plastic());
    let mut s = Sampler::new(7, 0, 0);
    for (wo, wi) in [(dir(20.0, 10.0), dir(40.0, 200.0)), (dir(70.0, 0.0), dir(65.0, 170.0)), (dir(5.0, 90.0), dir(85.0, 30.0))] {
        assert!(close(m.eval(&[], Vec2::ZERO, wo, wi), inner.eval(&[], Vec2::ZERO, wo, wi)));
        assert_eq!(m.pdf(&[], Vec2::ZERO, wo, wi), inner.pdf(&[], Vec2::ZERO, wo, wi));
        for _ in 0..64 {
            let (ul, u) = (s.next_1d(), s.next_2d());
            let (a, b) = (m.sample(&[], Vec2::ZERO, wo, ul, u), inner.sample(&[], Vec2::ZERO, wo, ul, u));
            match (a, b) {
                (Some(a), Some(b)) => {
                    assert_eq!((a.wi, a.lobe, a.pdf), (b.wi, b.lobe, b.pdf));
                    assert!(close(a.weight, b.weight));
                }
                (None, None) => {}
                _ => panic!("opacity 1: the mask samples {a:?}, the nested bsdf {b:?}"),
            }
        }
    }
    assert_eq!(m.opacity(&[], Vec2::ZERO), 1.0);
    assert_eq!(inner.opacity(&[], Vec2::ZERO), 1.0);
}

#[test]
fn mask_with_opacity_zero_is_a_pure_pass_through() {
    let m = mask(0.0);
    let mut s = Sampler::new(8, 0, 0);
    for wo in [dir(20.0, 10.0), dir(80.0, 120.0), -dir(30.0, 40.0)] {
        assert_eq!(m.eval(&[], Vec2::ZERO, wo, dir(30.0, 200.0)), Color::ZERO);
        assert_eq!(m.pdf(&[], Vec2::ZERO, wo, dir(30.0, 200.0)), 0.0);
        for _ in 0..64 {
            let bs = m.sample(&[], Vec2::ZERO, wo, s.next_1d(), s.next_2d()).expect("the null lobe always samples");
            assert_eq!((bs.wi, bs.weight, bs.pdf, bs.lobe, bs.eta), (-wo, Color::ONE, 1.0, Lobe::Null, 1.0));
            assert!(bs.lobe.is_delta());
        }
    }
    // Out-of-range opacities clamp (Mitsuba's eval_opacity), colours are read through luminance.
    assert_eq!(mask(-2.0).opacity(&[], Vec2::ZERO), 0.0);
    assert_eq!(mask(3.0).opacity(&[], Vec2::ZERO), 1.0);
    let rgb = Material::Mask { opacity: Texture::Const(Color::new(1.0, 0.0, 0.0)), nested: Box::new(plastic()) };
    assert!((rgb.opacity(&[], Vec2::ZERO) - 0.212671).abs() < 1e-6);
}

#[test]
fn mask_sampling_matches_its_pdf_and_opacity() {
    // Chi² of the non-null samples against `pdf` (= opacity · nested pdf), a textured opacity
    // included, and the null lobe's share.
    let cfg = Chi2Config { samples: 200_000, tests: 3, ..Default::default() };
    let images = vec![Image { width: 2, height: 1, data: vec![white(0.3), white(0.9)] }];
    let textured = Material::Mask { opacity: Texture::bitmap(0, Vec2::ONE), nested: Box::new(plastic()) };
    for (m, uv, wo) in [
        (mask(0.6), Vec2::ZERO, dir(35.0, 20.0)),
        (mask(0.25), Vec2::ZERO, dir(75.0, 200.0)),
        (textured, Vec2::new(0.25, 0.5), dir(50.0, 0.0)),
    ] {
        let out = check_bsdf(&cfg, &m, &images, uv, wo);
        assert!(out.passed, "{m:?} wo {wo}: {out:?}");
        let o = m.opacity(&images, uv) as f64;
        let n = 40_000;
        let mut s = Sampler::new(3, 1, 0);
        let nulls = (0..n).filter(|_| m.sample(&images, uv, wo, s.next_1d(), s.next_2d()).is_some_and(|b| b.lobe == Lobe::Null)).count();
        let share = nulls as f64 / n as f64;
        let sd = (o * (1.0 - o) / n as f64).sqrt();
        assert!((share - (1.0 - o)).abs() < 5.0 * sd, "null share {share}, expected {}", 1.0 - o);
    }
}

/// The hit at the centre-ish point `uv` of a 2x2 quad in the z = 0 plane (normal +z, Mitsuba's
/// rectangle: `dp/du = (2, 0, 0)`, `dp/dv = (0, 2, 0)`), seen from above, with material `m`.
fn quad_hit(m: Material, images: Vec<Image>, uv: Vec2) -> (Scene, SurfaceHit) {
    let desc = SceneDesc {
        shapes: vec![ShapeDesc {
            name: "quad".into(),
            geometry: Geometry::Mesh(TriMesh::rectangle(&Mat4::IDENTITY)),
            material: 0,
            emission: None,
            flip_normals: false,
        }],
        materials: vec![m],
        images,
        camera: CameraDesc {
            to_world: look_at(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, Vec3::Y),
            fov_deg: 40.0,
            fov_axis: FovAxis::X,
            near_clip: 1e-3,
        },
        film: FilmDesc { width: 4, height: 4, filter: PixelFilter::Box, sample_border: false },
        ..Default::default()
    };
    let scene = Scene::prepare(desc, BackendKind::Bvh).expect("valid scene");
    let p = Vec3::new(2.0 * uv.x - 1.0, 2.0 * uv.y - 1.0, 0.0);
    let hit = scene.intersect(&Ray::new(p + Vec3::new(0.1, -0.05, 2.0), Vec3::new(-0.1, 0.05, -2.0).normalize())).expect("hit");
    (scene, hit)
}

fn near(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-4
}

#[test]
fn flat_bump_and_normal_maps_leave_the_nested_bsdf_unchanged() {
    let uv = Vec2::new(0.3, 0.6);
    let flat_normals = Texture::Const(Color::new(0.5, 0.5, 1.0));
    for m in [
        Material::BumpMap { height: Texture::Const(white(0.7)), scale: 3.0, nested: Box::new(plastic()) },
        Material::NormalMap { normals: flat_normals, nested: Box::new(plastic()) },
    ] {
        let (scene, hit) = quad_hit(m.clone(), Vec::new(), uv);
        assert!(near(hit.frame.n, Vec3::Z) && near(hit.base_n, Vec3::Z), "{m:?}: frame {:?}", hit.frame);
        assert!(near(hit.dp_du, Vec3::new(2.0, 0.0, 0.0)) && near(hit.dp_dv, Vec3::new(0.0, 2.0, 0.0)));
        let (wo, wi) = (dir(30.0, 10.0), dir(50.0, 220.0));
        let m = &scene.materials[hit.material as usize];
        assert!(close(m.eval(&scene.images, hit.uv, wo, wi), plastic().eval(&scene.images, hit.uv, wo, wi)));
        assert_eq!(m.pdf(&scene.images, hit.uv, wo, wi), plastic().pdf(&scene.images, hit.uv, wo, wi));
        let (up, down) = (Vec3::new(0.3, 0.2, 0.5).normalize(), Vec3::new(0.3, 0.2, -0.5).normalize());
        // No perturbation: nothing to check or shadow (below the surface, the nested one-sided
        // bsdf is what gives zero).
        assert_eq!((hit.shading_factor(up), hit.shading_factor(down), hit.terminator_alpha2), (1.0, 1.0, 0.0));
    }
}

#[test]
fn bump_and_normal_maps_tilt_the_frame_as_mitsuba_does() {
    // Height rising linearly along u: 8 texels 0, 1, ..., 7 (luminance), so dh/du = 8 per uv
    // between texel centres; with scale 1/4 the gradient is 2 and dp/du' = (2, 0, 2):
    // n' = normalize((2,0,2) × (0,2,0)) = (-1, 0, 1)/√2.
    let ramp = Image { width: 8, height: 1, data: (0..8).map(|i| white(i as f32)).collect() };
    let bump = Material::BumpMap { height: Texture::bitmap(0, Vec2::ONE), scale: 0.25, nested: Box::new(plastic()) };
    let (_, hit) = quad_hit(bump, vec![ramp], Vec2::new(0.5, 0.5));
    assert!(near(hit.frame.n, Vec3::new(-1.0, 0.0, 1.0).normalize()), "bump normal {}", hit.frame.n);
    assert!(near(hit.base_n, Vec3::Z));
    assert!(hit.frame.s.dot(hit.frame.n).abs() < 1e-5 && hit.frame.s.x > 0.0, "tangent follows dp/du: {:?}", hit.frame);
    // Mitsuba's side check: between the two planes a direction has no BSDF value; above both
    // the terminator shadowing (α² = tan²45° / 8) dims grazing directions only.
    assert!((hit.terminator_alpha2 - 0.125).abs() < 1e-6, "{}", hit.terminator_alpha2);
    assert_eq!(hit.shading_factor(Vec3::new(-1.0, 0.0, -0.3).normalize()), 0.0);
    assert_eq!(hit.shading_factor(Vec3::Z), 1.0);
    let grazing = Vec3::new(-1.0, 0.0, 0.3).normalize();
    let g = 2.0 / (1.0 + (1.0 + 0.125 * (1.0 / 0.3f32).powi(2)).sqrt());
    assert!((hit.shading_factor(grazing) - g).abs() < 1e-5, "{} vs {g}", hit.shading_factor(grazing));

    // Normal map: red is +u (dp/du = +x), green +v (+y): (1, 0.5, 0.5) → +x, i.e. a normal in
    // the surface plane; (0.5, 0.5 + 0.5 sin 30°, 0.5 + 0.5 cos 30°) → tilted 30° towards +y.
    let (s, c) = 30f32.to_radians().sin_cos();
    let nm = Material::NormalMap { normals: Texture::Const(Color::new(0.5, 0.5 + 0.5 * s, 0.5 + 0.5 * c)), nested: Box::new(plastic()) };
    let (_, hit) = quad_hit(nm, Vec::new(), Vec2::new(0.4, 0.7));
    assert!(near(hit.frame.n, Vec3::new(0.0, s, c)), "normal-map normal {}", hit.frame.n);
    // A mask over a normal map keeps the mask (its null lobe) and tilts the frame.
    let masked = Material::Mask {
        opacity: Texture::Const(white(0.5)),
        nested: Box::new(Material::NormalMap { normals: Texture::Const(Color::new(1.0, 0.5, 0.5)), nested: Box::new(plastic()) }),
    };
    let (scene, hit) = quad_hit(masked, Vec::new(), Vec2::new(0.4, 0.7));
    assert!(near(hit.frame.n, Vec3::X), "{}", hit.frame.n);
    assert!(matches!(scene.materials[hit.material as usize], Material::Mask { .. }));
}

#[test]
fn resolving_a_mask_picks_the_nested_material_with_the_opacity() {
    let (scene, hit) = quad_hit(mask(0.3), Vec::new(), Vec2::splat(0.5));
    let mut h = hit;
    assert!(!scene.resolve_mask(&mut h, 0.29), "u < opacity: the surface");
    assert_eq!(scene.materials[h.material as usize], plastic());
    let mut h = hit;
    assert!(scene.resolve_mask(&mut h, 0.31), "u ≥ opacity: passes");
    assert_eq!(h.material, hit.material);
    // Other materials are never resolved.
    let (scene, hit) = quad_hit(plastic(), Vec::new(), Vec2::splat(0.5));
    let mut h = hit;
    assert!(!scene.resolve_mask(&mut h, 0.99));
    assert_eq!(h.material, hit.material);
}

#[test]
fn wrappers_validate_their_parts() {
    let bad_nested = Material::Diffuse { reflectance: Texture::Const(white(-1.0)) };
    assert!(Material::Mask { opacity: Texture::Const(white(0.5)), nested: Box::new(bad_nested.clone()) }.validate(0).is_err());
    assert!(Material::Mask { opacity: Texture::bitmap(3, Vec2::ONE), nested: Box::new(plastic()) }.validate(1).is_err());
    assert!(Material::BumpMap { height: Texture::Const(white(0.5)), scale: f32::NAN, nested: Box::new(plastic()) }.validate(0).is_err());
    assert!(Material::NormalMap { normals: Texture::Const(white(0.5)), nested: Box::new(bad_nested) }.validate(0).is_err());
    assert!(Material::BumpMap { height: Texture::Const(white(0.5)), scale: -2.0, nested: Box::new(plastic()) }.validate(0).is_ok());
}
