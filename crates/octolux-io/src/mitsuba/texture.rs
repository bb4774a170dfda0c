//! Mitsuba `texture` plugins (`bitmap`, `checkerboard`) and colour parameters that may be
//! textured.

use super::props::{ColorKind, Props, Spec};
use super::tree::{resolve_file, Elem};
use super::Builder;
use crate::image_io::{linear_to_srgb, srgb_to_linear};
use crate::IoError;
use glam::Vec2;
use octolux::image::Image;
use octolux::math::Color;
use octolux::scene::material::{TexFilter, Texture};

/// How a bitmap's stored values become the linear values octolux uses: as the file says (8-bit
/// files sRGB, EXR and HDR linear), or as Mitsuba 3's `raw` and Mitsuba 0.6's `gamma` ask
/// (`gamma` 1: linear, -1: sRGB, any other positive value `g`: `v^g`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(super) enum Decode {
    File,
    /// The stored values themselves (`raw`, `gamma` 1).
    Linear,
    Srgb,
    /// A power law, the exponent's bits.
    Power(u32),
}

impl Decode {
    /// From a bitmap's (or envmap's) `raw` and `gamma`: `gamma` must be -1, or positive and
    /// finite; with both given, `gamma` decides and `raw` must agree (true only with 1).
    pub(super) fn from_props(p: &Props<'_>, e: &Elem) -> Result<Decode, IoError> {
        let raw = p.boolean("raw")?;
        let Some(g) = p.float("gamma")? else { return Ok(if raw == Some(true) { Decode::Linear } else { Decode::File }) };
        let d = if g == -1.0 {
            Decode::Srgb
        } else if g == 1.0 {
            Decode::Linear
        } else if g.is_finite() && g > 0.0 {
            Decode::Power(g.to_bits())
        } else {
            return Err(e.loc.error(format!("{}: gamma {g} must be 1 (linear), -1 (sRGB) or another positive exponent", e.describe())));
        };
        if raw.is_some_and(|r| r != (d == Decode::Linear)) {
            return Err(e.loc.error(format!("{}: raw and gamma {g} disagree; give one of them", e.describe())));
        }
        Ok(d)
    }

    /// Apply to an image as read (`eight_bit`: decoded from sRGB by the reader).
    pub(super) fn apply(self, img: &mut Image, eight_bit: bool) {
        if self == Decode::File || (self == Decode::Linear && !eight_bit) {
            return;
        }
        for c in &mut img.data {
            // the stored values (the reader's sRGB decoding undone, exact to float rounding)
            let stored = if eight_bit { Color::new(linear_to_srgb(c.x), linear_to_srgb(c.y), linear_to_srgb(c.z)) } else { *c };
            *c = match self {
                Decode::File | Decode::Linear => stored,
                Decode::Srgb => Color::new(srgb_to_linear(stored.x), srgb_to_linear(stored.y), srgb_to_linear(stored.z)),
                Decode::Power(bits) => {
                    let g = f32::from_bits(bits);
                    Color::new(stored.x.max(0.0).powf(g), stored.y.max(0.0).powf(g), stored.z.max(0.0).powf(g))
                }
            };
        }
    }
}

impl<'t> Builder<'t> {
    /// A colour parameter as a texture (default when absent).
    pub(super) fn texture_param(&mut self, p: &Props<'t>, name: &str, kind: ColorKind, default: f32) -> Result<Texture, IoError> {
        match p.spec(name, kind, &mut self.warnings)? {
            None => Ok(Texture::Const(Color::splat(default))),
            Some(Spec::Const(c)) => Ok(Texture::Const(c)),
            Some(Spec::Texture(t)) => self.texture(t),
        }
    }

    /// A colour parameter that must be constant; a bitmap is replaced by its average.
    pub(super) fn color_param(&mut self, p: &Props<'t>, name: &str, kind: ColorKind, default: f32) -> Result<Color, IoError> {
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

    /// Add a decoded image (a bitmap's, an envmap's) to the scene, checked first against the
    /// memory budget together with every image before it (MIP levels included): each file is
    /// checked alone when read, but a 1 KB scene may name one large image under many names
    /// (hard links, each read on its own).
    pub(super) fn push_image(&mut self, e: &Elem, img: octolux::image::Image) -> Result<u32, IoError> {
        crate::image_io::check_scene_texels(&self.desc.images, &img).map_err(|b| e.loc.error(format!("{}: {b}", e.describe())))?;
        self.desc.images.push(img);
        Ok((self.desc.images.len() - 1) as u32)
    }

    /// The trilinear filter of image `image`, its MIP pyramid built once per image.
    fn mipmapped(&mut self, image: u32) -> TexFilter {
        if let Some(f) = self.mipmaps.get(&image) {
            return *f;
        }
        let filter = match Texture::bitmap(image, Vec2::ONE).with_mipmaps(&mut self.desc.images) {
            Texture::Bitmap { filter, .. } => filter,
            Texture::Const(_) => TexFilter::Bilinear,
        };
        self.mipmaps.insert(image, filter);
        filter
    }

    /// A texture declared at scene level, before (or without) a reference: Mitsuba 3
    /// instantiates every scene-level object, so a `bitmap` whose file is missing fails the
    /// scene even when nothing uses it ("failed to instantiate texture plugin of type
    /// \"bitmap\"", probed with Mitsuba 3.9.1). The same error here, naming file and line;
    /// the image itself is read only when a material references it.
    pub(super) fn scene_level_texture(&mut self, e: &'t Elem) -> Result<(), IoError> {
        if e.attr("type") != Some("bitmap") {
            return Ok(());
        }
        let p = self.props(e)?;
        let name = p.string("filename")?.ok_or_else(|| e.loc.error(format!("{} needs a \"filename\"", e.describe())))?;
        let path = resolve_file(&e.loc, name, &self.main_dir, self.search_dirs)
            .ok_or_else(|| e.loc.error(format!("{}: image file \"{name}\" not found", e.describe())))?;
        crate::files::check_input(&path)?;
        Ok(())
    }

    pub(super) fn texture(&mut self, e: &'t Elem) -> Result<Texture, IoError> {
        let ty = e.req_attr("type")?;
        let p = self.props(e)?;
        let tex = match ty {
            "bitmap" => {
                let name = p.string("filename")?.ok_or_else(|| e.loc.error(format!("{} needs a \"filename\"", e.describe())))?;
                let path = resolve_file(&e.loc, name, &self.main_dir, self.search_dirs)
                    .ok_or_else(|| e.loc.error(format!("{}: image file \"{name}\" not found", e.describe())))?;
                // Mitsuba 3 decodes 8-bit files from sRGB unless `raw` (EXR and HDR are linear);
                // Mitsuba 0.6's `gamma` overrides the file's encoding ([`Decode`]).
                let eight_bit = !path.extension().is_some_and(|x| x.eq_ignore_ascii_case("exr") || x.eq_ignore_ascii_case("hdr"));
                let mut decode = Decode::from_props(&p, e)?;
                if decode == Decode::Linear && !eight_bit {
                    decode = Decode::File;
                }
                // one file under several names (`sub/../t.png`, a link) is read once
                let key = (std::fs::canonicalize(&path).unwrap_or_else(|_| path.clone()), decode);
                let image = match self.images.get(&key) {
                    Some(&i) => i,
                    None => {
                        let (mut img, negative) = crate::image_io::read_texture(&path)?;
                        self.warnings.extend(negative);
                        decode.apply(&mut img, eight_bit);
                        let i = self.push_image(e, img)?;
                        self.images.insert(key, i);
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
                if let Some(v) = p.string("wrap_mode")? {
                    if !v.eq_ignore_ascii_case("repeat") {
                        self.warn(e, format!("wrap_mode \"{v}\" is not supported; using repeat"));
                    }
                }
                let filter = match p.string("filter_type")?.map(str::to_ascii_lowercase).as_deref() {
                    None | Some("bilinear") => TexFilter::Bilinear,
                    Some("nearest") => TexFilter::Nearest,
                    Some("trilinear") => self.mipmapped(image),
                    Some(v) => {
                        // Mitsuba 0.6's `ewa` (its default) is the nearest to trilinear MIP-mapping.
                        let (filter, name) =
                            if v == "ewa" { (self.mipmapped(image), "trilinear") } else { (TexFilter::Bilinear, "bilinear") };
                        self.warn(e, format!("filter_type \"{v}\" is not supported; using {name}"));
                        filter
                    }
                };
                Texture::Bitmap { image, uv_scale, filter }
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
}
