//! Export a [`SceneDesc`] as a Mitsuba 3 scene (XML version 3.0.0), so that Mitsuba can render
//! the very scene octolux renders.
//!
//! What is written:
//! - a `perspective` sensor (`to_world` as a row-major matrix, `fov`, `fov_axis`, `near_clip`)
//!   with an `independent` sampler and an `hdrfilm` of the same size and `rfilter`;
//! - a `path` integrator with the given `max_depth`;
//! - every material as a top-level `<bsdf id="mat{i}">` in index order (so a reload keeps the
//!   indices), microfacet ones with `distribution="ggx"` spelled out (Mitsuba's default is
//!   Beckmann); a perfect mirror (`eta = k = 0`) as `material="none"`; IORs as `int_ior = eta`,
//!   `ext_ior = 1`; bitmaps as 32-bit float OpenEXR files next to the meshes;
//! - every shape: spheres as `sphere` with `center`/`radius`; meshes (already in world space) as
//!   binary little-endian PLY files with normals and uvs when present, referenced as
//!   `mesh_prefix + file name`; a mesh without normals gets `face_normals = true` (Mitsuba
//!   would otherwise smooth it); emission as a nested `area` emitter;
//! - every light (`point`, `spot`, `directional`, `constant`, `envmap` with its image as EXR, `sunsky`); an [`Light::Area`] entry becomes
//!   the emission of its shape.
//!
//! Numbers are written with Rust's shortest round-trip formatting, so reading the file back
//! gives the same `f32` values (up to the arithmetic of transforms).

use crate::IoError;
use glam::{Mat4, Vec2, Vec3};
use octolux::math::Color;
use octolux::scene::camera::FovAxis;
use octolux::scene::material::{Material, Microfacet, Roughness, TexFilter, Texture};
use octolux::scene::Light;
use octolux::scene::{Geometry, PixelFilter, SceneDesc, TriMesh};
use std::fmt::Write as _;
use std::path::Path;

fn rgb(c: Color) -> String {
    format!("{}, {}, {}", c.x, c.y, c.z)
}

fn v3(v: Vec3) -> String {
    format!("{}, {}, {}", v.x, v.y, v.z)
}

/// Row-major 16 values.
fn matrix(m: &Mat4) -> String {
    let r = m.transpose().to_cols_array();
    r.iter().map(|v| v.to_string()).collect::<Vec<_>>().join(" ")
}

/// XML-escape an attribute value.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;").replace('\'', "&apos;")
}

/// A file-name-safe version of a shape name.
fn sanitize(name: &str) -> String {
    let s: String = name.chars().map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' }).take(48).collect();
    if s.is_empty() {
        "mesh".into()
    } else {
        s
    }
}

/// Encode a triangle mesh as a binary little-endian PLY file.
pub fn ply_bytes(mesh: &TriMesh) -> Vec<u8> {
    let mut header = String::from("ply\nformat binary_little_endian 1.0\ncomment written by octolux\n");
    let _ = writeln!(header, "element vertex {}", mesh.positions.len());
    header.push_str("property float x\nproperty float y\nproperty float z\n");
    if mesh.normals.is_some() {
        header.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    if mesh.uvs.is_some() {
        header.push_str("property float u\nproperty float v\n");
    }
    let _ = writeln!(header, "element face {}", mesh.indices.len());
    header.push_str("property list uchar int vertex_indices\nend_header\n");
    let mut out = header.into_bytes();
    for (i, p) in mesh.positions.iter().enumerate() {
        for v in p.to_array() {
            out.extend_from_slice(&v.to_le_bytes());
        }
        if let Some(n) = &mesh.normals {
            for v in n[i].to_array() {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        if let Some(uv) = &mesh.uvs {
            for v in uv[i].to_array() {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    for t in &mesh.indices {
        out.push(3);
        for &i in t {
            out.extend_from_slice(&(i as i32).to_le_bytes());
        }
    }
    out
}

/// Writes the XML text; files (meshes, images) go to `mesh_dir`.
struct Writer<'a> {
    xml: String,
    mesh_dir: &'a Path,
    mesh_prefix: &'a str,
    desc: &'a SceneDesc,
}

impl Writer<'_> {
    fn line(&mut self, indent: usize, s: &str) {
        for _ in 0..indent {
            self.xml.push_str("    ");
        }
        self.xml.push_str(s);
        self.xml.push('\n');
    }

    fn write_file(&self, name: &str, bytes: &[u8]) -> Result<(), IoError> {
        let path = self.mesh_dir.join(name);
        crate::files::write_synced(&path, bytes).map_err(|e| IoError::os(&path, e))
    }

    /// A reflectance parameter: `<rgb>` or a bitmap texture (written as EXR once per image).
    fn texture(&mut self, indent: usize, name: &str, t: &Texture, written: &mut [bool]) -> Result<(), IoError> {
        match t {
            Texture::Const(c) => self.line(indent, &format!("<rgb name=\"{name}\" value=\"{}\"/>", rgb(*c))),
            Texture::Bitmap { image, uv_scale, filter } => {
                let img = self.desc.images.get(*image as usize).ok_or_else(|| {
                    IoError::invalid(
                        self.mesh_dir,
                        format!("a material uses image {image} but the scene has {} images", self.desc.images.len()),
                    )
                })?;
                let file = format!("texture_{image:03}.exr");
                if !written[*image as usize] {
                    crate::image_io::write_exr(&self.mesh_dir.join(&file), img)?;
                    written[*image as usize] = true;
                }
                self.line(indent, &format!("<texture type=\"bitmap\" name=\"{name}\">"));
                self.line(indent + 1, &format!("<string name=\"filename\" value=\"{}\"/>", esc(&format!("{}{file}", self.mesh_prefix))));
                // Mitsuba 3 has no trilinear filter: its bitmap is bilinear (the default) there.
                if *filter == TexFilter::Nearest {
                    self.line(indent + 1, "<string name=\"filter_type\" value=\"nearest\"/>");
                }
                if *uv_scale != Vec2::ONE {
                    self.line(indent + 1, "<transform name=\"to_uv\">");
                    self.line(indent + 2, &format!("<scale x=\"{}\" y=\"{}\"/>", uv_scale.x, uv_scale.y));
                    self.line(indent + 1, "</transform>");
                }
                self.line(indent, "</texture>");
            }
        }
        Ok(())
    }

    fn conductor_ior(&mut self, indent: usize, eta: Color, k: Color) {
        if eta == Color::ZERO && k == Color::ZERO {
            self.line(indent, "<string name=\"material\" value=\"none\"/>");
        } else {
            self.line(indent, &format!("<rgb name=\"eta\" value=\"{}\"/>", rgb(eta)));
            self.line(indent, &format!("<rgb name=\"k\" value=\"{}\"/>", rgb(k)));
        }
    }

    /// A microfacet distribution's `distribution` and `alpha` (or `alpha_u`, `alpha_v`).
    fn distribution(&mut self, indent: usize, d: &Microfacet) {
        self.line(indent, &format!("<string name=\"distribution\" value=\"{}\"/>", d.kind.name()));
        if d.is_isotropic() {
            self.line(indent, &format!("<float name=\"alpha\" value=\"{}\"/>", d.alpha_u));
        } else {
            self.line(indent, &format!("<float name=\"alpha_u\" value=\"{}\"/>", d.alpha_u));
            self.line(indent, &format!("<float name=\"alpha_v\" value=\"{}\"/>", d.alpha_v));
        }
    }

    /// A possibly textured roughness: as [`Self::distribution`] when constant, else the
    /// distribution's name and the alpha textures.
    fn roughness(&mut self, indent: usize, r: &Roughness, written: &mut [bool]) -> Result<(), IoError> {
        if let Some(d) = r.constant() {
            self.distribution(indent, &d);
            return Ok(());
        }
        self.line(indent, &format!("<string name=\"distribution\" value=\"{}\"/>", r.kind.name()));
        if r.is_isotropic() {
            self.texture(indent, "alpha", &r.alpha_u, written)
        } else {
            self.texture(indent, "alpha_u", &r.alpha_u, written)?;
            self.texture(indent, "alpha_v", &r.alpha_v, written)
        }
    }

    fn bsdf(&mut self, indent: usize, m: &Material, id: Option<&str>, written: &mut [bool]) -> Result<(), IoError> {
        let id_attr = id.map(|i| format!(" id=\"{}\"", esc(i))).unwrap_or_default();
        let open = |ty: &str| format!("<bsdf type=\"{ty}\"{id_attr}>");
        match m {
            Material::Diffuse { reflectance } => {
                self.line(indent, &open("diffuse"));
                self.texture(indent + 1, "reflectance", reflectance, written)?;
            }
            Material::Conductor { eta, k, specular_reflectance } => {
                self.line(indent, &open("conductor"));
                self.conductor_ior(indent + 1, *eta, *k);
                self.line(indent + 1, &format!("<rgb name=\"specular_reflectance\" value=\"{}\"/>", rgb(*specular_reflectance)));
            }
            Material::RoughConductor { distribution, eta, k, specular_reflectance } => {
                self.line(indent, &open("roughconductor"));
                self.roughness(indent + 1, distribution, written)?;
                self.conductor_ior(indent + 1, *eta, *k);
                self.line(indent + 1, &format!("<rgb name=\"specular_reflectance\" value=\"{}\"/>", rgb(*specular_reflectance)));
            }
            Material::RoughDielectric { distribution, eta, specular_reflectance, specular_transmittance } => {
                self.line(indent, &open("roughdielectric"));
                self.roughness(indent + 1, distribution, written)?;
                self.line(indent + 1, &format!("<float name=\"int_ior\" value=\"{eta}\"/>"));
                self.line(indent + 1, "<float name=\"ext_ior\" value=\"1\"/>");
                self.line(indent + 1, &format!("<rgb name=\"specular_reflectance\" value=\"{}\"/>", rgb(*specular_reflectance)));
                self.line(indent + 1, &format!("<rgb name=\"specular_transmittance\" value=\"{}\"/>", rgb(*specular_transmittance)));
            }
            Material::Plastic { diffuse_reflectance, specular_reflectance, eta, nonlinear } => {
                self.line(indent, &open("plastic"));
                self.line(indent + 1, &format!("<float name=\"int_ior\" value=\"{eta}\"/>"));
                self.line(indent + 1, "<float name=\"ext_ior\" value=\"1\"/>");
                self.line(indent + 1, &format!("<boolean name=\"nonlinear\" value=\"{nonlinear}\"/>"));
                self.texture(indent + 1, "diffuse_reflectance", diffuse_reflectance, written)?;
                self.line(indent + 1, &format!("<rgb name=\"specular_reflectance\" value=\"{}\"/>", rgb(*specular_reflectance)));
            }
            Material::Ward { .. } | Material::Phong { .. } => {
                let name = if matches!(m, Material::Ward { .. }) { "ward" } else { "phong" };
                return Err(IoError::invalid(
                    self.mesh_dir,
                    format!("Mitsuba 3 has no \"{name}\" bsdf (a Mitsuba 0.6 plugin); the scene cannot be exported as it is"),
                ));
            }
            Material::Dielectric { eta, specular_reflectance, specular_transmittance }
            | Material::ThinDielectric { eta, specular_reflectance, specular_transmittance } => {
                let ty = if matches!(m, Material::Dielectric { .. }) { "dielectric" } else { "thindielectric" };
                self.line(indent, &open(ty));
                self.line(indent + 1, &format!("<float name=\"int_ior\" value=\"{eta}\"/>"));
                self.line(indent + 1, "<float name=\"ext_ior\" value=\"1\"/>");
                self.line(indent + 1, &format!("<rgb name=\"specular_reflectance\" value=\"{}\"/>", rgb(*specular_reflectance)));
                self.line(indent + 1, &format!("<rgb name=\"specular_transmittance\" value=\"{}\"/>", rgb(*specular_transmittance)));
            }
            Material::RoughPlastic { diffuse_reflectance, specular_reflectance, distribution, eta, nonlinear } => {
                self.line(indent, &open("roughplastic"));
                self.distribution(indent + 1, distribution);
                self.line(indent + 1, &format!("<float name=\"int_ior\" value=\"{eta}\"/>"));
                self.line(indent + 1, "<float name=\"ext_ior\" value=\"1\"/>");
                self.line(indent + 1, &format!("<boolean name=\"nonlinear\" value=\"{nonlinear}\"/>"));
                self.texture(indent + 1, "diffuse_reflectance", diffuse_reflectance, written)?;
                self.line(indent + 1, &format!("<rgb name=\"specular_reflectance\" value=\"{}\"/>", rgb(*specular_reflectance)));
            }
            Material::Blend { weight, first, second } => {
                self.line(indent, &open("blendbsdf"));
                match weight {
                    Texture::Const(c) if c.x == c.y && c.y == c.z => {
                        self.line(indent + 1, &format!("<float name=\"weight\" value=\"{}\"/>", c.x))
                    }
                    _ => self.texture(indent + 1, "weight", weight, written)?,
                }
                self.bsdf(indent + 1, first, None, written)?;
                self.bsdf(indent + 1, second, None, written)?;
            }
            Material::Mask { opacity, nested } => {
                self.line(indent, &open("mask"));
                self.texture(indent + 1, "opacity", opacity, written)?;
                self.bsdf(indent + 1, nested, None, written)?;
            }
            // A constant height has no gradient: the nested bsdf alone is the same material.
            Material::BumpMap { height: Texture::Const(_), nested, .. } => return self.bsdf(indent, nested, id, written),
            Material::BumpMap { height, scale, nested } => {
                self.line(indent, &open("bumpmap"));
                self.texture(indent + 1, "height", height, written)?;
                self.line(indent + 1, &format!("<float name=\"scale\" value=\"{scale}\"/>"));
                self.bsdf(indent + 1, nested, None, written)?;
            }
            Material::NormalMap { normals, nested } => {
                self.line(indent, &open("normalmap"));
                self.texture(indent + 1, "normalmap", normals, written)?;
                self.bsdf(indent + 1, nested, None, written)?;
            }
            Material::TwoSided { front, back } => {
                self.line(indent, &open("twosided"));
                self.bsdf(indent + 1, front, None, written)?;
                if front != back {
                    self.bsdf(indent + 1, back, None, written)?;
                }
            }
        }
        self.line(indent, "</bsdf>");
        Ok(())
    }
}

/// The Mitsuba 3 XML text describing `desc`; meshes and textures are written into `mesh_dir`
/// (which must exist) and referenced as `mesh_prefix + file name`.
pub fn to_mitsuba_xml(desc: &SceneDesc, spp: u32, max_depth: i32, mesh_dir: &Path, mesh_prefix: &str) -> Result<String, IoError> {
    if !mesh_dir.is_dir() {
        return Err(IoError::invalid(mesh_dir, "the mesh folder does not exist"));
    }
    let mut w = Writer { xml: String::new(), mesh_dir, mesh_prefix, desc };
    w.line(0, "<?xml version=\"1.0\" encoding=\"utf-8\"?>");
    w.line(0, "<!-- Written by octolux: the scene octolux renders, for Mitsuba 3 (scalar_rgb). -->");
    w.line(0, "<scene version=\"3.0.0\">");

    w.line(1, "<integrator type=\"path\">");
    w.line(2, &format!("<integer name=\"max_depth\" value=\"{max_depth}\"/>"));
    w.line(1, "</integrator>");

    let cam = &desc.camera;
    let axis = match cam.fov_axis {
        FovAxis::X => "x",
        FovAxis::Y => "y",
        FovAxis::Diagonal => "diagonal",
        FovAxis::Smaller => "smaller",
        FovAxis::Larger => "larger",
    };
    w.line(1, "<sensor type=\"perspective\">");
    w.line(2, &format!("<float name=\"fov\" value=\"{}\"/>", cam.fov_deg));
    w.line(2, &format!("<string name=\"fov_axis\" value=\"{axis}\"/>"));
    // Mitsuba requires near_clip > 0.
    let near = if cam.near_clip > 0.0 { cam.near_clip } else { 1e-6 };
    w.line(2, &format!("<float name=\"near_clip\" value=\"{near}\"/>"));
    w.line(2, "<transform name=\"to_world\">");
    w.line(3, &format!("<matrix value=\"{}\"/>", matrix(&cam.to_world)));
    w.line(2, "</transform>");
    w.line(2, "<sampler type=\"independent\">");
    w.line(3, &format!("<integer name=\"sample_count\" value=\"{spp}\"/>"));
    w.line(2, "</sampler>");
    w.line(2, "<film type=\"hdrfilm\">");
    w.line(3, &format!("<integer name=\"width\" value=\"{}\"/>", desc.film.width));
    w.line(3, &format!("<integer name=\"height\" value=\"{}\"/>", desc.film.height));
    if desc.film.sample_border {
        w.line(3, "<boolean name=\"sample_border\" value=\"true\"/>");
    }
    w.line(3, "<string name=\"pixel_format\" value=\"rgb\"/>");
    match desc.film.filter {
        PixelFilter::Box => w.line(3, "<rfilter type=\"box\"/>"),
        PixelFilter::Tent => w.line(3, "<rfilter type=\"tent\"/>"),
        PixelFilter::Gaussian { stddev } => {
            w.line(3, "<rfilter type=\"gaussian\">");
            w.line(4, &format!("<float name=\"stddev\" value=\"{stddev}\"/>"));
            w.line(3, "</rfilter>");
        }
    }
    w.line(2, "</film>");
    w.line(1, "</sensor>");

    let mut written = vec![false; desc.images.len()];
    for (i, m) in desc.materials.iter().enumerate() {
        w.bsdf(1, m, Some(&format!("mat{i}")), &mut written)?;
    }

    // Area lights listed as lights become the emission of their shape.
    let mut emission: Vec<Option<Color>> = desc.shapes.iter().map(|s| s.emission).collect();
    for l in &desc.lights {
        if let Light::Area { shape, radiance } = l {
            let slot = emission.get_mut(*shape as usize).ok_or_else(|| {
                IoError::invalid(mesh_dir, format!("an area light refers to shape {shape}, but the scene has {}", desc.shapes.len()))
            })?;
            *slot = Some(slot.unwrap_or(Color::ZERO) + *radiance);
        }
    }

    for (i, s) in desc.shapes.iter().enumerate() {
        if s.material as usize >= desc.materials.len() {
            return Err(IoError::invalid(
                mesh_dir,
                format!("shape '{}' uses material {} but the scene has {}", s.name, s.material, desc.materials.len()),
            ));
        }
        w.xml.push_str(&format!("    <!-- {} -->\n", esc(&s.name).replace("--", "- -")));
        match &s.geometry {
            Geometry::Sphere { center, radius } => {
                w.line(1, "<shape type=\"sphere\">");
                w.line(2, &format!("<point name=\"center\" value=\"{}\"/>", v3(*center)));
                w.line(2, &format!("<float name=\"radius\" value=\"{radius}\"/>"));
            }
            Geometry::Mesh(mesh) => {
                let file = format!("{i:04}_{}.ply", sanitize(&s.name));
                w.write_file(&file, &ply_bytes(mesh))?;
                w.line(1, "<shape type=\"ply\">");
                w.line(2, &format!("<string name=\"filename\" value=\"{}\"/>", esc(&format!("{mesh_prefix}{file}"))));
                if mesh.normals.is_none() {
                    w.line(2, "<boolean name=\"face_normals\" value=\"true\"/>");
                }
            }
        }
        if s.flip_normals {
            w.line(2, "<boolean name=\"flip_normals\" value=\"true\"/>");
        }
        w.line(2, &format!("<ref id=\"mat{}\"/>", s.material));
        if let Some(e) = emission[i] {
            w.line(2, "<emitter type=\"area\">");
            w.line(3, &format!("<rgb name=\"radiance\" value=\"{}\"/>", rgb(e)));
            w.line(2, "</emitter>");
        }
        w.line(1, "</shape>");
    }

    for l in &desc.lights {
        match l {
            Light::Area { .. } => {}
            Light::Point { position, intensity } => {
                w.line(1, "<emitter type=\"point\">");
                w.line(2, &format!("<point name=\"position\" value=\"{}\"/>", v3(*position)));
                w.line(2, &format!("<rgb name=\"intensity\" value=\"{}\"/>", rgb(*intensity)));
                w.line(1, "</emitter>");
            }
            Light::Spot { position, frame, intensity, cos_cutoff, cos_falloff_start } => {
                let m = Mat4::from_cols(frame.s.extend(0.0), frame.t.extend(0.0), frame.n.extend(0.0), position.extend(1.0));
                w.line(1, "<emitter type=\"spot\">");
                w.line(2, "<transform name=\"to_world\">");
                w.line(3, &format!("<matrix value=\"{}\"/>", matrix(&m)));
                w.line(2, "</transform>");
                w.line(2, &format!("<rgb name=\"intensity\" value=\"{}\"/>", rgb(*intensity)));
                w.line(2, &format!("<float name=\"cutoff_angle\" value=\"{}\"/>", cos_cutoff.clamp(-1.0, 1.0).acos().to_degrees()));
                w.line(2, &format!("<float name=\"beam_width\" value=\"{}\"/>", cos_falloff_start.clamp(-1.0, 1.0).acos().to_degrees()));
                w.line(1, "</emitter>");
            }
            Light::Directional { direction, irradiance } => {
                w.line(1, "<emitter type=\"directional\">");
                w.line(2, &format!("<vector name=\"direction\" value=\"{}\"/>", v3(*direction)));
                w.line(2, &format!("<rgb name=\"irradiance\" value=\"{}\"/>", rgb(*irradiance)));
                w.line(1, "</emitter>");
            }
            Light::Constant { radiance } => {
                w.line(1, "<emitter type=\"constant\">");
                w.line(2, &format!("<rgb name=\"radiance\" value=\"{}\"/>", rgb(*radiance)));
                w.line(1, "</emitter>");
            }
            Light::Envmap { image, scale, to_world } => {
                let img = desc.images.get(*image as usize).ok_or_else(|| {
                    IoError::invalid(mesh_dir, format!("an envmap uses image {image} but the scene has {} images", desc.images.len()))
                })?;
                let file = format!("envmap_{image:03}.exr");
                crate::image_io::write_exr(&mesh_dir.join(&file), img)?;
                w.line(1, "<emitter type=\"envmap\">");
                w.line(2, &format!("<string name=\"filename\" value=\"{}\"/>", esc(&format!("{mesh_prefix}{file}"))));
                w.line(2, &format!("<float name=\"scale\" value=\"{scale}\"/>"));
                w.line(2, "<transform name=\"to_world\">");
                w.line(3, &format!("<matrix value=\"{}\"/>", matrix(&Mat4::from_mat3(*to_world))));
                w.line(2, "</transform>");
                w.line(1, "</emitter>");
            }
            Light::Sunsky(d) => {
                w.line(1, "<emitter type=\"sunsky\">");
                w.line(2, &format!("<vector name=\"sun_direction\" value=\"{}\"/>", v3(d.sun_direction)));
                w.line(2, &format!("<float name=\"turbidity\" value=\"{}\"/>", d.turbidity));
                w.line(2, &format!("<rgb name=\"albedo\" value=\"{}\"/>", rgb(d.albedo)));
                w.line(2, &format!("<float name=\"sun_scale\" value=\"{}\"/>", d.sun_scale));
                w.line(2, &format!("<float name=\"sky_scale\" value=\"{}\"/>", d.sky_scale));
                w.line(2, &format!("<float name=\"sun_aperture\" value=\"{}\"/>", d.sun_aperture_deg));
                w.line(2, "<transform name=\"to_world\">");
                w.line(3, &format!("<matrix value=\"{}\"/>", matrix(&Mat4::from_mat3(d.to_world))));
                w.line(2, "</transform>");
                w.line(1, "</emitter>");
            }
        }
    }
    w.line(0, "</scene>");
    Ok(w.xml)
}

/// Write `desc` as a Mitsuba 3 scene at `xml_path`, with its meshes and textures in a
/// `meshes/` folder beside it, by the rule of [`crate::files`]: the XML path and the folder are
/// checked first; every file is written into a staged folder and a staged XML, and only when
/// all are complete are they renamed into place (the staged folder becomes `meshes/` when there
/// is none, else its files replace those of the same name there, each checked again first:
/// never an input of this run, never anything but a regular file), the XML last. Any failure
/// (a full disk) removes what was staged and leaves the previous files untouched.
pub fn write_mitsuba_scene(desc: &SceneDesc, spp: u32, max_depth: i32, xml_path: &Path) -> Result<(), IoError> {
    use crate::files;
    files::check_output(xml_path).map_err(IoError::Output)?;
    let mesh_dir = files::folder_of(xml_path).join("meshes");
    check_mesh_dir(&mesh_dir)?;
    let staged_dir = files::staging_name(&mesh_dir, "staged");
    let staged_xml = files::staging_name(xml_path, "staged");
    files::note_staged(&staged_dir);
    files::note_staged(&staged_xml);
    let result = std::fs::create_dir(&staged_dir)
        .map_err(|e| IoError::os(&staged_dir, e))
        .and_then(|()| to_mitsuba_xml(desc, spp, max_depth, &staged_dir, "meshes/"))
        .and_then(|xml| files::write_synced(&staged_xml, xml.as_bytes()).map_err(|e| IoError::os(xml_path, e)))
        .and_then(|()| commit_mesh_dir(&staged_dir, &mesh_dir))
        .and_then(|()| files::commit(&staged_xml, xml_path).map_err(IoError::Output));
    let _ = std::fs::remove_dir_all(&staged_dir);
    let _ = std::fs::remove_file(&staged_xml);
    files::forget_staged(&staged_dir);
    files::forget_staged(&staged_xml);
    result
}

/// `meshes/` beside the XML: absent, or a folder (a link to one counts).
fn check_mesh_dir(mesh_dir: &Path) -> Result<(), IoError> {
    match std::fs::metadata(mesh_dir) {
        Ok(m) if m.is_dir() => Ok(()),
        Ok(m) => Err(IoError::Output(format!(
            "'{}' is {}: the exported meshes go into a folder of that name",
            mesh_dir.display(),
            crate::files::kind_of(&m.file_type())
        ))),
        Err(_) if std::fs::symlink_metadata(mesh_dir).is_ok() => {
            Err(IoError::Output(format!("'{}' is a dangling link: the exported meshes go into a folder of that name", mesh_dir.display())))
        }
        Err(_) => Ok(()),
    }
}

/// Move the complete staged folder's files into `mesh_dir` (module docs of
/// [`write_mitsuba_scene`]): every target is checked before the first rename.
fn commit_mesh_dir(staged_dir: &Path, mesh_dir: &Path) -> Result<(), IoError> {
    let mut names: Vec<std::ffi::OsString> = std::fs::read_dir(staged_dir)
        .and_then(|d| d.map(|e| e.map(|e| e.file_name())).collect())
        .map_err(|e| IoError::os(staged_dir, e))?;
    names.sort();
    if names.is_empty() {
        return Ok(());
    }
    check_mesh_dir(mesh_dir)?;
    if std::fs::symlink_metadata(mesh_dir).is_err() {
        return std::fs::rename(staged_dir, mesh_dir).map_err(|e| IoError::os(mesh_dir, e));
    }
    for n in &names {
        crate::files::recheck_output(&mesh_dir.join(n)).map_err(IoError::Output)?;
    }
    for n in &names {
        crate::files::commit(&staged_dir.join(n), &mesh_dir.join(n)).map_err(IoError::Output)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ply_layout_is_binary_little_endian() {
        let mesh =
            TriMesh { positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y], normals: Some(vec![Vec3::Z; 3]), uvs: None, indices: vec![[0, 1, 2]] };
        let bytes = ply_bytes(&mesh);
        let text = String::from_utf8_lossy(&bytes);
        let header_end = text.find("end_header\n").unwrap() + "end_header\n".len();
        assert!(text.starts_with("ply\nformat binary_little_endian 1.0\n"));
        assert!(text[..header_end].contains("property float nz\n") && !text[..header_end].contains("property float u\n"));
        // 3 vertices x 6 floats + 1 face (1 byte count + 3 ints).
        assert_eq!(bytes.len() - header_end, 3 * 6 * 4 + 1 + 12);
        let x1 = f32::from_le_bytes(bytes[header_end + 24..header_end + 28].try_into().unwrap());
        assert_eq!(x1, 1.0, "second vertex x");
        assert_eq!(bytes[header_end + 72], 3);
    }

    #[test]
    fn matrices_are_written_row_major() {
        let m = Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(matrix(&m), "1 0 0 1 0 1 0 2 0 0 1 3 0 0 0 1");
    }
}
