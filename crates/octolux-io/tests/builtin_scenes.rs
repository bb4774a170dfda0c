//! Built-in scenes: they validate, the camera sees the whole box, walls face inwards and blocks
//! outwards, the light faces down with the published area and a positive emission.

use glam::Vec3;
use octolux::scene::camera::Camera;
use octolux::scene::material::Material;
use octolux::scene::{Geometry, SceneDesc, ShapeDesc, TriMesh};
use octolux_io::builtin::{self, NAMES};

fn mesh<'a>(desc: &'a SceneDesc, name: &str) -> &'a TriMesh {
    let s = desc.shapes.iter().find(|s| s.name == name).unwrap_or_else(|| panic!("no shape '{name}'"));
    match &s.geometry {
        Geometry::Mesh(m) => m,
        g => panic!("'{name}' should be a mesh, got {g:?}"),
    }
}

/// (unnormalised geometric normal, centroid) of every triangle.
fn triangles(m: &TriMesh) -> Vec<(Vec3, Vec3)> {
    m.indices
        .iter()
        .map(|t| {
            let (a, b, c) = (m.positions[t[0] as usize], m.positions[t[1] as usize], m.positions[t[2] as usize]);
            ((b - a).cross(c - a), (a + b + c) / 3.0)
        })
        .collect()
}

#[test]
fn every_builtin_scene_exists_and_validates() {
    for name in NAMES {
        let desc = builtin::scene(name).unwrap_or_else(|| panic!("built-in '{name}' missing"));
        desc.validate().unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!((desc.film.width, desc.film.height), (512, 512));
        assert_eq!(desc.hints.spp, Some(64));
        assert!(desc.shapes.iter().any(|s| s.emission.is_some()), "{name} has a light");
    }
    assert!(builtin::scene("no-such-scene").is_none());
}

#[test]
fn camera_sees_the_whole_box() {
    for name in NAMES {
        let desc = builtin::scene(name).unwrap();
        assert!((desc.camera.fov_deg - 39.3077).abs() < 1e-3, "35 mm lens on 25 mm film");
        let cam = Camera::new(&desc.camera, desc.film.width, desc.film.height);
        assert!((cam.position() - Vec3::new(278.0, 273.0, -800.0)).length() < 1e-3);
        assert!((cam.forward() - Vec3::Z).length() < 1e-6);
        for x in [0.0, 556.0] {
            for y in [0.0, 548.8] {
                for z in [0.0, 559.2] {
                    let p = Vec3::new(x, y, z);
                    let f = cam.project(p).unwrap_or_else(|| panic!("{p} behind the camera"));
                    assert!(f.x >= 0.0 && f.y >= 0.0 && f.x <= 512.0 && f.y <= 512.0, "{name}: corner {p} projects to {f}");
                }
            }
        }
        // Red wall (x ~ 556) on the image's left, green (x = 0) on its right, floor at the bottom.
        let mid = |n: &str| {
            let m = mesh(&desc, n);
            cam.project(m.positions.iter().copied().sum::<Vec3>() / m.positions.len() as f32).unwrap()
        };
        assert!(mid("red-wall").x < 256.0 && mid("green-wall").x > 256.0);
        assert!(mid("floor").y > 256.0 && mid("ceiling").y < 256.0);
    }
}

#[test]
fn walls_face_inwards_and_blocks_outwards() {
    let desc = builtin::scene("cornell-box").unwrap();
    let center = builtin::CORNELL_BOX_CENTER;
    for wall in ["floor", "ceiling", "back-wall", "red-wall", "green-wall"] {
        let tris = triangles(mesh(&desc, wall));
        assert_eq!(tris.len(), 2, "{wall}");
        for (n, c) in tris {
            assert!(n.normalize().dot((center - c).normalize()) > 0.1, "{wall}: normal {n} at {c} must face the box centre");
        }
    }
    // Specific directions: the floor up, the back wall towards the camera, the red wall -x.
    assert!(triangles(mesh(&desc, "floor")).iter().all(|(n, _)| n.normalize().y > 0.999));
    assert!(triangles(mesh(&desc, "back-wall")).iter().all(|(n, _)| n.normalize().z < -0.999));
    assert!(triangles(mesh(&desc, "red-wall")).iter().all(|(n, _)| n.normalize().x < -0.99));
    assert!(triangles(mesh(&desc, "green-wall")).iter().all(|(n, _)| n.normalize().x > 0.999));
    for (block, height) in [("short-block", 165.0f32), ("tall-block", 330.0)] {
        let m = mesh(&desc, block);
        let tris = triangles(m);
        assert_eq!(tris.len(), 10, "{block}: top and four sides");
        let centroid = m.positions.iter().copied().sum::<Vec3>() / m.positions.len() as f32;
        for (n, c) in &tris {
            // Outwards: away from the block's vertical axis for the sides, up for the top.
            let away = Vec3::new(c.x - centroid.x, if (c.y - height).abs() < 1e-3 { 1.0 } else { 0.0 }, c.z - centroid.z);
            assert!(n.dot(away) > 0.0, "{block}: normal {n} at {c}");
        }
        assert!(m.bounds().min.y.abs() < 1e-6 && (m.bounds().max.y - height).abs() < 1e-4);
    }
}

#[test]
fn light_faces_down_below_the_ceiling_with_positive_area_and_emission() {
    for name in NAMES {
        let desc = builtin::scene(name).unwrap();
        let lights: Vec<&ShapeDesc> = desc.shapes.iter().filter(|s| s.emission.is_some()).collect();
        assert_eq!(lights.len(), 1);
        let light = lights[0];
        let e = light.emission.unwrap();
        assert!(e.min_element() > 0.0 && e.is_finite(), "{e}");
        let m = match &light.geometry {
            Geometry::Mesh(m) => m,
            g => panic!("{g:?}"),
        };
        assert!((m.area() - 130.0 * 105.0).abs() < 1e-2, "area {}", m.area());
        for (n, c) in triangles(m) {
            assert!(n.normalize().y < -0.999, "light normal {n}");
            assert!(c.y < 548.8 && c.y > 548.0, "just below the ceiling: {c}");
        }
        // The light is black (it absorbs), one-sided like every emitter.
        assert!(matches!(desc.materials[light.material as usize], Material::Diffuse { .. }));
    }
}

#[test]
fn spheres_rest_on_the_floor_inside_the_box() {
    let desc = builtin::scene("cornell-spheres").unwrap();
    assert!(desc.shapes.iter().all(|s| s.name != "short-block" && s.name != "tall-block"));
    let mut kinds = Vec::new();
    let mut spheres = Vec::new();
    for s in &desc.shapes {
        if let Geometry::Sphere { center, radius } = s.geometry {
            assert!((center.y - radius).abs() < 1e-4, "{}: resting on the floor", s.name);
            assert!(center.x - radius > 0.0 && center.x + radius < 549.6 && center.z - radius > 0.0 && center.z + radius < 559.2);
            kinds.push(desc.materials[s.material as usize].clone());
            spheres.push((center, radius));
        }
    }
    assert_eq!(spheres.len(), 2);
    assert!((spheres[0].0 - spheres[1].0).length() > spheres[0].1 + spheres[1].1, "spheres do not overlap");
    assert!(kinds.iter().any(|m| matches!(m, Material::Conductor { eta, k, .. } if *eta == Vec3::ZERO && *k == Vec3::ZERO)));
    assert!(kinds.iter().any(|m| matches!(m, Material::Dielectric { eta, .. } if *eta == 1.5)));
    let cam = Camera::new(&desc.camera, desc.film.width, desc.film.height);
    for (c, _) in spheres {
        let f = cam.project(c).unwrap();
        assert!(f.x > 0.0 && f.x < 512.0 && f.y > 0.0 && f.y < 512.0);
    }
}
