//! Linear-RGB images: the bitmaps textures read and the films the renderer writes (file
//! formats live in `octolux-io`).

use crate::math::Color;
use glam::Vec2;

/// A linear-RGB bitmap (row 0 is the top of the image, `data[row * width + column]`).
#[derive(Clone, Debug, Default)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub data: Vec<Color>,
}

impl Image {
    /// Bilinear lookup with wrap-around (Mitsuba `bitmap` defaults: repeat, bilinear).
    ///
    /// Mitsuba 3's convention: `uv = (0,0)` is the top-left corner of the image (row 0) and `v`
    /// runs downwards, texel centres at half-integer pixel coordinates (`x = u·W - 1/2`,
    /// `y = v·H - 1/2`). Mesh loaders flip OBJ texture coordinates (`v → 1 - v`, Mitsuba's
    /// `flip_tex_coords`), so an OBJ's `(0,0)` ends up at the bottom-left as in Mitsuba.
    /// An empty or inconsistent image, or a non-finite `uv`, reads as black.
    pub fn lookup(&self, uv: Vec2) -> Color {
        let (w, h) = (self.width as usize, self.height as usize);
        if w == 0 || h == 0 || self.data.len() < w * h || !uv.is_finite() {
            return Color::ZERO;
        }
        let x = uv.x * w as f32 - 0.5;
        let y = uv.y * h as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let ix0 = (x0 as i64).rem_euclid(w as i64) as usize;
        let iy0 = (y0 as i64).rem_euclid(h as i64) as usize;
        let ix1 = if ix0 + 1 == w { 0 } else { ix0 + 1 };
        let iy1 = if iy0 + 1 == h { 0 } else { iy0 + 1 };
        let at = |ix: usize, iy: usize| self.data[iy * w + ix];
        let top = at(ix0, iy0) * (1.0 - fx) + at(ix1, iy0) * fx;
        let bottom = at(ix0, iy1) * (1.0 - fx) + at(ix1, iy1) * fx;
        top * (1.0 - fy) + bottom * fy
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::material::Texture;

    #[test]
    fn image_lookup_is_bilinear_with_repeat_and_mitsuba_v() {
        // 2x2 image: row 0 (top) = red, green; row 1 (bottom) = blue, white
        let im = Image { width: 2, height: 2, data: vec![Color::X, Color::Y, Color::Z, Color::ONE] };
        let near = |a: Color, b: Color| (a - b).abs().max_element() < 1e-5;
        assert!(near(im.lookup(Vec2::new(0.25, 0.25)), Color::X), "v = 0 is the top row");
        assert!(near(im.lookup(Vec2::new(0.75, 0.25)), Color::Y));
        assert!(near(im.lookup(Vec2::new(0.25, 0.75)), Color::Z), "bottom-left texel centre");
        assert!(near(im.lookup(Vec2::new(0.75, 0.75)), Color::ONE));
        // halfway between the two top texels, and between the two left texels
        assert!(near(im.lookup(Vec2::new(0.5, 0.25)), Color::new(0.5, 0.5, 0.0)));
        assert!(near(im.lookup(Vec2::new(0.25, 0.5)), Color::new(0.5, 0.0, 0.5)));
        // repeat wrap: the image corner blends all four texels, and uv is periodic
        assert!(near(im.lookup(Vec2::ZERO), Color::splat(0.5)));
        assert!(near(im.lookup(Vec2::new(0.5, 0.0)), Color::splat(0.5)));
        let uv = Vec2::new(0.3, 0.6);
        assert!(near(im.lookup(uv + Vec2::new(1.0, -2.0)), im.lookup(uv)));
        assert!(near(im.lookup(uv + Vec2::new(-3.0, 5.0)), im.lookup(uv)));
        assert_eq!(Image::default().lookup(uv), Color::ZERO);
        assert_eq!(im.lookup(Vec2::new(f32::NAN, 0.0)), Color::ZERO);
        // a non-square image: column index from u, row index from v
        let wide = Image { width: 4, height: 1, data: vec![Color::ZERO, Color::X, Color::Y, Color::Z] };
        assert!(near(wide.lookup(Vec2::new(0.375, 0.5)), Color::X) && near(wide.lookup(Vec2::new(0.875, 0.9)), Color::Z));
        // textures go through the uv scale
        let tex = Texture::Bitmap { image: 0, uv_scale: Vec2::splat(2.0) };
        assert!(near(tex.eval(std::slice::from_ref(&im), Vec2::new(0.125, 0.125)), Color::X));
    }
}
