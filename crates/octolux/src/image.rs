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
        let Some(([i00, i10, i01, i11], fx, fy)) = self.bilinear_taps(uv) else { return Color::ZERO };
        let top = self.data[i00] * (1.0 - fx) + self.data[i10] * fx;
        let bottom = self.data[i01] * (1.0 - fx) + self.data[i11] * fx;
        top * (1.0 - fy) + bottom * fy
    }

    /// The texels of the bilinear, repeat-wrapped lookup at `uv` ([`Image::lookup`]'s
    /// convention): indices into `data` of `(x0, y0)`, `(x1, y0)`, `(x0, y1)`, `(x1, y1)`, and
    /// the weights `(fx, fy)` of `x1` and `y1`. `None` for an empty or inconsistent image or a
    /// non-finite `uv`.
    pub fn bilinear_taps(&self, uv: Vec2) -> Option<([usize; 4], f32, f32)> {
        let (w, h) = (self.width as usize, self.height as usize);
        if w == 0 || h == 0 || self.data.len() < w * h || !uv.is_finite() {
            return None;
        }
        let x = uv.x * w as f32 - 0.5;
        let y = uv.y * h as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (ix0, iy0) = (wrap(x0 as i64, w), wrap(y0 as i64, h));
        let ix1 = if ix0 + 1 == w { 0 } else { ix0 + 1 };
        let iy1 = if iy0 + 1 == h { 0 } else { iy0 + 1 };
        Some(([iy0 * w + ix0, iy0 * w + ix1, iy1 * w + ix0, iy1 * w + ix1], x - x0, y - y0))
    }

    /// Ask the CPU to bring the four texels of [`Image::lookup`] at `uv` into its cache, so that
    /// a lookup made a little later finds them there (no effect on any value). Textures of a few
    /// megapixels do not stay in cache: on sponza the bilinear reads were 15% of the path
    /// tracer's time, most of it waiting for memory. No-op off x86-64.
    #[inline]
    pub fn prefetch(&self, uv: Vec2) {
        #[cfg(target_arch = "x86_64")]
        if let Some((taps, _, _)) = self.bilinear_taps(uv) {
            for i in taps {
                let p = self.data.as_ptr().wrapping_add(i) as *const i8;
                // SAFETY: a prefetch never faults and reads nothing into the program; `p` lies
                // in `data` (`bilinear_taps` checked `data.len() >= width · height`).
                #[allow(unused_unsafe)]
                unsafe {
                    std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p)
                };
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = uv;
    }

    /// The texel containing `uv` (Mitsuba's `nearest` filter: `⌊u·W⌋, ⌊v·H⌋`, repeat wrap).
    /// An empty or inconsistent image, or a non-finite `uv`, reads as black.
    pub fn nearest(&self, uv: Vec2) -> Color {
        let (w, h) = (self.width as usize, self.height as usize);
        if w == 0 || h == 0 || self.data.len() < w * h || !uv.is_finite() {
            return Color::ZERO;
        }
        let ix = wrap((uv.x * w as f32).floor() as i64, w);
        let iy = wrap((uv.y * h as f32).floor() as i64, h);
        self.data[iy * w + ix]
    }

    /// The next MIP level: `max(1, ⌈n/2⌉)` texels along each axis (Mitsuba 0.6's level
    /// sizes), each the area-weighted mean of the texels it covers (a box filter; for odd
    /// sizes a texel is shared by two with fractional weights). The mean of the image is kept.
    pub fn downsampled(&self) -> Image {
        let (w, h) = (self.width as usize, self.height as usize);
        if w == 0 || h == 0 || self.data.len() < w * h {
            return Image::default();
        }
        let (nw, nh) = (w.div_ceil(2).max(1), h.div_ceil(2).max(1));
        let wx = box_weights(w, nw);
        let wy = box_weights(h, nh);
        // Rows first (w → nw), then columns (h → nh); f64 sums. Each output row sums the
        // horizontal sums of its input rows (an input row shared by two output rows is summed
        // again for each, the same bits), so the rows are independent: computed in parallel,
        // without a buffer of the whole image.
        use rayon::prelude::*;
        let mut data = vec![Color::ZERO; nw * nh];
        data.par_chunks_mut(nw).zip(wy.par_iter()).for_each(|(out, taps_y)| {
            let mut acc = vec![[0.0f64; 3]; nw];
            for &(iy, wt_y) in taps_y {
                let src = &self.data[iy * w..(iy + 1) * w];
                for (a, taps) in acc.iter_mut().zip(&wx) {
                    let mut row = [0.0f64; 3];
                    for &(i, wt) in taps {
                        let c = src[i];
                        row[0] += wt * c.x as f64;
                        row[1] += wt * c.y as f64;
                        row[2] += wt * c.z as f64;
                    }
                    a[0] += wt_y * row[0];
                    a[1] += wt_y * row[1];
                    a[2] += wt_y * row[2];
                }
            }
            for (o, a) in out.iter_mut().zip(&acc) {
                *o = Color::new(a[0] as f32, a[1] as f32, a[2] as f32);
            }
        });
        Image { width: nw as u32, height: nh as u32, data }
    }

    /// The MIP levels below this image, finest first, down to 1x1 (empty for a 1x1 or empty
    /// image).
    pub fn mip_pyramid(&self) -> Vec<Image> {
        let mut levels: Vec<Image> = Vec::new();
        loop {
            let last = levels.last().unwrap_or(self);
            if last.width <= 1 && last.height <= 1 || last.data.is_empty() {
                return levels;
            }
            let next = last.downsampled();
            levels.push(next);
        }
    }
}

/// For each of `m` output texels covering `n` input texels, the input texels it overlaps and
/// the weights (overlap / output width, summing to 1).
/// `i` wrapped into `0..n` (`n > 0`), as `rem_euclid`; without the 64-bit division when `i` is
/// already in range, the common case of texture coordinates in [0, 1] (the division was a
/// visible part of a texture lookup's cost).
#[inline]
fn wrap(i: i64, n: usize) -> usize {
    if (0..n as i64).contains(&i) {
        i as usize
    } else {
        i.rem_euclid(n as i64) as usize
    }
}

fn box_weights(n: usize, m: usize) -> Vec<Vec<(usize, f64)>> {
    let s = n as f64 / m as f64;
    (0..m)
        .map(|j| {
            let (a, b) = (j as f64 * s, (j + 1) as f64 * s);
            let (lo, hi) = (a.floor() as usize, (b.ceil() as usize).min(n));
            (lo..hi)
                .filter_map(|i| {
                    let overlap = (b.min(i as f64 + 1.0) - a.max(i as f64)).max(0.0);
                    (overlap > 0.0).then_some((i, overlap / s))
                })
                .collect()
        })
        .collect()
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
        let tex = Texture::bitmap(0, Vec2::splat(2.0));
        assert!(near(tex.eval(std::slice::from_ref(&im), Vec2::new(0.125, 0.125)), Color::X));
    }

    /// The next MIP level, row by row in parallel, holds the bits of the two-pass form (every
    /// row's horizontal sums first, then the columns), for even, odd and unit sizes.
    #[test]
    fn downsampled_equals_the_two_pass_box_filter() {
        let two_pass = |im: &Image| -> Vec<[u32; 3]> {
            let (w, h) = (im.width as usize, im.height as usize);
            let (nw, nh) = (w.div_ceil(2).max(1), h.div_ceil(2).max(1));
            let (wx, wy) = (box_weights(w, nw), box_weights(h, nh));
            let rows: Vec<[f64; 3]> = (0..h)
                .flat_map(|y| {
                    wx.iter().map(move |taps| {
                        let mut a = [0.0f64; 3];
                        for &(i, wt) in taps {
                            let c = im.data[y * w + i];
                            (0..3).for_each(|k| a[k] += wt * c[k] as f64);
                        }
                        a
                    })
                })
                .collect();
            let mut out = Vec::new();
            for taps in &wy {
                for x in 0..nw {
                    let mut a = [0.0f64; 3];
                    for &(i, wt) in taps {
                        (0..3).for_each(|k| a[k] += wt * rows[i * nw + x][k]);
                    }
                    out.push(a.map(|v| (v as f32).to_bits()));
                }
            }
            out
        };
        for (w, h) in [(1usize, 1usize), (1, 7), (6, 1), (8, 6), (7, 5), (33, 18), (64, 63)] {
            let data =
                (0..w * h).map(|i| Color::new((i as f32 * 0.37).sin().abs(), (i % 13) as f32 / 7.0, 1.0 / (1.0 + i as f32))).collect();
            let im = Image { width: w as u32, height: h as u32, data };
            let next = im.downsampled();
            assert_eq!((next.width as usize, next.height as usize), (w.div_ceil(2), h.div_ceil(2)));
            let got: Vec<[u32; 3]> = next.data.iter().map(|c| c.to_array().map(f32::to_bits)).collect();
            assert!(got == two_pass(&im), "{w}x{h}");
        }
    }
}
