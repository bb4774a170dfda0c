//! Built-in scenes: the classic Cornell box and a Cornell box with a mirror and a glass sphere.
//!
//! Geometry is Cornell's published measurements of the real box, in millimetres
//! (<https://www.graphics.cornell.edu/online/box/data.html>): floor, ceiling, back wall, the
//! green wall at x = 0 (on the image's right) and the red wall at x ≈ 556 (on the left), the
//! short and tall blocks, and the light 343..213 × 332..227 placed 0.5 mm below the ceiling
//! (y = 548.3) so that it does not coincide with it, facing down. The front of the box is open
//! and the camera is outside it, at (278, 273, -800) looking along +z with +y up; its 35 mm lens
//! on a 25 mm film gives a field of view of 2·atan(12.5/35) = 39.3077°.
//!
//! Materials: Cornell's spectral data reduced to RGB as in Benedikt Bitterli's "Cornell Box"
//! (Rendering Resources, CC0; the version in the shared folder's `scenes/bitterli-cornell-box`, see
//! [`crate::shared`]):
//! white (0.725, 0.71, 0.68), red (0.63, 0.065, 0.05), green (0.14, 0.45, 0.091), light
//! radiance (17, 12, 4) W/(m² sr), and a black (non-reflecting) luminaire.
//!
//! Orientation (Mitsuba semantics: diffuse surfaces are one-sided, black from behind, and area
//! lights emit on the front side only): every wall triangle's geometric normal
//! `(b - a) × (c - a)` points into the box, every block face outwards, the light downwards.
//! The published vertex order is not relied upon: each quad is oriented explicitly.
//!
//! Render hints: 512×512 film with a tent filter, 64 samples per pixel, `max_depth = -1`
//! (unbounded paths ended by Russian roulette, Mitsuba's default), i.e. full global
//! illumination, which is what the radiance cache is meant to reproduce.

use glam::Vec3;
use octolux::math::Color;
use octolux::scene::camera::{look_at, CameraDesc, FovAxis};
use octolux::scene::material::{Material, Texture};
use octolux::scene::{FilmDesc, Geometry, PixelFilter, SceneDesc, SceneHints, ShapeDesc, TriMesh};

/// Names of the built-in scenes; the first is the default.
pub const NAMES: &[&str] = &["cornell-box", "cornell-spheres"];

/// The built-in scene of that name.
pub fn scene(name: &str) -> Option<SceneDesc> {
    match name {
        "cornell-box" => Some(cornell_box(true)),
        "cornell-spheres" => Some(cornell_spheres()),
        _ => None,
    }
}

/// Centre of the Cornell box's interior (mm), used to orient the walls inwards.
pub const CORNELL_BOX_CENTER: Vec3 = Vec3::new(278.0, 274.4, 279.6);
/// Height of the light below the ceiling (mm).
pub const LIGHT_OFFSET_MM: f32 = 0.5;
/// Radiance of the Cornell box light, W/(m² sr) per RGB channel.
pub const LIGHT_RADIANCE: Color = Color::new(17.0, 12.0, 4.0);

const WHITE: Color = Color::new(0.725, 0.71, 0.68);
const RED: Color = Color::new(0.63, 0.065, 0.05);
const GREEN: Color = Color::new(0.14, 0.45, 0.091);

/// Indices of the materials of the Cornell box scenes.
const MAT_WHITE: u32 = 0;
const MAT_RED: u32 = 1;
const MAT_GREEN: u32 = 2;
const MAT_LIGHT: u32 = 3;

fn v(x: f32, y: f32, z: f32) -> Vec3 {
    Vec3::new(x, y, z)
}

/// Append quad `q` as two triangles (0,1,2), (0,2,3), reversing its order first when its
/// normal would point against `want` (a direction, or a function of the quad's centroid).
fn push_quad(mesh: &mut TriMesh, mut q: [Vec3; 4], want: impl Fn(Vec3) -> Vec3) {
    let centroid = (q[0] + q[1] + q[2] + q[3]) * 0.25;
    let n = (q[1] - q[0]).cross(q[2] - q[0]) + (q[2] - q[0]).cross(q[3] - q[0]);
    if n.dot(want(centroid)) < 0.0 {
        q.reverse();
    }
    let base = mesh.positions.len() as u32;
    mesh.positions.extend_from_slice(&q);
    mesh.indices.push([base, base + 1, base + 2]);
    mesh.indices.push([base, base + 2, base + 3]);
}

/// A wall: one quad facing the box centre.
fn wall(q: [Vec3; 4]) -> TriMesh {
    let mut m = TriMesh::default();
    push_quad(&mut m, q, |c| CORNELL_BOX_CENTER - c);
    m
}

/// A block from its top quad (the published top face) and height: top and four sides, all
/// facing away from the block's centre (no bottom face: it rests on the floor).
fn block(top: [Vec3; 4], height: f32) -> TriMesh {
    let down = Vec3::new(0.0, height, 0.0);
    let center = (top[0] + top[1] + top[2] + top[3]) * 0.25 - down * 0.5;
    let out = move |c: Vec3| c - center;
    let mut m = TriMesh::default();
    push_quad(&mut m, top, out);
    for i in 0..4 {
        let (a, b) = (top[i], top[(i + 1) % 4]);
        push_quad(&mut m, [a - down, b - down, b, a], out);
    }
    m
}

fn shape(name: &str, mesh: TriMesh, material: u32) -> ShapeDesc {
    ShapeDesc { name: name.into(), geometry: Geometry::Mesh(mesh), material, emission: None, flip_normals: false }
}

/// The Cornell box, with or without its two blocks.
fn cornell_box(with_blocks: bool) -> SceneDesc {
    let diffuse = |c: Color| Material::Diffuse { reflectance: Texture::Const(c) };
    let materials = vec![diffuse(WHITE), diffuse(RED), diffuse(GREEN), diffuse(Color::ZERO)];
    let mut shapes = vec![
        shape("floor", wall([v(552.8, 0.0, 0.0), v(0.0, 0.0, 0.0), v(0.0, 0.0, 559.2), v(549.6, 0.0, 559.2)]), MAT_WHITE),
        shape("ceiling", wall([v(556.0, 548.8, 0.0), v(556.0, 548.8, 559.2), v(0.0, 548.8, 559.2), v(0.0, 548.8, 0.0)]), MAT_WHITE),
        shape("back-wall", wall([v(549.6, 0.0, 559.2), v(0.0, 0.0, 559.2), v(0.0, 548.8, 559.2), v(556.0, 548.8, 559.2)]), MAT_WHITE),
        shape("green-wall", wall([v(0.0, 0.0, 559.2), v(0.0, 0.0, 0.0), v(0.0, 548.8, 0.0), v(0.0, 548.8, 559.2)]), MAT_GREEN),
        shape("red-wall", wall([v(552.8, 0.0, 0.0), v(549.6, 0.0, 559.2), v(556.0, 548.8, 559.2), v(556.0, 548.8, 0.0)]), MAT_RED),
    ];
    if with_blocks {
        shapes.push(shape(
            "short-block",
            block([v(130.0, 165.0, 65.0), v(82.0, 165.0, 225.0), v(240.0, 165.0, 272.0), v(290.0, 165.0, 114.0)], 165.0),
            MAT_WHITE,
        ));
        shapes.push(shape(
            "tall-block",
            block([v(423.0, 330.0, 247.0), v(265.0, 330.0, 296.0), v(314.0, 330.0, 456.0), v(472.0, 330.0, 406.0)], 330.0),
            MAT_WHITE,
        ));
    }
    let y = 548.8 - LIGHT_OFFSET_MM;
    let mut light = TriMesh::default();
    push_quad(&mut light, [v(343.0, y, 227.0), v(343.0, y, 332.0), v(213.0, y, 332.0), v(213.0, y, 227.0)], |_| Vec3::NEG_Y);
    shapes.push(ShapeDesc { emission: Some(LIGHT_RADIANCE), ..shape("light", light, MAT_LIGHT) });

    let camera = CameraDesc {
        to_world: look_at(v(278.0, 273.0, -800.0), v(278.0, 273.0, 0.0), Vec3::Y),
        fov_deg: 2.0 * (12.5f32 / 35.0).atan().to_degrees(),
        fov_axis: FovAxis::X,
        near_clip: 1e-2,
    };
    SceneDesc {
        shapes,
        materials,
        images: Vec::new(),
        lights: Vec::new(),
        camera,
        film: FilmDesc { width: 512, height: 512, filter: PixelFilter::Tent, sample_border: false },
        hints: SceneHints { spp: Some(64), max_depth: Some(-1), integrator: None },
    }
}

/// Radius of the two spheres of `cornell-spheres` (mm).
pub const SPHERE_RADIUS: f32 = 100.0;
/// Centres of the mirror (back left) and glass (front right) spheres, resting on the floor, as
/// in Jensen's caustics box.
pub const MIRROR_SPHERE_CENTER: Vec3 = Vec3::new(380.0, SPHERE_RADIUS, 360.0);
pub const GLASS_SPHERE_CENTER: Vec3 = Vec3::new(175.0, SPHERE_RADIUS, 170.0);

/// The Cornell box without blocks, with a perfect mirror sphere at the back left and a glass
/// sphere (eta 1.5) at the front right. The mirror is a `Conductor` with eta = k = 0, the
/// convention for Mitsuba's material "none" (Fresnel factor 1).
fn cornell_spheres() -> SceneDesc {
    let mut desc = cornell_box(false);
    let mirror = desc.materials.len() as u32;
    desc.materials.push(Material::Conductor { eta: Color::ZERO, k: Color::ZERO, specular_reflectance: Color::ONE });
    let glass = mirror + 1;
    desc.materials.push(Material::Dielectric { eta: 1.5, specular_reflectance: Color::ONE, specular_transmittance: Color::ONE });
    for (name, center, material) in [("mirror-sphere", MIRROR_SPHERE_CENTER, mirror), ("glass-sphere", GLASS_SPHERE_CENTER, glass)] {
        desc.shapes.push(ShapeDesc {
            name: name.into(),
            geometry: Geometry::Sphere { center, radius: SPHERE_RADIUS },
            material,
            emission: None,
            flip_normals: false,
        });
    }
    desc
}
