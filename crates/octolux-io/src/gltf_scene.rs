//! glTF 2.0 scenes (`.gltf` with its buffers and images, or `.glb`; issue 15, item 3), read
//! with the `gltf` crate, which validates the document.
//!
//! What is read, and how it maps onto octolux:
//! - the default scene (else the first), its node tree with every node's transform;
//! - mesh primitives in `TRIANGLES` mode: positions, normals, first texture coordinates,
//!   indices (a transform that mirrors reverses the winding, as the specification says);
//!   other modes are skipped with a warning; glTF's texture origin is the image's top left,
//!   so v becomes 1 − v (Mitsuba's and octolux's origin is the bottom left);
//! - metallic-roughness materials. glTF's BRDF is a GGX microfacet model (alpha = roughness²)
//!   that blends, by `metallic`, a dielectric (IOR 1.5: a specular coat over the base colour
//!   as diffuse) and a metal whose reflectance is the base colour. octolux renders it as
//!   `roughplastic` (GGX, IOR 1.5, base colour (texture) as diffuse reflectance) for
//!   metallic 0, `roughconductor` with a perfect mirror tinted by the base colour for
//!   metallic 1, and a `blendbsdf` of the two in between; every material is two-sided (as
//!   Blender and most viewers shade it). The base-colour texture is read; metallic-roughness,
//!   normal, occlusion and emissive textures are replaced by their factors, with a warning;
//! - emissive materials (`emissiveFactor` × `KHR_materials_emissive_strength`) make their
//!   primitives area lights of that radiance (W/(m² sr), front side);
//! - cameras: the first perspective camera in the node tree is the scene's camera (`yfov`
//!   along the vertical axis; glTF cameras look down −z with +y up), every perspective camera
//!   is a sensor for `--sensors`; the film is 640 pixels wide with the first camera's aspect
//!   ratio (else 640×480);
//! - `KHR_lights_punctual`: photometric units converted at 683 lm/W — point and spot lights'
//!   candela become W/sr (intensity / 683), a directional light's lux W/m²; spot cones from
//!   `innerConeAngle` / `outerConeAngle`; `range` is ignored (physical falloff), with a warning.
//!
//! A scene without any light gets none: octolux warns that it renders black.

use crate::{IoError, LoadedScene};
use glam::{Mat4, Vec2, Vec3};
use octolux::math::{Color, Frame};
use octolux::scene::camera::{CameraDesc, FovAxis};
use octolux::scene::material::microfacet::{Microfacet, MicrofacetKind, Roughness};
use octolux::scene::material::{Material, Texture};
use octolux::scene::{FilmDesc, Geometry, Light, SceneDesc, ShapeDesc, TriMesh};
use std::collections::HashMap;
use std::path::Path;

/// Width of the film of a glTF scene (its height follows the camera's aspect ratio).
pub const FILM_WIDTH: u32 = 640;
/// Photometric to radiometric units at 555 nm (lm/W).
const LUMENS_PER_WATT: f32 = 683.0;
/// glTF's dielectric index of refraction (F0 = 0.04).
const IOR: f32 = 1.5;

struct Loader<'a> {
    path: &'a Path,
    buffers: Vec<gltf::buffer::Data>,
    desc: SceneDesc,
    warnings: Vec<String>,
    /// glTF material index (None: the default material) -> octolux material and emission.
    materials: HashMap<Option<usize>, (u32, Option<Color>)>,
    /// glTF image index -> octolux image index.
    images: HashMap<usize, u32>,
    cameras: Vec<(CameraDesc, Option<f32>)>,
}

/// Load a `.gltf` or `.glb` scene.
pub fn load(path: &Path) -> Result<LoadedScene, IoError> {
    let bytes = std::fs::read(path).map_err(|e| IoError::os(path, e))?;
    octolux::budget::check_items(|| format!("a glTF file of {} bytes", bytes.len()), bytes.len() as u64, 4)
        .map_err(|e| IoError::invalid(path, e.to_string()))?;
    let gltf = gltf::Gltf::from_slice(&bytes).map_err(|e| IoError::invalid(path, format!("not a valid glTF 2.0 file: {e}")))?;
    let base = path.parent().unwrap_or(Path::new("."));
    let buffers = gltf::import_buffers(&gltf.document, Some(base), gltf.blob.clone())
        .map_err(|e| IoError::invalid(path, format!("cannot read the glTF buffers: {e}")))?;
    let mut l = Loader {
        path,
        buffers,
        desc: SceneDesc::default(),
        warnings: Vec::new(),
        materials: HashMap::new(),
        images: HashMap::new(),
        cameras: Vec::new(),
    };
    let doc = &gltf.document;
    let scene = doc.default_scene().or_else(|| doc.scenes().next()).ok_or_else(|| IoError::invalid(path, "the glTF file has no scene"))?;
    let mut stack: Vec<(gltf::Node, Mat4)> = scene.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
    stack.reverse();
    let mut visited = 0usize;
    while let Some((node, parent)) = stack.pop() {
        visited += 1;
        if visited > 1_000_000 {
            return Err(IoError::invalid(path, "the glTF node tree has more than a million nodes"));
        }
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        if !world.is_finite() {
            l.warnings.push(format!("{}: node {} has a non-finite transform; skipped", path.display(), node.index()));
            continue;
        }
        if let Some(mesh) = node.mesh() {
            l.mesh(&mesh, &world)?;
        }
        if let Some(cam) = node.camera() {
            l.camera(&cam, &world);
        }
        if let Some(light) = node.light() {
            l.light(&light, &world);
        }
        let children: Vec<_> = node.children().map(|c| (c, world)).collect();
        stack.extend(children.into_iter().rev());
    }
    let Loader { mut desc, warnings, cameras, .. } = l;
    let aspect = cameras.first().and_then(|c| c.1);
    desc.film = FilmDesc {
        width: FILM_WIDTH,
        height: aspect.map_or(480, |a| ((FILM_WIDTH as f32 / a).round() as u32).max(1)),
        ..FilmDesc::default()
    };
    let sensors: Vec<CameraDesc> = cameras.into_iter().map(|c| c.0).collect();
    desc.camera = match sensors.first() {
        Some(c) => c.clone(),
        None => crate::mesh::framing_camera(desc.bounds()),
    };
    Ok(LoadedScene { desc, warnings, sensors, notes: Vec::new() })
}

impl Loader<'_> {
    fn warn(&mut self, msg: String) {
        let line = format!("{}: {msg}", self.path.display());
        if !self.warnings.contains(&line) {
            self.warnings.push(line);
        }
    }

    fn mesh(&mut self, mesh: &gltf::Mesh, world: &Mat4) -> Result<(), IoError> {
        let name = mesh.name().map_or_else(|| format!("mesh {}", mesh.index()), String::from);
        for (k, prim) in mesh.primitives().enumerate() {
            if prim.mode() != gltf::mesh::Mode::Triangles {
                self.warn(format!("{name}: primitive {k} is drawn as {:?}, not triangles; skipped", prim.mode()));
                continue;
            }
            let buffers = &self.buffers;
            let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
            let Some(positions) = reader.read_positions() else {
                self.warn(format!("{name}: primitive {k} has no positions; skipped"));
                continue;
            };
            let positions: Vec<Vec3> = positions.map(Vec3::from).collect();
            let n = positions.len();
            let normals: Option<Vec<Vec3>> =
                reader.read_normals().map(|it| it.map(Vec3::from).collect()).filter(|v: &Vec<Vec3>| v.len() == n);
            let uvs: Option<Vec<Vec2>> = reader
                .read_tex_coords(0)
                .map(|t| t.into_f32().map(|[u, v]| Vec2::new(u, 1.0 - v)).collect())
                .filter(|v: &Vec<Vec2>| v.len() == n);
            let flat: Vec<u32> = match reader.read_indices() {
                Some(i) => i.into_u32().collect(),
                None => (0..n as u32).collect(),
            };
            if !flat.len().is_multiple_of(3) || flat.iter().any(|&i| i as usize >= n) {
                return Err(IoError::invalid(
                    self.path,
                    format!("{name}: primitive {k} has indices that are not triangles of its vertices"),
                ));
            }
            let mirror = world.determinant() < 0.0;
            let indices = flat.chunks_exact(3).map(|t| if mirror { [t[0], t[2], t[1]] } else { [t[0], t[1], t[2]] }).collect();
            let mut tri = TriMesh { positions, normals, uvs, indices };
            tri.transform(world);
            let (material, emission) = self.material(&prim.material())?;
            let shape_name = if mesh.primitives().len() > 1 { format!("{name}/{k}") } else { name.clone() };
            self.desc.shapes.push(ShapeDesc { name: shape_name, geometry: Geometry::Mesh(tri), material, emission, flip_normals: false });
        }
        Ok(())
    }

    fn material(&mut self, m: &gltf::Material) -> Result<(u32, Option<Color>), IoError> {
        if let Some(&v) = self.materials.get(&m.index()) {
            return Ok(v);
        }
        let name = m.name().map_or_else(|| m.index().map_or("the default material".into(), |i| format!("material {i}")), String::from);
        let pbr = m.pbr_metallic_roughness();
        let [r, g, b, _a] = pbr.base_color_factor();
        let factor = Color::new(r, g, b);
        let base = match pbr.base_color_texture() {
            Some(info) => {
                if info.tex_coord() != 0 {
                    self.warn(format!("{name}: base colour texture on uv set {}; octolux reads set 0", info.tex_coord()));
                }
                let image = self.image(&info.texture().source())?;
                if factor != Color::ONE {
                    self.warn(format!("{name}: base colour factor {factor} times a texture is rendered as the texture alone"));
                }
                Texture::bitmap(image, Vec2::ONE)
            }
            None => Texture::Const(factor),
        };
        for (what, present) in [
            ("metallic-roughness texture", pbr.metallic_roughness_texture().is_some()),
            ("normal texture", m.normal_texture().is_some()),
            ("occlusion texture", m.occlusion_texture().is_some()),
            ("emissive texture", m.emissive_texture().is_some()),
        ] {
            if present {
                self.warn(format!("{name}: the {what} is not read; its factors are used"));
            }
        }
        if m.alpha_mode() != gltf::material::AlphaMode::Opaque {
            self.warn(format!("{name}: alpha mode {:?} is rendered opaque", m.alpha_mode()));
        }
        let alpha = pbr.roughness_factor().clamp(0.0, 1.0).powi(2);
        let metallic = pbr.metallic_factor().clamp(0.0, 1.0);
        let ggx = Microfacet { kind: MicrofacetKind::Ggx, alpha_u: alpha, alpha_v: alpha };
        let dielectric = Material::RoughPlastic {
            diffuse_reflectance: base.clone(),
            specular_reflectance: Color::ONE,
            distribution: ggx,
            eta: IOR,
            nonlinear: false,
        };
        let tint = match &base {
            Texture::Const(c) => *c,
            _ if metallic > 0.0 => {
                self.warn(format!("{name}: a metal's textured base colour is rendered as its factor"));
                factor
            }
            _ => factor,
        };
        let metal =
            Material::RoughConductor { distribution: Roughness::from(ggx), eta: Color::ZERO, k: Color::ZERO, specular_reflectance: tint };
        let surface = if metallic <= 0.0 {
            dielectric
        } else if metallic >= 1.0 {
            metal
        } else {
            Material::Blend { weight: Texture::Const(Color::splat(metallic)), first: Box::new(dielectric), second: Box::new(metal) }
        };
        let material = Material::TwoSided { front: Box::new(surface.clone()), back: Box::new(surface) };
        let e = Color::from(m.emissive_factor()) * m.emissive_strength().unwrap_or(1.0);
        let emission = (e.max_element() > 0.0 && e.is_finite()).then_some(e);
        self.desc.materials.push(material);
        let v = ((self.desc.materials.len() - 1) as u32, emission);
        self.materials.insert(m.index(), v);
        Ok(v)
    }

    fn image(&mut self, img: &gltf::Image) -> Result<u32, IoError> {
        if let Some(&i) = self.images.get(&img.index()) {
            return Ok(i);
        }
        let decoded = match img.source() {
            gltf::image::Source::Uri { uri, .. } => {
                if uri.starts_with("data:") {
                    return Err(IoError::invalid(
                        self.path,
                        format!("image {}: data: URIs are not read; use a .glb or image files", img.index()),
                    ));
                }
                let file = self.path.parent().unwrap_or(Path::new(".")).join(percent_decode(uri));
                crate::image_io::read_image(&file)?
            }
            gltf::image::Source::View { view, mime_type } => {
                let buf = self.buffers.get(view.buffer().index()).map(|b| &b.0[..]).unwrap_or(&[]);
                let bytes = buf.get(view.offset()..view.offset() + view.length()).ok_or_else(|| {
                    IoError::invalid(self.path, format!("image {}: its buffer view lies outside the buffer", img.index()))
                })?;
                let ext = if mime_type == "image/jpeg" { "jpg" } else { "png" };
                let named = self.path.with_file_name(format!(
                    "{}#image{}.{ext}",
                    self.path.file_name().unwrap_or_default().to_string_lossy(),
                    img.index()
                ));
                crate::image_io::decode_image(&named, bytes)?
            }
        };
        self.desc.images.push(decoded);
        let i = (self.desc.images.len() - 1) as u32;
        self.images.insert(img.index(), i);
        Ok(i)
    }

    fn camera(&mut self, cam: &gltf::Camera, world: &Mat4) {
        match cam.projection() {
            gltf::camera::Projection::Perspective(p) => {
                // glTF looks down -z with +x right; octolux (Mitsuba) down +z with +x left
                let to_world = *world * Mat4::from_scale(Vec3::new(-1.0, 1.0, -1.0));
                let desc = CameraDesc { to_world, fov_deg: p.yfov().to_degrees(), fov_axis: FovAxis::Y, near_clip: p.znear().max(1e-4) };
                self.cameras.push((desc, p.aspect_ratio().filter(|a| a.is_finite() && *a > 0.0)));
            }
            gltf::camera::Projection::Orthographic(_) => {
                self.warn(format!("camera {}: orthographic cameras are not supported; skipped", cam.index()))
            }
        }
    }

    fn light(&mut self, light: &gltf::khr_lights_punctual::Light, world: &Mat4) {
        use gltf::khr_lights_punctual::Kind;
        let colour = Color::from(light.color()) * light.intensity() / LUMENS_PER_WATT;
        let position = world.transform_point3(Vec3::ZERO);
        let direction = world.transform_vector3(-Vec3::Z).normalize_or_zero();
        if light.range().is_some() {
            self.warn(format!("light {}: `range` is ignored (the falloff is physical)", light.index()));
        }
        let l = match light.kind() {
            Kind::Point => Light::Point { position, intensity: colour },
            Kind::Directional => Light::Directional { direction, irradiance: colour },
            Kind::Spot { inner_cone_angle, outer_cone_angle } => Light::Spot {
                position,
                frame: Frame::from_normal(direction),
                intensity: colour,
                cos_cutoff: outer_cone_angle.cos(),
                cos_falloff_start: inner_cone_angle.min(outer_cone_angle).cos(),
            },
        };
        match l.validate() {
            Ok(()) if direction != Vec3::ZERO => self.desc.lights.push(l),
            Ok(()) => self.warn(format!("light {}: its node's transform has no direction; skipped", light.index())),
            Err(e) => self.warn(format!("light {}: {e}; skipped", light.index())),
        }
    }
}

/// `%20` and the like in a relative URI.
fn percent_decode(uri: &str) -> String {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        if b[i] == b'%' && i + 2 < b.len() {
            if let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}
