//! The `octree` integrator's analytic tests: furnaces and an open sky.

use super::*;
use crate::integrators::test_scenes::{check_furnace, furnace_box_scene, furnace_scene, image_mean, sky_plane_scene};
use crate::integrators::Integrator;
use crate::math::Color;
use crate::render::{render, RenderSettings};
use crate::scene::material::Material;
use glam::Vec3;

fn render_mean(scene: &Scene, s: OctreeIntegratorSettings, spp: u32) -> (f64, OctreeBuildStats, RayCounters) {
    let o = OctreeIntegrator::build(scene, s).unwrap();
    let stats = o.stats.clone();
    let (img, st) = render(scene, &Integrator::Octree(Box::new(o)), &RenderSettings { spp, ..Default::default() }, &|_, _| {});
    assert!(img.data.iter().all(|c| c.is_finite() && c.min_element() >= 0.0));
    (image_mean(&img.data), stats, st.counters)
}

/// The furnace: a closed cube emitting Le = 1 with albedo ρ = 0.5 has radiance 2 and
/// indirect irradiance π everywhere (`test_scenes::furnace_box_scene`). The incident field
/// is uniform, so an octree leaf's estimate is unbiased wherever its gathering box holds
/// only planar walls whose triangles it clips (the geometry-area estimator); what is left
/// is photon noise. The image (the middle of one wall) reads a few dozen leaves, so its
/// mean carries the noise of a few thousand photons: measured over photon seeds 0–3 with
/// 200 000 photons, the irradiance mean spread over 3.145–3.213 (σ ≈ 1%), with 1 000 000
/// 3.117 and 3.153. With 400 000 photons σ ≈ 0.7%; the render adds the next-event
/// estimate's noise (256 pixels x 16 spp, on a quarter of the radiance: ~0.5%). The bound,
/// 3%, is 4σ.
#[test]
fn furnace_is_analytic() {
    let scene = furnace_box_scene(0.5, 1.0);
    let mut means = Vec::new();
    for view in [OctreeView::Render, OctreeView::Irradiance] {
        let mut s = OctreeIntegratorSettings { view, ..Default::default() };
        s.photons.photons = 400_000;
        let (mean, stats, counters) = render_mean(&scene, s, 16);
        assert_eq!(stats.caustic_photons, 0);
        assert!(stats.global.valid_leaves > 8 && counters.cache_queries > 0, "{stats:?}");
        means.push(mean);
    }
    check_furnace(means[0], means[1], 0.03, "octree");
    // The paper's renderer reads the same octree at the first vertex.
    let mut s = OctreeIntegratorSettings { mode: Mode::Paper, ..Default::default() };
    s.photons.photons = 400_000;
    let (paper, _, _) = render_mean(&scene, s, 16);
    eprintln!("octree mode=paper: furnace render {paper:.4} (2)");
    assert!((paper - 2.0).abs() < 2.0 * 0.03, "mode=paper render {paper}, expected 2");
}

/// The furnace in an analytic sphere (`test_scenes::furnace_scene`: closed, emitting
/// Le = 1 inwards, ρ = 0.5, camera at the centre; radiance 2 everywhere). Before the
/// sphere was clipped exactly, the geometry-area estimator saw it as a tessellation its
/// photons did not lie on: mean 71.5 (`--gather`: 461,040). The octree carries a quarter
/// of the radiance (ρ E / π = 0.5 of 2), so the render's error is a quarter of the
/// irradiance's: with 400 000 photons the irradiance mean's photon noise is ~0.7% (as in
/// the cube's furnace), the render's ~0.2% plus the direct light's ~0.3% (256 pixels x 16
/// spp): the bound, 1%, is about 3σ; the irradiance view keeps the cube's 3%. No pixel may
/// exceed 1.5x the truth (the blow-ups were 700x).
#[test]
fn furnace_in_an_analytic_sphere_is_analytic() {
    let scene = furnace_scene(0.5, 1.0);
    for mode in [Mode::Terminate, Mode::Paper] {
        let mut means = Vec::new();
        for view in [OctreeView::Render, OctreeView::Irradiance] {
            let mut s = OctreeIntegratorSettings { view, mode, ..Default::default() };
            s.photons.photons = 400_000;
            let o = OctreeIntegrator::build(&scene, s).unwrap();
            assert_eq!(o.stats.global.geometry_fallback_leaves, 0, "{:?}", o.stats.global);
            let (img, _) = render(&scene, &Integrator::Octree(Box::new(o)), &RenderSettings { spp: 16, ..Default::default() }, &|_, _| {});
            let max = img.data.iter().map(|c| c.max_element()).fold(0.0f32, f32::max);
            let truth = if view == OctreeView::Render { 2.0 } else { std::f32::consts::PI };
            assert!(max < 1.5 * truth, "{mode:?}, {view:?}: pixel {max}");
            means.push(image_mean(&img.data));
        }
        eprintln!("octree sphere furnace, {mode:?}: render {:.4} (2), irradiance {:.4} (π)", means[0], means[1]);
        assert!((means[0] - 2.0).abs() < 0.01 * 2.0, "{mode:?}: render {}", means[0]);
        check_furnace(means[0], means[1], 0.03, "octree, analytic sphere");
    }
}

/// A Lambertian plane under a constant sky: all its light is direct (`ρ L_sky`), so the
/// photon pass stores nothing, the octree adds nothing (direct light is never counted
/// twice) and the render is the NEE estimate alone. Noise: one light sample per camera
/// sample, `4 ρ L cos θ` on the upper half of a uniform sphere of directions, of relative
/// standard deviation √(8/3 − 1) = 1.29; 256 pixels x 256 spp make it 0.5% for the image
/// mean; the bound is 2% (4σ).
#[test]
fn plane_under_a_constant_sky_gets_direct_light_only() {
    let (rho, sky) = (0.5, 2.0);
    let scene = sky_plane_scene(rho, sky);
    let mut s = OctreeIntegratorSettings::default();
    s.photons.photons = 50_000;
    let (render_mean_, stats, _) = render_mean(&scene, s.clone(), 256);
    assert_eq!((stats.global_photons, stats.caustic_photons), (0, 0), "{stats:?}");
    let expect = (rho * sky) as f64;
    eprintln!("octree: plane under a constant sky {render_mean_:.4} ({expect})");
    assert!((render_mean_ / expect - 1.0).abs() < 0.02, "render {render_mean_}, expected {expect}");
    s.view = OctreeView::Irradiance;
    let (irradiance, _, _) = render_mean(&scene, s, 4);
    assert_eq!(irradiance, 0.0, "indirect irradiance under an open sky");
}

/// With a footprint factor no cone reaches, no path ends in the cache, and with a caustic
/// photon count no leaf reaches, the caustic octree is not read either: the `octree` integrator
/// is the path tracer's loop, and its images are the path tracer's bit for bit (on a box, a box
/// with a glass sphere and a mirror, and a sky).
#[test]
fn octree_ending_no_path_is_the_path_tracer_bit_for_bit() {
    use crate::integrators::path::PathSettings;
    use crate::integrators::test_scenes::{box_desc, sky_plane_scene};
    let mut glass = box_desc();
    glass.materials.push(Material::Dielectric { eta: 1.5, specular_reflectance: Color::ONE, specular_transmittance: Color::ONE });
    glass.materials.push(Material::Conductor { eta: Color::ZERO, k: Color::ZERO, specular_reflectance: Color::splat(0.9) });
    let sphere = |c: Vec3, m: u32| crate::scene::ShapeDesc {
        name: "sphere".into(),
        geometry: crate::scene::Geometry::Sphere { center: c, radius: 0.3 },
        material: m,
        emission: None,
        flip_normals: false,
    };
    glass.shapes.push(sphere(Vec3::new(-0.4, 0.3, -0.3), 3));
    glass.shapes.push(sphere(Vec3::new(0.4, 0.3, -0.4), 4));
    glass.film.width = 16;
    glass.film.height = 16;
    let scenes = [
        ("box", crate::integrators::test_scenes::box_scene(16)),
        ("glass", Scene::prepare(glass, crate::accel::BackendKind::Bvh).unwrap()),
        ("sky", sky_plane_scene(0.5, 2.0)),
    ];
    for (name, scene) in &scenes {
        for max_depth in [-1, 5] {
            let mut s = OctreeIntegratorSettings { footprint: 1e30, caustic_photons: u32::MAX, max_depth, ..Default::default() };
            s.photons.photons = 20_000;
            let rs = RenderSettings { spp: 8, ..Default::default() };
            let o = Integrator::Octree(Box::new(OctreeIntegrator::build(scene, s.clone()).unwrap()));
            let (a, sa) = render(scene, &o, &rs, &|_, _| {});
            let p = Integrator::Path(PathSettings { max_depth, rr_depth: s.rr_depth, ..Default::default() });
            let (b, sb) = render(scene, &p, &rs, &|_, _| {});
            assert_eq!(sa.counters.cache_ends, [0; 4], "{name}");
            assert!(
                a.data.iter().zip(&b.data).all(|(x, y)| x.to_array().map(f32::to_bits) == y.to_array().map(f32::to_bits)),
                "{name}, max_depth {max_depth}: the images differ"
            );
            assert_eq!((sa.counters.rays, sa.counters.shadow_rays), (sb.counters.rays, sb.counters.shadow_rays), "{name}");
        }
    }
}

/// Where the cache may be read at the camera vertex (footprint factor 0: any cone is wide
/// enough), a diffuse camera vertex ends there and a glossy one (every surface a rough
/// conductor of alpha 0.05, under `min_alpha`) is traced on, whatever vertex it is; a rougher
/// one (alpha 0.6) ends there too. With the default factor (0.25) a camera vertex ends only
/// where its pixel is at least a quarter of a leaf wide: in this box at 50k photons 48% of the
/// camera paths do at 64² (7856 of 16384), 22% at 128² (14500 of 65536), the smaller leaves
/// near edges and corners first; the other paths end one bounce on.
#[test]
fn a_glossy_camera_vertex_is_traced_on() {
    use crate::scene::material::Texture;
    use crate::scene::material::{MicrofacetKind, Roughness};
    let ends = |material: Option<f32>, footprint: f32, res: u32| {
        let mut desc = crate::integrators::test_scenes::box_desc();
        desc.film.width = res;
        desc.film.height = res;
        if let Some(alpha) = material {
            // every surface becomes rough metal
            let metal = Material::RoughConductor {
                distribution: Roughness {
                    kind: MicrofacetKind::Ggx,
                    alpha_u: Texture::Const(Color::splat(alpha)),
                    alpha_v: Texture::Const(Color::splat(alpha)),
                },
                eta: Color::ZERO,
                k: Color::ZERO,
                specular_reflectance: Color::splat(0.8),
            };
            desc.materials.iter_mut().for_each(|m| *m = metal.clone());
        }
        let scene = Scene::prepare(desc, crate::accel::BackendKind::Bvh).unwrap();
        let mut s = OctreeIntegratorSettings { footprint, ..Default::default() };
        s.photons.photons = 50_000;
        let o = Integrator::Octree(Box::new(OctreeIntegrator::build(&scene, s).unwrap()));
        let (img, st) = render(&scene, &o, &RenderSettings { spp: 4, ..Default::default() }, &|_, _| {});
        assert!(img.data.iter().all(|c| c.is_finite() && c.min_element() >= 0.0));
        st.counters.cache_ends
    };
    let diffuse = ends(None, 0.0, 16);
    let glossy = ends(Some(0.05), 0.0, 16);
    let rough = ends(Some(0.6), 0.0, 16);
    let coarse = ends(None, DEFAULT_FOOTPRINT, 64);
    let default = ends(None, DEFAULT_FOOTPRINT, 128);
    eprintln!("paths ended at vertex 1, 2, 3, 4+: diffuse {diffuse:?}, glossy {glossy:?}, rough {rough:?}, diffuse default {default:?}");
    // 16² pixels x 4 spp = 1024 camera paths, most of them on the walls of material 0
    assert!(diffuse[0] > 500, "{diffuse:?}");
    assert_eq!(glossy, [0; 4], "a glossy vertex ended in the cache");
    assert!(rough[0] > 500, "{rough:?}");
    let share = |e: [u64; 4], res: u64| e[0] as f64 / (res * res * 4) as f64;
    assert!(
        share(default, 128) > 0.05 && share(default, 128) < 0.7 * share(coarse, 64),
        "a finer pixel ends fewer camera vertices: 64² {coarse:?}, 128² {default:?}"
    );
    assert!(default[1] > 32000, "128² x 4 spp paths, most of them ending at vertex 2: {default:?}");
}
