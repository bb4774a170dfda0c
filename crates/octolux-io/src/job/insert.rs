//! `render --insert OBJECT --insert-path PATH.json` (issue 13, item 5; docs/guide/baking.md
//! "Inserted objects"): an object absent from the bake (an OBJ or PLY mesh, or the shapes of a
//! Mitsuba XML file) is added to the rendered scene, moved per frame by an object path
//! (`octolux::scene::object_path`). The lighting is the bake's: the cache's fingerprint is
//! compared with the scene *without* the object (which the object does not change), and the
//! `octree` integrator reads the object's indirect light from its volumetric values
//! (`octolux::integrators::octree::insert`). Any other integrator renders the scene with the
//! object as it is (`--integrator path` gives the truth to compare with).
//!
//! With the `octree` integrator the object's light comes, by default, from an incremental
//! re-bake ([`InsertLight::Rebake`], `octolux::integrators::octree::rebake`): the photon paths
//! the object meets are traced again and the leaves around the photons they move re-estimated,
//! so that the object casts its indirect shadow, bleeds its colour and is lit by the scene with
//! it; [`InsertLight::Volume`] reads the baked volumetric values on the object instead and
//! leaves the scene's light as baked.
//!
//! The object's shapes are appended after the scene's, its materials after the scene's (their
//! indices shifted); its lights, camera and film are ignored (a note says so). Refused: an
//! emitting object (the bake holds no light from it) and textured materials (their images are
//! not carried over).

use super::{bail, Context, Frontend, Result};
use glam::{Mat4, Vec3};
use octolux::integrators::octree::insert::{InsertAo, Inserted};
use octolux::integrators::octree::rebake::{ObjectMove, RebakeState, RebakeStats};
use octolux::integrators::octree::OctreeIntegrator;
use octolux::math::{Bounds3, Ray};
use octolux::scene::material::Material;
use octolux::scene::object_path::ObjectPath;
use octolux::scene::{Geometry, Scene, ShapeDesc};
use std::path::{Path, PathBuf};

/// Most ambient-occlusion rays per shading point (`--insert-ao`): one shading point's rays run
/// inside one sample, where an interrupt cannot stop them (4294967295 ran for minutes).
pub const MAX_AO_RAYS: u32 = 4096;

/// Where an inserted object's light comes from with the `octree` integrator (`--insert-light`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum InsertLight {
    /// An incremental re-bake per frame: the object is part of the photon solution.
    #[default]
    Rebake,
    /// The baked volumetric values, read on the object; the scene's light stays as baked.
    Volume,
}

impl InsertLight {
    pub fn name(self) -> &'static str {
        match self {
            InsertLight::Rebake => "rebake",
            InsertLight::Volume => "volume",
        }
    }
}

/// An object to insert, read and checked.
pub struct Insertion {
    /// Where its light comes from with the `octree` integrator.
    pub light: InsertLight,
    /// As named on the command line.
    pub file: String,
    shapes: Vec<ShapeDesc>,
    materials: Vec<Material>,
    /// The motion; none: the object as loaded.
    pub path: Option<ObjectPath>,
    /// Rays of the ambient-occlusion correction (0: none).
    ao_rays: u32,
    /// Their length; none: the object's bounding-box diagonal at each frame.
    ao_distance: Option<f32>,
}

/// Read an object path file (JSON), validated, every frame included (`crate::paths`);
/// errors name the file.
pub fn read_object_path(path: &Path) -> Result<ObjectPath> {
    crate::paths::read_object_path(path).map_err(|e| super::JobError(format!("object path {e}")))
}

/// An object to insert, as a front end names it.
#[derive(Clone, Debug, Default)]
pub struct InsertRequest {
    /// OBJ, PLY, or a Mitsuba XML file whose shapes are inserted.
    pub file: String,
    /// Its motion: JSON keyframes (`--insert-path`).
    pub path: Option<PathBuf>,
    /// Ambient-occlusion rays per shading point (`--insert-ao`; none: 0).
    pub ao: Option<u32>,
    /// Their length (`--insert-ao-distance`; none: the object's bounding-box diagonal).
    pub ao_distance: Option<f32>,
    /// Where its light comes from (`--insert-light`).
    pub light: InsertLight,
}

/// The insertion `args` ask for, read and checked before any long work.
pub fn read(args: &InsertRequest, fe: &dyn Frontend) -> Result<Insertion> {
    let file = &args.file;
    let path = args.path.as_deref().map(read_object_path).transpose()?;
    if let Some(n) = args.ao.filter(|&n| n > MAX_AO_RAYS) {
        bail!("--insert-ao {n}: at most {MAX_AO_RAYS} rays per shading point");
    }
    if let Some(d) = args.ao_distance {
        if !(d.is_finite() && d > 0.0) {
            bail!("--insert-ao-distance must be a positive length, got {d}");
        }
    }
    if args.light == InsertLight::Rebake && (args.ao.is_some_and(|n| n > 0) || args.ao_distance.is_some()) {
        bail!(
            "--insert-ao corrects the baked light around the object with --insert-light volume; the default re-bake \
             casts the object's shadow itself (add --insert-light volume, or leave out --insert-ao)"
        );
    }
    let loaded = crate::load_scene(file, &[]).with_context(|| format!("cannot load the object to insert '{file}'"))?;
    for w in &loaded.warnings {
        fe.warning(&format!("{file}: {w}"));
    }
    let d = loaded.desc;
    if d.shapes.is_empty() {
        bail!("--insert {file}: the file holds no shape");
    }
    if let Some(s) = d.shapes.iter().find(|s| s.emission.is_some()) {
        bail!("--insert {file}: shape '{}' emits light, which the baked lighting does not hold; insert objects that do not emit", s.name);
    }
    if !d.images.is_empty() {
        bail!("--insert {file}: textured materials are not supported for inserted objects (the object has {} images)", d.images.len());
    }
    // a bare mesh has no light of its own: the loader lights it with a sky (`mesh`), not the file
    let mesh = Path::new(file)
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("obj") || e.eq_ignore_ascii_case("ply"));
    match if mesh { 0 } else { d.lights.len() } {
        0 => {}
        1 => fe.note(&format!("--insert {file}: its light is ignored (only its shapes are inserted)")),
        n => fe.note(&format!("--insert {file}: its {n} lights are ignored (only its shapes are inserted)")),
    }
    Ok(Insertion {
        light: args.light,
        file: file.clone(),
        shapes: d.shapes,
        materials: d.materials,
        path,
        ao_rays: args.ao.unwrap_or(0),
        ao_distance: args.ao_distance,
    })
}

impl Insertion {
    /// The object's transform at a time (none: the path's first key, or the object as loaded).
    pub fn transform_at(&self, time_s: Option<f64>) -> Mat4 {
        match &self.path {
            Some(p) => p.transform_at(time_s.unwrap_or_else(|| p.frame_time(1))),
            None => Mat4::IDENTITY,
        }
    }

    /// The object's shapes moved by `m`, their material indices counted from the first of
    /// `first_material` materials before the object's ([`Insertion::materials`] follow them).
    pub fn placed_shapes(&self, first_material: u32, m: &Mat4) -> Vec<ShapeDesc> {
        let scale =
            m.transform_vector3(Vec3::X).length().max(m.transform_vector3(Vec3::Y).length()).max(m.transform_vector3(Vec3::Z).length());
        let place = |s: &ShapeDesc| {
            let mut s = s.clone();
            s.material += first_material;
            s.name = format!("inserted {}", s.name);
            s.geometry = match s.geometry {
                Geometry::Mesh(mut mesh) => {
                    mesh.transform(m);
                    Geometry::Mesh(mesh)
                }
                Geometry::Sphere { center, radius } => Geometry::Sphere { center: m.transform_point3(center), radius: radius * scale },
            };
            s
        };
        self.shapes.iter().map(place).collect()
    }

    /// The object's materials.
    pub fn materials(&self) -> &[Material] {
        &self.materials
    }

    /// What the `octree` integrator needs to know of the object in a scene made of a base of
    /// `base_shapes` shapes and [`Insertion::placed_shapes`] after them.
    pub fn inserted(&self, base_shapes: usize, m: &Mat4) -> Inserted {
        let first = base_shapes as u32;
        let ao =
            (self.ao_rays > 0).then(|| InsertAo { rays: self.ao_rays, distance: self.ao_distance.unwrap_or_else(|| self.diagonal(m)) });
        Inserted { shapes: first..first + self.shapes.len() as u32, ao }
    }

    /// The object's bounding box, moved by `m`.
    pub fn bounds(&self, m: &Mat4) -> Bounds3 {
        let mut b = Bounds3::EMPTY;
        for s in &self.shapes {
            match &s.geometry {
                Geometry::Mesh(mesh) => mesh.positions.iter().for_each(|p| b.extend(m.transform_point3(*p))),
                Geometry::Sphere { center, radius } => {
                    let c = m.transform_point3(*center);
                    let r = *radius * m.transform_vector3(Vec3::X).length();
                    b.extend(c - Vec3::splat(r));
                    b.extend(c + Vec3::splat(r));
                }
            }
        }
        b
    }

    /// Diagonal of the object's bounding box, moved by `m`.
    fn diagonal(&self, m: &Mat4) -> f32 {
        let b = self.bounds(m);
        let d = (b.max - b.min).length();
        if d.is_finite() && d > 0.0 {
            d
        } else {
            1.0
        }
    }
}

/// The re-bake of an inserted object over the frames (`--insert-light rebake`): the photon
/// pass kept path by path with the leaves' sums, and where the object was in the last frame.
pub struct Rebaking {
    state: RebakeState,
    last: Option<Bounds3>,
}

impl Rebaking {
    /// Trace the photon pass of `o` again in `scene` (the baked one, without the object).
    pub fn start(o: &OctreeIntegrator, scene: &Scene, ins: &Insertion, fe: &dyn Frontend) -> Result<Rebaking> {
        let t = std::time::Instant::now();
        let paths = o.photon_paths(scene).with_context(|| format!("--insert {}: the photon pass to re-bake", ins.file))?;
        fe.info(&format!(
            "octree: {} photon paths kept for --insert {} ({} flight points) in {:.3} s",
            paths.len(),
            ins.file,
            paths.flight_points(),
            t.elapsed().as_secs_f64()
        ));
        Ok(Rebaking { state: RebakeState::new(paths), last: None })
    }

    /// Update `o` for `scene`, the baked scene with the object moved by `m` (its shapes
    /// `shapes`).
    pub fn frame(
        &mut self,
        o: &mut OctreeIntegrator,
        scene: &Scene,
        ins: &Insertion,
        m: &Mat4,
        shapes: std::ops::Range<u32>,
        fe: &dyn Frontend,
    ) -> Result<RebakeStats> {
        let now = [ins.bounds(m)];
        let was: Vec<Bounds3> = self.last.iter().copied().collect();
        let change = ObjectMove { was: &was, now: &now, shapes };
        let st = o.rebake(&mut self.state, scene, &change).with_context(|| format!("--insert {}: the re-bake", ins.file))?;
        fe.info(&format!(
            "octree: re-bake for --insert {}: {} of {} photon paths traced again, {} photons moved, {} leaves estimated, {} updated ({} kept) in {:.3} s",
            ins.file, st.paths_retraced, st.paths, st.photons_moved, st.leaves_estimated, st.leaves_updated, st.leaves_copied, st.t_s
        ));
        self.last = Some(now[0]);
        Ok(st)
    }
}

/// What `OUT.json` says of the inserted object in a frame: the file, the transform (4x4,
/// column-major) and the pixels (`y * width + x`) whose centre's camera ray first meets it,
/// so that errors can be measured on the object's pixels; with `--insert-light rebake` what the
/// frame's re-bake did (paths traced again, leaves estimated, seconds).
pub fn report(ins: &Insertion, scene: &Scene, m: &Mat4, shapes: &std::ops::Range<u32>, rebake: Option<&RebakeStats>) -> serde_json::Value {
    let (w, h) = (scene.film.width, scene.film.height);
    let pixels: Vec<u32> = (0..w * h)
        .filter(|&i| {
            let (o, d, tmin) = scene.camera.generate_ray(glam::Vec2::new((i % w) as f32 + 0.5, (i / w) as f32 + 0.5));
            let mut ray = Ray::new(o, d);
            ray.tmin = tmin;
            scene.intersect(&ray).is_some_and(|hit| shapes.contains(&hit.shape))
        })
        .collect();
    serde_json::json!({ "file": ins.file, "light": ins.light.name(), "transform": m.to_cols_array(), "pixels": pixels, "rebake": rebake })
}
