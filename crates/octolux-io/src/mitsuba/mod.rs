//! Mitsuba XML scene loader: Mitsuba 3 syntax and the 0.5/0.6 dialect of most research scenes
//! (root `version` < 2.0.0, camelCase parameter names), producing a [`SceneDesc`].
//!
//! Stages: `tree` reads the file(s) and applies the scene-language directives (`$param`,
//! `<default>`, `<include>`, `<path>`, dialect upgrade); `props` gives typed, use-tracked
//! access to a plugin's parameters; this module turns plugins into octolux descriptions.
//!
//! Conventions and choices (each departure from Mitsuba is reported as one warning naming the
//! file, line and element; loading goes on):
//! - Defaults are Mitsuba 3's: film 768x576 with a Gaussian filter (stddev 0.5), sampler 4 spp,
//!   `near_clip` 0.01, focal length 50 mm when no `fov`, diffuse reflectance 0.5, dielectric
//!   `int_ior` bk7 / `ext_ior` air, plastic `int_ior` polypropylene, microfacet `alpha` 0.1,
//!   spot `cutoff_angle` 20° and `beam_width` 3/4 of it, emitter intensities 1.
//! - A shape without a bsdf gets Mitsuba's default `diffuse` (0.5). Top-level bsdfs are
//!   instantiated in document order, so material indices follow the file.
//! - `conductor` presets use Mitsuba 3's RGB eta/k values (module `spectra`); `"none"` (and the
//!   default) is a perfect mirror, stored as `eta = k = 0` (octolux's convention).
//! - Only the GGX microfacet distribution exists: `beckmann` (Mitsuba's default for
//!   `roughconductor` and `roughplastic`) is replaced by GGX with the same alpha, with a warning.
//!   Anisotropic roughness uses `sqrt(alpha_u alpha_v)`.
//! - `roughdielectric` falls back to the smooth `dielectric`; smooth `plastic` becomes
//!   `roughplastic` with GGX alpha 0.01 (octolux has no smooth-plastic model); `mask`,
//!   `bumpmap` and `normalmap` use their nested bsdf; `thinlens` is a pinhole camera.
//! - The sampler type is irrelevant (only `sample_count` is read); `ldrfilm` is read as
//!   `hdrfilm`; tone-mapping and output parameters are ignored with a warning.
//! - Geometry is transformed to world space here; spheres keep an analytic form when their
//!   `to_world` is a similarity (uniform scale, rotation, translation), else it is an error.

mod props;
pub(crate) mod spectra;
mod tree;

use crate::{IoError, LoadedScene};
use glam::{Mat4, Vec2, Vec3};
use octolux::camera::FovAxis;
use octolux::light::Light;
use octolux::material::{Material, Texture};
use octolux::math::{Color, Frame};
use octolux::scene::{FilmDesc, Geometry, PixelFilter, SceneDesc, ShapeDesc, TriMesh};
use props::{ColorKind, Props, Spec};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use tree::{resolve_file, Elem};

/// GGX roughness used for Mitsuba's smooth `plastic`.
pub const SMOOTH_PLASTIC_ALPHA: f32 = 0.01;

/// Load a Mitsuba XML scene. `defines` override `<default>` parameters (like `mitsuba -D`).
pub fn load(path: &Path, defines: &[(String, String)]) -> Result<LoadedScene, IoError> {
    let mut warnings = Vec::new();
    let tree = tree::read(path, defines, &mut warnings)?;
    build(&tree, path, warnings)
}

/// Load a scene from XML text; `path` names it in messages and anchors relative file names.
pub fn load_str(text: &str, path: &Path, defines: &[(String, String)]) -> Result<LoadedScene, IoError> {
    let mut warnings = Vec::new();
    let tree = tree::read_str(text, path, defines, &mut warnings)?;
    build(&tree, path, warnings)
}

fn build(tree: &tree::Tree, path: &Path, warnings: Vec<String>) -> Result<LoadedScene, IoError> {
    let mut ids = HashMap::new();
    let mut aliases = Vec::new();
    collect_ids(&tree.root, &mut ids, &mut aliases)?;
    for a in aliases {
        let from = a.req_attr("id")?;
        let to = a.req_attr("as")?;
        let target = *ids.get(from).ok_or_else(|| a.loc.error(format!("<alias>: reference to unknown id \"{from}\"")))?;
        if ids.insert(to.to_string(), target).is_some() {
            return Err(a.loc.error(format!("<alias>: id \"{to}\" is already used")));
        }
    }
    let mut b = Builder {
        ids,
        main_dir: path.parent().map(Path::to_path_buf).unwrap_or_default(),
        search_dirs: &tree.search_dirs,
        desc: SceneDesc::default(),
        warnings,
        materials: HashMap::new(),
        images: HashMap::new(),
        default_material: None,
    };
    b.scene(&tree.root)?;
    Ok(LoadedScene { desc: b.desc, warnings: b.warnings })
}

/// Map every object `id` to its element; duplicate ids are an error.
fn collect_ids<'t>(e: &'t Elem, ids: &mut HashMap<String, &'t Elem>, aliases: &mut Vec<&'t Elem>) -> Result<(), IoError> {
    for c in &e.children {
        if c.tag == "alias" {
            aliases.push(c);
            continue;
        }
        if c.tag != "ref" && !props::is_value(c) {
            if let Some(id) = c.attr("id") {
                if let Some(prev) = ids.insert(id.to_string(), c) {
                    return Err(c.loc.error(format!("{} has duplicate id \"{id}\" (previous at {})", c.describe(), prev.loc)));
                }
            }
        }
        collect_ids(c, ids, aliases)?;
    }
    Ok(())
}

struct Builder<'t> {
    ids: HashMap<String, &'t Elem>,
    main_dir: PathBuf,
    search_dirs: &'t [PathBuf],
    desc: SceneDesc,
    warnings: Vec<String>,
    /// Material index of each bsdf element already instantiated (by address).
    materials: HashMap<*const Elem, u32>,
    /// Image index of each texture file already read.
    images: HashMap<PathBuf, u32>,
    default_material: Option<u32>,
}

/// Mitsuba 3's film when a scene gives none.
const DEFAULT_FILM: FilmDesc = FilmDesc { width: 768, height: 576, filter: PixelFilter::Gaussian { stddev: 0.5 } };

impl<'t> Builder<'t> {
    fn warn(&mut self, e: &Elem, msg: impl std::fmt::Display) {
        self.warnings.push(e.warning(msg));
    }

    fn props(&self, e: &'t Elem) -> Result<Props<'t>, IoError> {
        Props::new(e, &self.ids)
    }

    fn scene(&mut self, root: &'t Elem) -> Result<(), IoError> {
        self.desc.film = DEFAULT_FILM;
        let mut have_sensor = false;
        for c in &root.children {
            match c.tag.as_str() {
                "integrator" => self.integrator(c)?,
                "sensor" => {
                    if have_sensor {
                        self.warn(c, "only the first sensor is used; this one is ignored");
                    } else {
                        have_sensor = self.sensor(c)?;
                    }
                }
                "bsdf" => {
                    self.material_index(c)?;
                }
                "shape" => self.shape(c)?,
                "emitter" => self.emitter(c)?,
                // Instantiated when referenced.
                "texture" | "alias" => {}
                "ref" => self.warn(c, "a reference at scene level does nothing; ignored"),
                "medium" | "phase" | "volume" => self.warn(c, "participating media are not supported; ignored"),
                t if props::is_value(c) => self.warn(c, format!("<{t}> at scene level is not a scene parameter; ignored")),
                t => self.warn(c, format!("unsupported element <{t}>; ignored")),
            }
        }
        if !have_sensor {
            self.warnings.push(format!("{}: {}: no usable sensor; using Mitsuba's default camera and film", root.loc, root.describe()));
        }
        Ok(())
    }

    // ----------------------------------------------------------------------------------------
    // Integrator, sensor, film, sampler
    // ----------------------------------------------------------------------------------------

    fn integrator(&mut self, e: &'t Elem) -> Result<(), IoError> {
        let ty = e.req_attr("type")?;
        let p = self.props(e)?;
        let depth = p.int("max_depth")?;
        if let Some(d) = depth {
            if d < -1 || d > i32::MAX as i64 {
                return Err(e.loc.error(format!("{}: max_depth {d} must be -1 (unbounded) or >= 0", e.describe())));
            }
        }
        const PATH_LIKE: &[&str] =
            &["path", "volpath", "volpathmis", "prb", "prb_basic", "prbvolpath", "ptracer", "bdpt", "photonmapper", "ppm", "sppm"];
        self.desc.hints.max_depth = depth.map(|d| d as i32).or(PATH_LIKE.contains(&ty).then_some(-1));
        self.desc.hints.integrator = Some(ty.to_string());
        // Russian roulette only changes the variance.
        p.accept(&["rr_depth"]);
        p.finish(&mut self.warnings);
        Ok(())
    }

    /// Returns false when the sensor type is unsupported (and was skipped).
    fn sensor(&mut self, e: &'t Elem) -> Result<bool, IoError> {
        let ty = e.req_attr("type")?;
        match ty {
            "perspective" => {}
            "thinlens" => self.warn(e, "depth of field is not supported; rendered as a pinhole (perspective) camera"),
            _ => {
                self.warn(e, format!("unsupported sensor type \"{ty}\"; skipped"));
                return Ok(false);
            }
        }
        let p = self.props(e)?;
        // Film first: the fov conversions need the aspect ratio only at render time, but the
        // film also carries the sampler-independent settings.
        let mut film = DEFAULT_FILM;
        let mut spp = None;
        for (i, o) in p.objects() {
            match o.target.tag.as_str() {
                "film" => {
                    p.mark(i);
                    film = self.film(o.target)?;
                }
                "sampler" => {
                    p.mark(i);
                    spp = Some(self.sampler(o.target)?);
                }
                _ => {}
            }
        }
        let cam = &mut self.desc.camera;
        cam.to_world = p.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
        let fov = p.float("fov")?;
        let focal = p.get("focal_length").map(|f| (f.target.attr("value").unwrap_or("").to_string(), f.target));
        match (fov, focal) {
            (Some(_), Some(_)) => return Err(e.loc.error(format!("{}: give either fov or focal_length, not both", e.describe()))),
            (Some(f), None) => {
                cam.fov_deg = f;
                cam.fov_axis = match p.string("fov_axis")?.unwrap_or("x").to_ascii_lowercase().as_str() {
                    "x" => FovAxis::X,
                    "y" => FovAxis::Y,
                    "diagonal" => FovAxis::Diagonal,
                    "smaller" => FovAxis::Smaller,
                    "larger" => FovAxis::Larger,
                    other => {
                        return Err(e
                            .loc
                            .error(format!("{}: fov_axis \"{other}\" must be x, y, diagonal, smaller or larger", e.describe())))
                    }
                };
            }
            (None, focal) => {
                let (text, fe) = focal.unwrap_or_else(|| ("50mm".to_string(), e));
                let mm = props::parse_f32(fe, text.trim().trim_end_matches("mm"))?;
                if mm <= 0.0 {
                    return Err(fe.loc.error(format!("focal length {mm} mm must be positive")));
                }
                // 35 mm-equivalent focal length -> diagonal field of view (Mitsuba's parse_fov).
                cam.fov_deg = 2.0 * (36.0f32.hypot(24.0) / (2.0 * mm)).atan().to_degrees();
                cam.fov_axis = FovAxis::Diagonal;
                if p.has("fov_axis") {
                    p.string("fov_axis")?;
                }
            }
        }
        if !(cam.fov_deg > 0.0 && cam.fov_deg < 180.0) {
            return Err(e.loc.error(format!("{}: field of view {} degrees is outside (0, 180)", e.describe(), cam.fov_deg)));
        }
        cam.near_clip = p.float_or("near_clip", 1e-2)?;
        if cam.near_clip < 0.0 {
            return Err(e.loc.error(format!("{}: near_clip {} must not be negative", e.describe(), cam.near_clip)));
        }
        cam.validate().map_err(|msg| e.loc.error(format!("{}: {msg}", e.describe())))?;
        // Accepted without effect: the far plane lies beyond every scene we render, and the
        // focus settings only matter for thin lenses, which are not supported.
        p.accept(&["far_clip", "focus_distance", "aperture_radius", "shutter_open", "shutter_close"]);
        for axis in ["principal_point_offset_x", "principal_point_offset_y"] {
            if p.float(axis)?.is_some_and(|v| v != 0.0) {
                self.warn(e, format!("{axis} is not supported; the principal point stays at the image centre"));
            }
        }
        p.finish(&mut self.warnings);
        self.desc.film = film;
        if spp.is_some() {
            self.desc.hints.spp = spp;
        }
        Ok(true)
    }

    fn film(&mut self, e: &'t Elem) -> Result<FilmDesc, IoError> {
        let ty = e.req_attr("type")?;
        if !matches!(ty, "hdrfilm" | "ldrfilm") {
            self.warn(e, format!("film type \"{ty}\" is read as an hdrfilm"));
        }
        let p = self.props(e)?;
        let mut size = [DEFAULT_FILM.width, DEFAULT_FILM.height];
        for (k, name) in ["width", "height"].iter().enumerate() {
            if let Some(v) = p.int(name)? {
                if !(1..=1 << 15).contains(&v) {
                    return Err(e.loc.error(format!("{}: {name} {v} is outside 1..32768", e.describe())));
                }
                size[k] = v as u32;
            }
        }
        let mut filter = DEFAULT_FILM.filter;
        let mut seen = false;
        for (i, o) in p.objects() {
            if o.target.tag != "rfilter" {
                continue;
            }
            p.mark(i);
            if seen {
                return Err(o.elem.loc.error("a film can only have one reconstruction filter"));
            }
            seen = true;
            filter = self.rfilter(o.target)?;
        }
        // Output format only.
        p.accept(&["pixel_format", "component_format"]);
        p.finish(&mut self.warnings);
        Ok(FilmDesc { width: size[0], height: size[1], filter })
    }

    fn rfilter(&mut self, e: &'t Elem) -> Result<PixelFilter, IoError> {
        let ty = e.req_attr("type")?;
        let p = self.props(e)?;
        let f = match ty {
            "box" => {
                if p.float("radius")?.is_some_and(|r| r != 0.5) {
                    self.warn(e, "only the default box radius 0.5 is supported");
                }
                PixelFilter::Box
            }
            "tent" => {
                if p.float("radius")?.is_some_and(|r| r != 1.0) {
                    self.warn(e, "only the default tent radius 1 is supported");
                }
                PixelFilter::Tent
            }
            "gaussian" => {
                let stddev = p.float_or("stddev", 0.5)?;
                if stddev <= 0.0 {
                    return Err(e.loc.error(format!("{}: stddev {stddev} must be positive", e.describe())));
                }
                PixelFilter::Gaussian { stddev }
            }
            other => {
                self.warn(e, format!("reconstruction filter \"{other}\" is not supported; using Mitsuba's default gaussian (stddev 0.5)"));
                p.accept_all();
                PixelFilter::Gaussian { stddev: 0.5 }
            }
        };
        p.finish(&mut self.warnings);
        Ok(f)
    }

    fn sampler(&mut self, e: &'t Elem) -> Result<u32, IoError> {
        let p = self.props(e)?;
        let n = p.int("sample_count")?.unwrap_or(4);
        if !(1..=u32::MAX as i64).contains(&n) {
            return Err(e.loc.error(format!("{}: sample_count {n} must be positive", e.describe())));
        }
        // The sampler type and its settings only change the noise pattern.
        p.accept_all();
        Ok(n as u32)
    }

    // ----------------------------------------------------------------------------------------
    // Colours and textures
    // ----------------------------------------------------------------------------------------

    /// A colour parameter as a texture (default when absent).
    fn texture_param(&mut self, p: &Props<'t>, name: &str, kind: ColorKind, default: f32) -> Result<Texture, IoError> {
        match p.spec(name, kind, &mut self.warnings)? {
            None => Ok(Texture::Const(Color::splat(default))),
            Some(Spec::Const(c)) => Ok(Texture::Const(c)),
            Some(Spec::Texture(t)) => self.texture(t),
        }
    }

    /// A colour parameter that must be constant; a bitmap is replaced by its average.
    fn color_param(&mut self, p: &Props<'t>, name: &str, kind: ColorKind, default: f32) -> Result<Color, IoError> {
        match self.texture_param(p, name, kind, default)? {
            Texture::Const(c) => Ok(c),
            Texture::Bitmap { image, .. } => {
                let img = &self.desc.images[image as usize];
                let avg = img.data.iter().fold(Color::ZERO, |a, &c| a + c) / img.data.len().max(1) as f32;
                self.warn(p.owner, format!("a textured \"{name}\" is not supported here; using the image average {avg}"));
                Ok(avg)
            }
        }
    }

    fn texture(&mut self, e: &'t Elem) -> Result<Texture, IoError> {
        let ty = e.req_attr("type")?;
        let p = self.props(e)?;
        let tex = match ty {
            "bitmap" => {
                let name = p.string("filename")?.ok_or_else(|| e.loc.error(format!("{} needs a \"filename\"", e.describe())))?;
                let path = resolve_file(&e.loc, name, &self.main_dir, self.search_dirs)
                    .ok_or_else(|| e.loc.error(format!("{}: image file \"{name}\" not found", e.describe())))?;
                let image = match self.images.get(&path) {
                    Some(&i) => i,
                    None => {
                        let img = crate::image_io::read_image(&path)?;
                        self.desc.images.push(img);
                        let i = (self.desc.images.len() - 1) as u32;
                        self.images.insert(path.clone(), i);
                        i
                    }
                };
                let mut uv_scale = Vec2::ONE;
                if let Some(m) = p.transform("to_uv")? {
                    uv_scale = Vec2::new(m.x_axis.x, m.y_axis.y);
                    let off = [m.x_axis.y, m.y_axis.x, m.w_axis.x, m.w_axis.y];
                    if off.iter().any(|v| *v != 0.0) {
                        self.warn(e, "only the scale part of to_uv is supported (rotation and offset ignored)");
                    }
                }
                // Mitsuba 0.5 names.
                uv_scale *= Vec2::new(p.float_or("uscale", 1.0)?, p.float_or("vscale", 1.0)?);
                if p.float_or("uoffset", 0.0)? != 0.0 || p.float_or("voffset", 0.0)? != 0.0 {
                    self.warn(e, "texture offsets (uoffset/voffset) are not supported; ignored");
                }
                if p.bool_or("raw", false)?
                    && !path.extension().is_some_and(|x| x.eq_ignore_ascii_case("exr") || x.eq_ignore_ascii_case("hdr"))
                {
                    self.warn(e, "raw = true is not supported: 8-bit images are always decoded from sRGB");
                }
                for (param, default) in [("filter_type", "bilinear"), ("wrap_mode", "repeat")] {
                    if let Some(v) = p.string(param)? {
                        if !v.eq_ignore_ascii_case(default) {
                            self.warn(e, format!("{param} \"{v}\" is not supported; using {default}"));
                        }
                    }
                }
                Texture::Bitmap { image, uv_scale }
            }
            "checkerboard" => {
                let c0 = self.color_param(&p, "color0", ColorKind::Bounded, 0.4)?;
                let c1 = self.color_param(&p, "color1", ColorKind::Bounded, 0.2)?;
                self.warn(e, "checkerboard textures are not supported; using the average of its two colours");
                p.accept_all();
                Texture::Const((c0 + c1) * 0.5)
            }
            other => {
                self.warn(e, format!("unsupported texture type \"{other}\"; using a constant 0.5"));
                p.accept_all();
                Texture::Const(Color::splat(0.5))
            }
        };
        p.finish(&mut self.warnings);
        Ok(tex)
    }

    // ----------------------------------------------------------------------------------------
    // BSDFs
    // ----------------------------------------------------------------------------------------

    fn default_material(&mut self) -> u32 {
        if let Some(i) = self.default_material {
            return i;
        }
        self.desc.materials.push(Material::Diffuse { reflectance: Texture::Const(Color::splat(0.5)) });
        let i = (self.desc.materials.len() - 1) as u32;
        self.default_material = Some(i);
        i
    }

    /// Index of the material for bsdf element `e`, instantiating it once.
    fn material_index(&mut self, e: &'t Elem) -> Result<u32, IoError> {
        let key = e as *const Elem;
        if let Some(&i) = self.materials.get(&key) {
            return Ok(i);
        }
        let m = self.material(e)?;
        m.validate(self.desc.images.len()).map_err(|msg| e.loc.error(format!("{}: {msg}", e.describe())))?;
        self.desc.materials.push(m);
        let i = (self.desc.materials.len() - 1) as u32;
        self.materials.insert(key, i);
        Ok(i)
    }

    /// An IOR given as a number or a name from Mitsuba's table.
    fn ior(&mut self, p: &Props<'t>, name: &str, default: &str) -> Result<f32, IoError> {
        let v = match p.get(name) {
            None => spectra::lookup_ior(default).unwrap_or(1.0),
            Some(entry) => {
                let e = entry.target;
                match e.tag.as_str() {
                    "float" | "integer" => props::parse_f32(e, e.req_attr("value")?)?,
                    "string" => {
                        let n = e.req_attr("value")?;
                        spectra::lookup_ior(n)
                            .ok_or_else(|| e.loc.error(format!("unknown IOR name \"{n}\"; valid names are: {}", spectra::ior_names())))?
                    }
                    "rgb" | "spectrum" => {
                        let c = props::parse_color(e, ColorKind::Unbounded, &mut self.warnings)?;
                        if c.max_element() - c.min_element() > 1e-6 {
                            self.warn(e, "a spectrally varying IOR is not supported; using its luminance");
                        }
                        octolux::math::luminance(c)
                    }
                    t => return Err(entry.elem.loc.error(format!("{name} must be a <float> or <string>, not <{t}>"))),
                }
            }
        };
        if v <= 0.0 {
            return Err(p.owner.loc.error(format!("{}: {name} = {v} must be positive", p.owner.describe())));
        }
        Ok(v)
    }

    /// `int_ior / ext_ior` with Mitsuba's checks.
    fn eta(&mut self, p: &Props<'t>, int_default: &str) -> Result<f32, IoError> {
        let int = self.ior(p, "int_ior", int_default)?;
        let ext = self.ior(p, "ext_ior", "air")?;
        if int == ext {
            return Err(p
                .owner
                .loc
                .error(format!("{}: the interior and exterior indices of refraction must differ (both {int})", p.owner.describe())));
        }
        Ok(int / ext)
    }

    /// GGX alpha of a microfacet bsdf (warns about Beckmann and anisotropy).
    fn alpha(&mut self, p: &Props<'t>) -> Result<f32, IoError> {
        let e = p.owner;
        let dist = p.string("distribution")?.unwrap_or("beckmann").to_ascii_lowercase();
        if dist != "ggx" {
            self.warn(
                e,
                format!("microfacet distribution \"{dist}\" (Mitsuba's default is beckmann) is replaced by GGX with the same alpha"),
            );
        }
        p.accept(&["sample_visible"]);
        let (au, av) = (p.float("alpha_u")?, p.float("alpha_v")?);
        let alpha = match (p.float("alpha")?, au, av) {
            (Some(a), None, None) => a,
            (None, Some(u), Some(v)) => {
                if u != v {
                    self.warn(e, format!("anisotropic roughness is not supported; using alpha = sqrt({u} * {v})"));
                }
                (u * v).sqrt()
            }
            (None, None, None) => 0.1,
            _ => return Err(e.loc.error(format!("{}: give either alpha or both alpha_u and alpha_v", e.describe()))),
        };
        if alpha.is_nan() || alpha <= 0.0 {
            return Err(e.loc.error(format!("{}: alpha {alpha} must be positive", e.describe())));
        }
        Ok(alpha)
    }

    /// The nested bsdfs of a wrapper (nested elements or refs), in order.
    fn nested_bsdfs(&self, p: &Props<'t>) -> Vec<&'t Elem> {
        let mut v = Vec::new();
        for (i, o) in p.objects() {
            if o.target.tag == "bsdf" {
                p.mark(i);
                v.push(o.target);
            }
        }
        v
    }

    fn material(&mut self, e: &'t Elem) -> Result<Material, IoError> {
        let ty = e.req_attr("type")?;
        let p = self.props(e)?;
        let m = match ty {
            "diffuse" => Material::Diffuse { reflectance: self.texture_param(&p, "reflectance", ColorKind::Bounded, 0.5)? },
            "dielectric" | "roughdielectric" | "thindielectric" => {
                if ty == "roughdielectric" {
                    self.warn(e, "rough dielectrics are not supported; using a smooth dielectric with the same IORs");
                    p.accept(&["alpha", "alpha_u", "alpha_v", "distribution", "sample_visible"]);
                }
                let eta = self.eta(&p, "bk7")?;
                let specular_reflectance = self.color_param(&p, "specular_reflectance", ColorKind::Bounded, 1.0)?;
                let specular_transmittance = self.color_param(&p, "specular_transmittance", ColorKind::Bounded, 1.0)?;
                if ty == "thindielectric" {
                    Material::ThinDielectric { eta, specular_reflectance, specular_transmittance }
                } else {
                    Material::Dielectric { eta, specular_reflectance, specular_transmittance }
                }
            }
            "conductor" | "roughconductor" => {
                let preset = p.string("material")?;
                let (eta, k) = if p.has("eta") || p.has("k") {
                    if preset.is_some_and(|m| m != "none") {
                        return Err(e.loc.error(format!("{}: give either (eta, k) or material, not both", e.describe())));
                    }
                    (self.color_param(&p, "eta", ColorKind::Unbounded, 0.0)?, self.color_param(&p, "k", ColorKind::Unbounded, 1.0)?)
                } else {
                    let name = preset.unwrap_or("none");
                    match spectra::lookup_conductor(name).or_else(|| {
                        let lower = name.to_ascii_lowercase();
                        spectra::conductor_names().split(", ").find(|n| n.to_ascii_lowercase() == lower).and_then(spectra::lookup_conductor)
                    }) {
                        Some(v) => v,
                        None => {
                            self.warn(
                                e,
                                format!(
                                    "conductor material \"{name}\" is not in octolux's table ({}); using a perfect mirror",
                                    spectra::conductor_names()
                                ),
                            );
                            (Color::ZERO, Color::ZERO)
                        }
                    }
                };
                let specular_reflectance = self.color_param(&p, "specular_reflectance", ColorKind::Bounded, 1.0)?;
                if ty == "roughconductor" {
                    let alpha = self.alpha(&p)?;
                    Material::RoughConductor { alpha, eta, k, specular_reflectance }
                } else {
                    Material::Conductor { eta, k, specular_reflectance }
                }
            }
            "plastic" | "roughplastic" => {
                let alpha = if ty == "plastic" {
                    self.warn(e, format!("smooth plastic is approximated by a GGX roughplastic with alpha = {SMOOTH_PLASTIC_ALPHA}"));
                    SMOOTH_PLASTIC_ALPHA
                } else {
                    self.alpha(&p)?
                };
                let eta = self.eta(&p, "polypropylene")?;
                let diffuse_reflectance = self.texture_param(&p, "diffuse_reflectance", ColorKind::Bounded, 0.5)?;
                let specular_reflectance = self.color_param(&p, "specular_reflectance", ColorKind::Bounded, 1.0)?;
                if p.bool_or("nonlinear", false)? {
                    self.warn(e, "nonlinear = true is not supported; using the linear (default) model");
                }
                Material::RoughPlastic { diffuse_reflectance, specular_reflectance, alpha, eta }
            }
            "twosided" => {
                let nested = self.nested_bsdfs(&p);
                match nested.as_slice() {
                    [one] => {
                        let m = self.material(one)?;
                        Material::TwoSided { front: Box::new(m.clone()), back: Box::new(m) }
                    }
                    [front, back] => Material::TwoSided { front: Box::new(self.material(front)?), back: Box::new(self.material(back)?) },
                    _ => return Err(e.loc.error(format!("{} needs one or two nested bsdfs, found {}", e.describe(), nested.len()))),
                }
            }
            "mask" | "bumpmap" | "normalmap" => {
                let nested = self.nested_bsdfs(&p);
                let [inner] = nested.as_slice() else {
                    return Err(e.loc.error(format!("{} needs exactly one nested bsdf, found {}", e.describe(), nested.len())));
                };
                self.warn(e, format!("\"{ty}\" is not supported; using its nested bsdf alone"));
                p.accept_all();
                self.material(inner)?
            }
            "null" => {
                self.warn(e, "the null bsdf (invisible surface) is not supported; the surface is black diffuse");
                Material::Diffuse { reflectance: Texture::Const(Color::ZERO) }
            }
            other => {
                self.warn(e, format!("unsupported bsdf type \"{other}\"; using Mitsuba's default diffuse (reflectance 0.5)"));
                p.accept_all();
                Material::Diffuse { reflectance: Texture::Const(Color::splat(0.5)) }
            }
        };
        p.finish(&mut self.warnings);
        Ok(m)
    }

    // ----------------------------------------------------------------------------------------
    // Shapes
    // ----------------------------------------------------------------------------------------

    fn shape(&mut self, e: &'t Elem) -> Result<(), IoError> {
        let ty = e.req_attr("type")?;
        let p = self.props(e)?;
        let to_world = p.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
        let mut name = e.attr("id").map(str::to_string);
        let geometry = match ty {
            "obj" | "ply" => {
                let file = p.string("filename")?.ok_or_else(|| e.loc.error(format!("{} needs a \"filename\"", e.describe())))?;
                let path = resolve_file(&e.loc, file, &self.main_dir, self.search_dirs)
                    .ok_or_else(|| e.loc.error(format!("{}: mesh file \"{file}\" not found", e.describe())))?;
                let (mut mesh, warns) = crate::mesh::load_mesh_checked(&path)?;
                for w in warns {
                    self.warn(e, w);
                }
                if p.bool_or("face_normals", false)? {
                    mesh.normals = None;
                }
                if ty == "obj" && !p.bool_or("flip_tex_coords", true)? {
                    // The OBJ reader flips v like Mitsuba's default; undo it.
                    if let Some(uvs) = &mut mesh.uvs {
                        for uv in uvs.iter_mut() {
                            uv.y = 1.0 - uv.y;
                        }
                    }
                }
                mesh.transform(&to_world);
                if name.is_none() {
                    name = path.file_stem().map(|s| s.to_string_lossy().into_owned());
                }
                Geometry::Mesh(mesh)
            }
            "sphere" => {
                let center = p.vec3("center")?.unwrap_or(Vec3::ZERO);
                let radius = p.float_or("radius", 1.0)?;
                let m = to_world * Mat4::from_translation(center) * Mat4::from_scale(Vec3::splat(radius));
                let (x, y, z) = (m.x_axis.truncate(), m.y_axis.truncate(), m.z_axis.truncate());
                let r = x.length();
                let tol = 1e-4 * r;
                let similar = (y.length() - r).abs() <= tol
                    && (z.length() - r).abs() <= tol
                    && x.dot(y).abs() <= tol * r
                    && x.dot(z).abs() <= tol * r
                    && y.dot(z).abs() <= tol * r;
                if !similar || m.row(3) != glam::Vec4::W {
                    return Err(e
                        .loc
                        .error(format!("{}: to_world of a sphere may only rotate, translate and scale uniformly", e.describe())));
                }
                if !(r > 0.0 && r.is_finite() && m.w_axis.is_finite()) {
                    return Err(e.loc.error(format!("{}: the sphere radius {r} must be positive", e.describe())));
                }
                Geometry::Sphere { center: m.w_axis.truncate(), radius: r }
            }
            "rectangle" => Geometry::Mesh(TriMesh::rectangle(&to_world)),
            "cube" => Geometry::Mesh(TriMesh::cube(&to_world)),
            "disk" => Geometry::Mesh(TriMesh::disk(&to_world, 128)),
            other => {
                self.warn(e, format!("unsupported shape type \"{other}\"; skipped"));
                return Ok(());
            }
        };
        if let Geometry::Mesh(m) = &geometry {
            if !m.positions.iter().all(|v| v.is_finite()) {
                return Err(e.loc.error(format!("{}: vertices are not finite (check to_world)", e.describe())));
            }
            if m.indices.is_empty() {
                self.warn(e, "the mesh has no triangles; skipped");
                return Ok(());
            }
        }
        let flip_normals = p.bool_or("flip_normals", false)?;
        let mut material = None;
        let mut emission = None;
        for (i, o) in p.objects() {
            match o.target.tag.as_str() {
                "bsdf" => {
                    p.mark(i);
                    if material.is_some() {
                        return Err(o.elem.loc.error(format!("{} has more than one bsdf", e.describe())));
                    }
                    material = Some(self.material_index(o.target)?);
                }
                "emitter" => {
                    p.mark(i);
                    let em = o.target;
                    let ety = em.req_attr("type")?;
                    if ety != "area" {
                        self.warn(em, format!("emitter type \"{ety}\" cannot be attached to a shape; ignored"));
                        continue;
                    }
                    if emission.is_some() {
                        return Err(em.loc.error(format!("{} has more than one area emitter", e.describe())));
                    }
                    let ep = self.props(em)?;
                    let radiance = self.color_param(&ep, "radiance", ColorKind::Unbounded, 1.0)?;
                    if !radiance.is_finite() {
                        return Err(em.loc.error(format!("{}: radiance {radiance} is not finite", em.describe())));
                    }
                    emission = Some(radiance);
                    ep.accept(&["sampling_weight"]);
                    ep.finish(&mut self.warnings);
                }
                "medium" => {
                    p.mark(i);
                    self.warn(o.target, "participating media are not supported; ignored");
                }
                _ => {}
            }
        }
        let material = match material {
            Some(m) => m,
            None => self.default_material(),
        };
        p.finish(&mut self.warnings);
        let name = name.unwrap_or_else(|| format!("{ty}@{}", e.loc));
        self.desc.shapes.push(ShapeDesc { name, geometry, material, emission, flip_normals });
        Ok(())
    }

    // ----------------------------------------------------------------------------------------
    // Emitters
    // ----------------------------------------------------------------------------------------

    /// Emitter position and direction from `position`/`direction` or `to_world`.
    fn placement(&self, p: &Props<'t>, key: &str) -> Result<(Option<Vec3>, Option<Mat4>), IoError> {
        let v = p.vec3(key)?;
        let m = p.transform("to_world")?;
        if v.is_some() && m.is_some() {
            return Err(p.owner.loc.error(format!("{}: give either {key} or to_world, not both", p.owner.describe())));
        }
        Ok((v, m))
    }

    fn emitter(&mut self, e: &'t Elem) -> Result<(), IoError> {
        let ty = e.req_attr("type")?;
        let p = self.props(e)?;
        p.accept(&["sampling_weight"]);
        let light = match ty {
            "point" => {
                let intensity = self.color_param(&p, "intensity", ColorKind::Unbounded, 1.0)?;
                let position = match self.placement(&p, "position")? {
                    (Some(v), _) => v,
                    (None, Some(m)) => m.transform_point3(Vec3::ZERO),
                    (None, None) => Vec3::ZERO,
                };
                Light::Point { position, intensity }
            }
            "spot" => {
                let intensity = self.color_param(&p, "intensity", ColorKind::Unbounded, 1.0)?;
                let cutoff = p.float_or("cutoff_angle", 20.0)?;
                let mut beam = p.float_or("beam_width", cutoff * 0.75)?;
                if !(cutoff > 0.0 && cutoff < 180.0) {
                    return Err(e.loc.error(format!("{}: cutoff_angle {cutoff} must be in (0, 180) degrees", e.describe())));
                }
                if beam > cutoff || beam < 0.0 {
                    self.warn(e, format!("beam_width {beam} must lie in [0, cutoff_angle = {cutoff}]; clamped"));
                    beam = beam.clamp(0.0, cutoff);
                }
                let m = p.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
                let n = m.transform_vector3(Vec3::Z).normalize();
                let s = m.transform_vector3(Vec3::X);
                let s = (s - n * s.dot(n)).normalize();
                if !n.is_finite() || !s.is_finite() {
                    return Err(e.loc.error(format!("{}: to_world is degenerate", e.describe())));
                }
                let frame = Frame { s, t: n.cross(s), n };
                Light::Spot {
                    position: m.transform_point3(Vec3::ZERO),
                    frame,
                    intensity,
                    cos_cutoff: cutoff.to_radians().cos(),
                    cos_falloff_start: beam.to_radians().cos(),
                }
            }
            "directional" => {
                let irradiance = self.color_param(&p, "irradiance", ColorKind::Unbounded, 1.0)?;
                let d = match self.placement(&p, "direction")? {
                    (Some(v), _) => v,
                    (None, Some(m)) => m.transform_vector3(Vec3::Z),
                    (None, None) => Vec3::Z,
                };
                if !d.is_finite() || d.length_squared() == 0.0 {
                    return Err(e.loc.error(format!("{}: the direction is zero", e.describe())));
                }
                Light::Directional { direction: d.normalize(), irradiance }
            }
            "constant" => Light::Constant { radiance: self.color_param(&p, "radiance", ColorKind::Unbounded, 1.0)? },
            "area" => {
                self.warn(e, "an area emitter must be nested in a shape; ignored");
                return Ok(());
            }
            other => {
                self.warn(e, format!("unsupported emitter type \"{other}\"; ignored"));
                return Ok(());
            }
        };
        light.validate().map_err(|msg| e.loc.error(format!("{}: {msg}", e.describe())))?;
        p.finish(&mut self.warnings);
        self.desc.lights.push(light);
        Ok(())
    }
}
