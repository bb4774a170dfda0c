//! Textures: a reflectance-like parameter that is a constant or a bitmap looked up by uv
//! (Mitsuba's `bitmap` texture with its default repeat wrap and bilinear filter).

use super::check_color;
use crate::image::Image;
use crate::math::Color;
use glam::Vec2;

/// A reflectance-like parameter: constant or a bitmap looked up by uv.
#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    Const(Color),
    /// Index into `SceneDesc::images`; `uv_scale` multiplies the uvs (Mitsuba `to_uv` scale).
    Bitmap {
        image: u32,
        uv_scale: Vec2,
    },
}

impl Texture {
    #[inline]
    pub fn eval(&self, images: &[Image], uv: Vec2) -> Color {
        match self {
            Texture::Const(c) => *c,
            Texture::Bitmap { image, uv_scale } => images.get(*image as usize).map_or(Color::ZERO, |im| im.lookup(uv * *uv_scale)),
        }
    }

    pub(crate) fn validate(&self, n_images: usize, what: &str) -> Result<(), String> {
        match self {
            Texture::Const(c) => check_color(*c, what),
            Texture::Bitmap { image, uv_scale } => {
                if *image as usize >= n_images {
                    return Err(format!("{what}: bitmap {image} does not exist (the scene has {n_images} bitmaps)"));
                }
                if !uv_scale.is_finite() {
                    return Err(format!("{what}: uv scale {uv_scale} is not finite"));
                }
                Ok(())
            }
        }
    }

    /// Per-channel maximum over the texture (Mitsuba's `Texture::getMaximum`).
    pub fn max(&self, images: &[Image]) -> Color {
        match self {
            Texture::Const(c) => *c,
            Texture::Bitmap { image, .. } => {
                images.get(*image as usize).map_or(Color::ZERO, |im| im.data.iter().fold(Color::ZERO, |m, &c| m.max(c)))
            }
        }
    }

    /// This texture times `scale`: a constant directly, a bitmap through a scaled copy
    /// appended to `images`.
    pub fn scaled(&self, scale: f32, images: &mut Vec<Image>) -> Texture {
        match self {
            Texture::Const(c) => Texture::Const(*c * scale),
            Texture::Bitmap { image, uv_scale } => match images.get(*image as usize) {
                Some(im) => {
                    let copy = Image { width: im.width, height: im.height, data: im.data.iter().map(|&c| c * scale).collect() };
                    images.push(copy);
                    Texture::Bitmap { image: (images.len() - 1) as u32, uv_scale: *uv_scale }
                }
                None => self.clone(),
            },
        }
    }
}
