//! Property test on random scenes (issue 11, item 1): small scenes of open and closed
//! analytic and mesh shapes (analytic spheres; mesh spheres, cubes, rectangles, disks, open
//! tubes and hemispheres), under random transforms (the whole scene scaled by 10^±2, objects
//! from 0.003 to 2 of it, a quarter of them squashed to 1/10–1/1000 along one axis), some of
//! them emitting, optionally a constant sky or a point light, the camera inside an enclosure
//! (mostly facing inwards) or outside the objects. For every integrator (`path`, `octree`,
//! `octree --gather`, `photonmap`, `ward`, `christensen`) the image must be finite and
//! non-negative, and within a bound of the path tracer's (`SPP_PATH` samples per pixel; the
//! others take `SPP`):
//! - no pixel above [`K_MAX`] = 10 times the path tracer's largest pixel (the done-when
//!   on the collection), the largest of its renders at `SPP_PATH` and at `SPP` samples (the
//!   same camera rays as the others: an emitter smaller than a pixel, hit by one sample in
//!   `SPP`, makes a pixel `SPP_PATH / SPP` times brighter than at `SPP_PATH`);
//! - the image mean within a factor [`F_MEAN`] of the path tracer's, plus [`Z_NOISE`]
//!   standard deviations of a mean at `SPP` samples (estimated from the spread of the path
//!   tracer's pixels: an over-estimate, the spread holds the image's contrast too).
//!
//! The bounds come from measurement (`OCTOLUX_PROP_CASES=300 OCTOLUX_PROP_REPORT=1`, see
//! [`F_MEAN`]). The generator is a seeded loop (no shrinking): a failure prints the seed and
//! the scene (`Spec`). `OCTOLUX_PROP_CASES=N` and `OCTOLUX_PROP_FIRST=S` run other seeds;
//! `OCTOLUX_PROP_REPORT=1` prints the ratios and does not assert the bounds (finiteness is
//! always asserted); `OCTOLUX_PROP_SPEC=1` prints every scene, `OCTOLUX_PROP_PIXELS=1` every
//! image, `OCTOLUX_PROP_WORLD=W` sets the scene scale.

use octolux::accel::BackendKind;
use octolux::glam::{Mat4, Quat, Vec2, Vec3};
use octolux::integrators::path::PathSettings;
use octolux::integrators::{build, IntegratorSettings};
use octolux::render::{render, RenderSettings};
use octolux::scene::camera::{look_at, CameraDesc, FovAxis};
use octolux::scene::material::{Material, Texture};
use octolux::scene::{FilmDesc, Geometry, Light, PixelFilter, Scene, SceneDesc, ShapeDesc, TriMesh};
use octolux::Color;

/// Seeds run by default (the measurement ran many more, see [`F_MEAN`]).
const CASES: u64 = 12;
/// Largest pixel of any integrator over the path reference's largest pixel.
const K_MAX: f64 = 10.0;
/// Image mean of any integrator within this factor of the path reference's (plus the noise
/// allowance). Measured on seeds 0–299 (`OCTOLUX_PROP_CASES=300`, 12x12 pixels, path 256 spp,
/// the others 16 spp): outside [`KNOWN_LEAKS`] the largest factor a case needed was 1.71
/// (ward, seed 270, where christensen needs 1.5 and octree 1.05; the next ones 1.36 and
/// 1.31), 99% of the cases need at most 1.07 and 95% none; the largest pixel ratio was 5.8
/// (octree --gather, seed 193; 95% under 1.7). Before the shadow-ray fix of
/// `SurfaceHit::spawn_to`, the path tracer itself was 3–30x too dark in scenes a few
/// centimetres across (seeds 8, 165).
const F_MEAN: f64 = 2.0;
/// Floors of the bounds, as fractions of the brightest emitted radiance (`Spec::light_scale`):
/// the mean may exceed the path tracer's by `FLOOR_MEAN` of it, a pixel reach `K_MAX` times
/// `FLOOR_MAX` of it.
const FLOOR_MEAN: f64 = 1e-3;
const FLOOR_MAX: f64 = 1e-2;
/// Noise allowance of the mean test, in standard deviations of the mean at `SPP` samples.
const Z_NOISE: f64 = 3.0;
/// Seeds and integrators known to exceed the bounds (of seeds 0–299), and why; the test fails
/// if one of them comes back within them (then remove it). All are light leaking to where the
/// path tracer sees none, across surfaces of zero thickness or seams — below the leak goal of
/// issue 11 (no leak once a wall is one leaf thick):
/// - 104: an open emitting tube wider than the room crosses its walls; the walls inside the
///   tube (dark) take the light of the walls just outside through the tube's zero-thickness
///   wall (mean 4.1x for octree, 18x ward, 27x christensen; photonmap and octree --gather
///   within the bounds);
/// - 106: the camera inside a closed sphere that cuts the room's wall, the light outside it:
///   photons and estimates leak across the seam (path 0; octree mean 2.7e-3 of the light's
///   scale, ward 5e-3, christensen 9e-3, pixels up to 0.1 of it);
/// - 145: christensen only: a thin closed box emits inwards (its light trapped: path ~0
///   outside it); the ground's lookups find the box's dense irradiance photons through its
///   walls within the lookup radius (5.5% of a 75-unit scene) with a compatible normal (mean
///   5e4x, pixels 344x); ward and the others are within the bounds;
/// - 289: christensen only, mean 5.2x in a room of open hemispheres (not analysed).
const KNOWN_LEAKS: &[(u64, &str, &str)] = &[
    (104, "octree", "zero-thickness emitting tube across the walls"),
    (104, "ward", "zero-thickness emitting tube across the walls"),
    (104, "christensen", "zero-thickness emitting tube across the walls"),
    (106, "octree", "seam of a closed sphere cutting the wall"),
    (106, "ward", "seam of a closed sphere cutting the wall"),
    (106, "christensen", "seam of a closed sphere cutting the wall"),
    (145, "christensen", "irradiance photons trapped in a thin inward-emitting box, found through its walls"),
    (289, "christensen", "mean 5.2x (not analysed; the others within 1.3x)"),
];
/// Film edge in pixels, and samples per pixel of the reference and of the others.
const RES: u32 = 12;
const SPP_PATH: u32 = 256;
const SPP: u32 = 16;

/// Deterministic generator (SplitMix64).
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn f(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, a: f32, b: f32) -> f32 {
        a + (b - a) * self.f()
    }
    /// Log-uniform in [10^a, 10^b).
    fn log(&mut self, a: f32, b: f32) -> f32 {
        10f32.powf(self.range(a, b))
    }
    fn chance(&mut self, p: f32) -> bool {
        self.f() < p
    }
    fn pick(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
    /// A point in the ball of radius `r`.
    fn in_ball(&mut self, r: f32) -> Vec3 {
        loop {
            let p = Vec3::new(self.range(-1.0, 1.0), self.range(-1.0, 1.0), self.range(-1.0, 1.0));
            if p.length_squared() <= 1.0 {
                return p * r;
            }
        }
    }
    /// A uniform random rotation (Shoemake).
    fn rotation(&mut self) -> Quat {
        let (u1, u2, u3) = (self.f(), self.f() * std::f32::consts::TAU, self.f() * std::f32::consts::TAU);
        let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
        Quat::from_xyzw(a * u2.sin(), a * u2.cos(), b * u3.sin(), b * u3.cos()).normalize()
    }
}

/// Kinds of shape; the mesh kinds take any affine transform, the analytic sphere a centre and
/// a radius.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    AnalyticSphere,
    MeshSphere,
    Cube,
    Rectangle,
    Disk,
    /// Open cylinder of radius 1 from z = -1 to 1 (no caps).
    Tube,
    /// Open upper half of the unit sphere.
    Hemisphere,
}

const OBJECT_KINDS: [Kind; 7] =
    [Kind::AnalyticSphere, Kind::MeshSphere, Kind::Cube, Kind::Rectangle, Kind::Disk, Kind::Tube, Kind::Hemisphere];
const CLOSED_KINDS: [Kind; 3] = [Kind::AnalyticSphere, Kind::MeshSphere, Kind::Cube];

/// One shape of a random scene, as printed when a case fails.
#[derive(Clone, Debug)]
struct ShapeSpec {
    kind: Kind,
    center: Vec3,
    rotation: Quat,
    /// Scale along the local axes (equal for the analytic sphere).
    scale: Vec3,
    albedo: f32,
    /// `None`: diffuse; `Some(true)`: mirror; `Some(false)`: glass.
    specular: Option<bool>,
    emission: Option<f32>,
    flip_normals: bool,
}

/// A random scene before scaling by `world` (the whole scene, camera included).
#[derive(Clone, Debug)]
struct Spec {
    seed: u64,
    world: f32,
    inside: bool,
    shapes: Vec<ShapeSpec>,
    sky: Option<f32>,
    point: Option<(Vec3, f32)>,
    eye: Vec3,
    target: Vec3,
    fov_deg: f32,
}

fn uv_sphere(rings: u32, segments: u32, upper_half_only: bool) -> TriMesh {
    let mut m = TriMesh { normals: Some(Vec::new()), uvs: Some(Vec::new()), ..Default::default() };
    let theta_max = if upper_half_only { std::f32::consts::FRAC_PI_2 } else { std::f32::consts::PI };
    for i in 0..=rings {
        let theta = theta_max * i as f32 / rings as f32;
        for j in 0..=segments {
            let phi = std::f32::consts::TAU * j as f32 / segments as f32;
            let p = Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
            m.positions.push(p);
            m.normals.as_mut().unwrap().push(p);
            m.uvs.as_mut().unwrap().push(Vec2::new(j as f32 / segments as f32, i as f32 / rings as f32));
        }
    }
    let row = segments + 1;
    for i in 0..rings {
        for j in 0..segments {
            let (a, b, c, d) = (i * row + j, i * row + j + 1, (i + 1) * row + j, (i + 1) * row + j + 1);
            // outward winding; the pole triangles of zero area are dropped by `prepare`
            m.indices.push([a, c, b]);
            m.indices.push([b, c, d]);
        }
    }
    m
}

fn tube(segments: u32) -> TriMesh {
    let mut m = TriMesh { normals: Some(Vec::new()), uvs: Some(Vec::new()), ..Default::default() };
    for j in 0..=segments {
        let phi = std::f32::consts::TAU * j as f32 / segments as f32;
        let n = Vec3::new(phi.cos(), phi.sin(), 0.0);
        for z in [-1.0, 1.0] {
            m.positions.push(n + Vec3::Z * z);
            m.normals.as_mut().unwrap().push(n);
            m.uvs.as_mut().unwrap().push(Vec2::new(j as f32 / segments as f32, (z + 1.0) * 0.5));
        }
    }
    for j in 0..segments {
        let (a, b, c, d) = (2 * j, 2 * j + 1, 2 * j + 2, 2 * j + 3);
        m.indices.push([a, c, b]);
        m.indices.push([b, c, d]);
    }
    m
}

impl ShapeSpec {
    fn random(rng: &mut Rng, kind: Kind, center: Vec3, size: f32) -> ShapeSpec {
        let mut scale = Vec3::splat(size);
        if kind != Kind::AnalyticSphere {
            for a in 0..3 {
                scale[a] *= rng.range(0.5, 2.0);
            }
            // thin shapes: one axis a thousandth to a tenth of the others
            if rng.chance(0.25) {
                let a = rng.pick(3);
                scale[a] *= rng.log(-3.0, -1.0);
            }
        }
        let specular = if rng.chance(0.15) { Some(rng.chance(0.5)) } else { None };
        ShapeSpec {
            kind,
            center,
            rotation: rng.rotation(),
            scale,
            albedo: rng.range(0.1, 0.9),
            specular,
            emission: None,
            flip_normals: rng.chance(0.2),
        }
    }

    fn to_desc(&self, world: f32, material: u32) -> ShapeDesc {
        let to_world = Mat4::from_scale_rotation_translation(self.scale * world, self.rotation, self.center * world);
        let mesh = |mut m: TriMesh| {
            m.transform(&to_world);
            Geometry::Mesh(m)
        };
        let geometry = match self.kind {
            Kind::AnalyticSphere => Geometry::Sphere { center: self.center * world, radius: self.scale.x * world },
            Kind::MeshSphere => mesh(uv_sphere(12, 24, false)),
            Kind::Hemisphere => mesh(uv_sphere(6, 24, true)),
            Kind::Cube => Geometry::Mesh(TriMesh::cube(&to_world)),
            Kind::Rectangle => Geometry::Mesh(TriMesh::rectangle(&to_world)),
            Kind::Disk => Geometry::Mesh(TriMesh::disk(&to_world, 24)),
            Kind::Tube => mesh(tube(24)),
        };
        ShapeDesc {
            name: format!("{:?}", self.kind),
            geometry,
            material,
            emission: self.emission.map(Color::splat),
            flip_normals: self.flip_normals,
        }
    }

    fn material(&self) -> Material {
        match self.specular {
            None => Material::Diffuse { reflectance: Texture::Const(Color::splat(self.albedo)) },
            Some(true) => Material::Conductor { eta: Color::ZERO, k: Color::ZERO, specular_reflectance: Color::splat(self.albedo) },
            Some(false) => Material::Dielectric { eta: 1.5, specular_reflectance: Color::ONE, specular_transmittance: Color::ONE },
        }
    }
}

impl Spec {
    fn random(seed: u64) -> Spec {
        let mut rng = Rng(seed.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ 0x5EED);
        let world = rng.log(-2.0, 2.0);
        let inside = rng.chance(0.5);
        let mut shapes = Vec::new();
        let (eye, target);
        if inside {
            // the enclosure: a closed shape of size ~1 around the origin, inward (mostly)
            let kind = CLOSED_KINDS[rng.pick(CLOSED_KINDS.len())];
            let mut s = ShapeSpec::random(&mut rng, kind, Vec3::ZERO, 1.0);
            s.scale = if kind == Kind::AnalyticSphere {
                Vec3::ONE
            } else {
                Vec3::new(rng.range(0.7, 1.4), rng.range(0.7, 1.4), rng.range(0.7, 1.4))
            };
            s.specular = None;
            s.flip_normals = !rng.chance(0.1);
            if rng.chance(0.3) {
                s.emission = Some(rng.log(-1.0, 0.5));
            }
            shapes.push(s);
            eye = rng.in_ball(0.4);
            target = eye + rng.in_ball(1.0).normalize_or(Vec3::X);
        } else {
            eye = rng.in_ball(1.0).normalize_or(Vec3::Z) * rng.range(3.0, 5.0);
            target = rng.in_ball(0.3);
            if rng.chance(0.3) {
                // a large ground, possibly crossing the objects
                let height = rng.range(-1.5, -0.2);
                let mut s = ShapeSpec::random(&mut rng, Kind::Rectangle, Vec3::new(0.0, height, 0.0), 1.0);
                s.rotation = Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2);
                s.scale = Vec3::new(rng.log(0.5, 2.0), rng.log(0.5, 2.0), 1.0);
                s.specular = None;
                shapes.push(s);
            }
        }
        let objects = 1 + rng.pick(4);
        for _ in 0..objects {
            let kind = OBJECT_KINDS[rng.pick(OBJECT_KINDS.len())];
            let center = rng.in_ball(if inside { 0.6 } else { 1.0 });
            let size = rng.log(-2.5, 0.3) * if inside { 0.5 } else { 1.0 };
            let mut s = ShapeSpec::random(&mut rng, kind, center, size);
            if rng.chance(0.35) {
                s.specular = None;
                s.emission = Some(rng.log(0.0, 1.5));
            }
            shapes.push(s);
        }
        let sky = rng.chance(if inside { 0.2 } else { 0.6 }).then(|| rng.log(-0.5, 0.5));
        let point = rng.chance(0.15).then(|| (rng.in_ball(0.8), rng.log(-1.0, 1.0)));
        let mut spec = Spec { seed, world, inside, shapes, sky, point, eye, target, fov_deg: rng.range(30.0, 90.0) };
        // inside an enclosure, a light inside it (the sky cannot get in): an emitting object,
        // the enclosure emitting inwards, or else a point light
        let lit_inside = spec.point.is_some()
            || spec.shapes[1..].iter().any(|s| s.emission.is_some())
            || (spec.shapes[0].emission.is_some() && spec.shapes[0].flip_normals);
        if inside && !lit_inside {
            spec.point = Some((rng.in_ball(0.5), rng.log(-1.0, 1.0)));
        }
        if spec.sky.is_none() && spec.point.is_none() && spec.shapes.iter().all(|s| s.emission.is_none()) {
            let last = spec.shapes.last_mut().expect("at least one object");
            last.specular = None;
            last.emission = Some(rng.log(0.0, 1.5));
        }
        spec
    }

    /// The brightest radiance a light emits (W/(m² sr)); a point light counts as the
    /// irradiance it gives at one scene unit (`world`) from it.
    fn light_scale(&self) -> f64 {
        let mut l = self.sky.unwrap_or(0.0).max(self.point.map_or(0.0, |p| p.1));
        for s in &self.shapes {
            l = l.max(s.emission.unwrap_or(0.0));
        }
        f64::from(l)
    }

    fn desc(&self) -> SceneDesc {
        let w = self.world;
        let shapes = self.shapes.iter().enumerate().map(|(i, s)| s.to_desc(w, i as u32)).collect();
        let materials = self.shapes.iter().map(ShapeSpec::material).collect();
        let mut lights = Vec::new();
        if let Some(l) = self.sky {
            lights.push(Light::Constant { radiance: Color::splat(l) });
        }
        if let Some((p, i)) = self.point {
            // intensity scaled with the square of the scene so that irradiances do not depend on `world`
            lights.push(Light::Point { position: p * w, intensity: Color::splat(i * w * w) });
        }
        let dir = (self.target - self.eye).normalize();
        let up = if dir.y.abs() > 0.99 { Vec3::Z } else { Vec3::Y };
        SceneDesc {
            shapes,
            materials,
            lights,
            camera: CameraDesc {
                to_world: look_at(self.eye * w, self.target * w, up),
                fov_deg: self.fov_deg,
                fov_axis: FovAxis::X,
                near_clip: 1e-4 * w,
            },
            film: FilmDesc { width: RES, height: RES, filter: PixelFilter::Box, sample_border: false },
            ..Default::default()
        }
    }
}

/// Every cache integrator, with test-sized photon counts.
fn integrators() -> Vec<(&'static str, IntegratorSettings)> {
    octolux::testing::cache_integrators(100_000, 20_000, 4)
}

/// What the test reads of a render.
struct Stats {
    /// Mean over pixels and channels.
    mean: f64,
    /// Largest pixel channel.
    max: f64,
    /// Standard deviation of the pixels' channel means.
    std: f64,
}

/// [`Stats`] of a render; panics on a non-finite or negative pixel.
fn render_stats(spec: &Spec, scene: &Scene, name: &str, settings: &IntegratorSettings, spp: u32) -> Stats {
    let integrator = build(settings, scene).unwrap_or_else(|e| panic!("seed {}: {name}: {e}\n{spec:#?}", spec.seed));
    let (img, _) = render(scene, &integrator, &RenderSettings { spp, seed: spec.seed, ..Default::default() }, &|_, _| {});
    if let Some(bad) = img.data.iter().position(|c| !(c.is_finite() && c.min_element() >= 0.0)) {
        panic!("seed {}: {name}: pixel {bad} is {}\n{spec:#?}", spec.seed, img.data[bad]);
    }
    if std::env::var("OCTOLUX_PROP_PIXELS").is_ok_and(|v| v == "1") {
        println!("  {name} pixels:");
        for row in img.data.chunks(RES as usize) {
            println!("    {}", row.iter().map(|c| format!("{:9.2e}", c.element_sum() / 3.0)).collect::<Vec<_>>().join(" "));
        }
    }
    let n = img.data.len() as f64;
    let mean = img.data.iter().map(|c| c.element_sum() as f64 / 3.0).sum::<f64>() / n;
    let var = img.data.iter().map(|c| (c.element_sum() as f64 / 3.0 - mean).powi(2)).sum::<f64>() / (n - 1.0);
    Stats { mean, max: img.data.iter().map(|c| c.max_element() as f64).fold(0.0, f64::max), std: var.sqrt() }
}

fn env_u64(name: &str, default: u64) -> u64 {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

#[test]
fn random_scenes_every_integrator_finite_and_near_the_path_tracer() {
    let first = env_u64("OCTOLUX_PROP_FIRST", 0);
    let cases = env_u64("OCTOLUX_PROP_CASES", CASES);
    let report = std::env::var("OCTOLUX_PROP_REPORT").is_ok_and(|v| v == "1");
    let mut failures = Vec::new();
    for seed in first..first + cases {
        let mut spec = Spec::random(seed);
        if let Some(w) = std::env::var("OCTOLUX_PROP_WORLD").ok().and_then(|v| v.parse().ok()) {
            spec.world = w;
        }
        if std::env::var("OCTOLUX_PROP_SPEC").is_ok_and(|v| v == "1") {
            println!("{spec:#?}");
        }
        let scene = Scene::prepare(spec.desc(), BackendKind::Bvh).unwrap_or_else(|e| panic!("seed {seed}: {e}\n{spec:#?}"));
        let max_depth = std::env::var("OCTOLUX_PROP_PATH_DEPTH").ok().and_then(|v| v.parse().ok()).unwrap_or(-1);
        let path = IntegratorSettings::Path(PathSettings { max_depth, ..Default::default() });
        let reference = render_stats(&spec, &scene, "path", &path, SPP_PATH);
        // The path tracer at the others' sample count and seed takes the same camera rays:
        // an emitter smaller than a pixel, hit by one camera sample in `SPP`, makes a pixel
        // `SPP_PATH / SPP` times brighter than at `SPP_PATH` samples, in every integrator.
        let same_rays = render_stats(&spec, &scene, "path", &path, SPP);
        let ref_max = reference.max.max(same_rays.max);
        // The mean's noise at `SPP` samples, bounded by the pixels' spread (which also holds
        // the image's own contrast, so it over-estimates the noise).
        let sigma = reference.std / f64::from(RES * RES).sqrt() * f64::from(SPP_PATH / SPP).sqrt();
        // Floors for black references (light that reaches the camera's side through a seam,
        // e.g. a photon offset across the line where a plane cuts a sphere): a fraction of
        // the brightest emitted radiance.
        let light = spec.light_scale();
        let slack = (Z_NOISE * sigma).max(FLOOR_MEAN * light);
        let ref_max = ref_max.max(FLOOR_MAX * light);
        let kinds: Vec<_> = spec.shapes.iter().map(|s| format!("{:?}", s.kind)).collect();
        println!(
            "seed {seed}: world {:.3}, {}, {}, path mean {:.4e} max {ref_max:.4e} slack {slack:.3e}",
            spec.world,
            if spec.inside { "inside" } else { "outside" },
            kinds.join("+"),
            reference.mean,
        );
        for (name, settings) in integrators() {
            let got = render_stats(&spec, &scene, name, &settings, SPP);
            let mean_ok = got.mean <= F_MEAN * reference.mean + slack && got.mean >= reference.mean / F_MEAN - slack;
            let max_ok = got.max <= K_MAX * ref_max;
            let known = KNOWN_LEAKS.iter().any(|&(s, n, _)| s == seed && n == name);
            println!(
                "  prop seed {seed} {name:16} mean_ratio {:.4} max_ratio {:.4} mean {:.4e} max {:.4e}{}",
                got.mean / reference.mean.max(1e-30),
                got.max / ref_max.max(1e-30),
                got.mean,
                got.max,
                if known { " (known leak)" } else { "" }
            );
            let within = mean_ok && max_ok;
            if within && known {
                failures.push(format!("seed {seed}, {name}: listed in KNOWN_LEAKS but within the bounds now: remove it"));
            }
            if !within && !known {
                failures.push(format!(
                    "seed {seed}, {name}: mean {:.4e} (path {:.4e} ± {slack:.2e}), max {:.4e} (path {ref_max:.4e})\n{spec:#?}",
                    got.mean, reference.mean, got.max
                ));
            }
        }
    }
    if !report {
        assert!(failures.is_empty(), "{} failures:\n{}", failures.len(), failures.join("\n"));
    }
}
