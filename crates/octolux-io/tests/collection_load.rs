//! The research scenes of the shared collection (`bitterli-collection/*/scene.xml`, Mitsuba 0.6
//! syntax) load: no error, geometry present, and the warnings printed per scene (run with
//! `--nocapture` to read them). Elements the loader maps must not be reported unsupported:
//! the `serialized` shapes in particular. Each scene is skipped with one line when absent.

use octolux::scene::Geometry;
use octolux_io::shared::shared_scene;

const SCENES: [&str; 6] = ["box", "classroom", "dining-room", "sponza", "torus", "veach-lamp"];

#[test]
#[cfg_attr(
    all(
        missing = "scenes/bitterli-collection/box",
        missing = "scenes/bitterli-collection/classroom",
        missing = "scenes/bitterli-collection/dining-room",
        missing = "scenes/bitterli-collection/sponza",
        missing = "scenes/bitterli-collection/torus",
        missing = "scenes/bitterli-collection/veach-lamp"
    ),
    ignore = "needs ../shared/scenes/bitterli-collection (or $OCTOLUX_SHARED): see docs/guide/scenes.md"
)]
fn collection_scenes_load_with_their_geometry() {
    for name in SCENES {
        let Some(path) = shared_scene(&format!("bitterli-collection/{name}/scene.xml")) else { continue };
        let t = std::time::Instant::now();
        let s = octolux_io::load_scene(&path.to_string_lossy(), &[]).unwrap_or_else(|e| panic!("{name}: {e}"));
        let triangles: usize = s
            .desc
            .shapes
            .iter()
            .map(|sh| match &sh.geometry {
                Geometry::Mesh(m) => m.indices.len(),
                Geometry::Sphere { .. } => 0,
            })
            .sum();
        println!(
            "{name}: {} shapes, {triangles} triangles, {} materials, {} lights, loaded in {:.2} s, {} warnings",
            s.desc.shapes.len(),
            s.desc.materials.len(),
            s.desc.lights.len(),
            t.elapsed().as_secs_f64(),
            s.warnings.len()
        );
        for w in &s.warnings {
            println!("  {w}");
        }
        assert!(triangles > 0, "{name}: no geometry");
        for w in &s.warnings {
            assert!(!w.contains("unsupported shape type"), "{name}: {w}");
        }
    }
}
