//! Image input and output on [`octolux::image::Image`] (linear RGB, row 0 at the top).
//!
//! - OpenEXR is written as 32-bit float RGB (lossless compression), so a write/read round trip
//!   is bit-exact; reading accepts any RGB(A) EXR (half, float or uint samples; alpha ignored).
//! - PNG output applies the sRGB transfer function (IEC 61966-2-1) to the clamped linear values
//!   and rounds to 8 bits; NaN becomes 0.
//! - Textures ([`read_image`]): PNG/JPEG are sRGB-encoded and converted to linear (as Mitsuba's
//!   `bitmap` does for 8-bit images with `raw = false`); EXR and Radiance HDR are linear.
//!
//! Every output is written atomically: the data goes to a temporary file in the destination
//! folder, which is renamed over the destination only once complete, so a failed or interrupted
//! write never leaves a truncated file under the final name.

use crate::IoError;
use octolux::image::Image;
use octolux::math::Color;
use std::path::Path;

/// sRGB transfer function (linear -> encoded), for values in `[0, 1]`.
#[inline]
pub fn linear_to_srgb(v: f32) -> f32 {
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Inverse sRGB transfer function (encoded -> linear), for values in `[0, 1]`.
#[inline]
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.040_45 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Encode one linear value as an 8-bit sRGB code (clamped to `[0, 1]`, NaN -> 0, rounded).
#[inline]
pub fn encode_srgb8(v: f32) -> u8 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    (linear_to_srgb(v) * 255.0 + 0.5).floor().clamp(0.0, 255.0) as u8
}

/// Write a file atomically, by the rule of [`crate::files`]: the target is checked (a regular
/// file or nothing, not an input), `write` produces the complete file at the staging path it is
/// given (an error message on failure), and on success it is renamed to `path` after a second
/// check. On any failure the staged file is removed and `path` is left untouched.
pub fn write_atomically(path: &Path, write: impl FnOnce(&Path) -> Result<(), String>) -> Result<(), IoError> {
    if path.file_name().is_none() {
        return Err(IoError::invalid(path, "output path has no file name"));
    }
    crate::files::recheck_output(path).map_err(IoError::Output)?;
    let tmp = crate::files::staging_name(path, "tmp");
    crate::files::note_staged(&tmp);
    let result = match write(&tmp) {
        Err(msg) => Err(IoError::invalid(path, format!("could not write: {msg}"))),
        Ok(()) => crate::files::recheck_output(path)
            .map_err(IoError::Output)
            .and_then(|()| std::fs::rename(&tmp, path).map_err(|e| IoError::os(path, e))),
    };
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    crate::files::forget_staged(&tmp);
    result
}

/// Write bytes to a file atomically (see [`write_atomically`]).
pub fn write_bytes_atomically(path: &Path, bytes: &[u8]) -> Result<(), IoError> {
    write_atomically(path, |tmp| std::fs::write(tmp, bytes).map_err(|e| e.to_string()))
}

fn check_image(path: &Path, img: &Image) -> Result<(), IoError> {
    if img.width == 0 || img.height == 0 {
        return Err(IoError::invalid(path, format!("cannot write an empty {}x{} image", img.width, img.height)));
    }
    if img.data.len() != img.width as usize * img.height as usize {
        return Err(IoError::invalid(path, format!("image data has {} pixels, expected {}x{}", img.data.len(), img.width, img.height)));
    }
    Ok(())
}

/// Write a 32-bit float RGB OpenEXR file (atomically). Blocks are stored in increasing line
/// order (RLE-compressed 64x64 tiles), so equal images give byte-identical files whatever the
/// order in which the encoder's threads finish.
pub fn write_exr(path: &Path, img: &Image) -> Result<(), IoError> {
    use exr::prelude::{Encoding, Layer, LayerAttributes, LineOrder, SpecificChannels, Vec2, WritableImage};
    check_image(path, img)?;
    let w = img.width as usize;
    let channels = SpecificChannels::rgb(|Vec2(x, y): Vec2<usize>| {
        let c = img.data[y * w + x];
        (c.x, c.y, c.z)
    });
    let encoding = Encoding { line_order: LineOrder::Increasing, ..Encoding::FAST_LOSSLESS };
    let layer = Layer::new((w, img.height as usize), LayerAttributes::default(), encoding, channels);
    let image = exr::prelude::Image::from_layer(layer);
    write_atomically(path, |tmp| image.write().to_file(tmp).map_err(|e| e.to_string()))
}

/// Read the first RGB(A) layer of an OpenEXR file as linear RGB (alpha is ignored).
pub fn read_exr(path: &Path) -> Result<Image, IoError> {
    let bytes = crate::files::read(path)?;
    decode_exr(path, &bytes)
}

/// Decode OpenEXR bytes (see [`read_exr`]); `path` names the data in messages. The header's
/// size is checked against the file size and the memory budget ([`octolux::budget`]) before
/// any pixel is allocated.
pub fn decode_exr(path: &Path, bytes: &[u8]) -> Result<Image, IoError> {
    let invalid = |e: exr::error::Error| IoError::invalid(path, format!("not a readable RGB OpenEXR file: {e}"));
    // Headers only (no pixel data): sizes are validated before decoding.
    let meta = exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(bytes), false).map_err(invalid)?;
    for h in &meta.headers {
        let (w, hh) = (h.layer_size.width() as u64, h.layer_size.height() as u64);
        octolux::budget::check_image(w, hh).map_err(|e| IoError::invalid(path, e.to_string()))?;
    }
    use exr::prelude::{ReadChannels, ReadLayers};
    let result = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |res: exr::math::Vec2<usize>, _: &exr::prelude::RgbaChannels| Image {
                width: res.width() as u32,
                height: res.height() as u32,
                data: vec![Color::ZERO; res.width() * res.height()],
            },
            |img: &mut Image, pos: exr::math::Vec2<usize>, (r, g, b, _a): (f32, f32, f32, f32)| {
                let i = pos.y() * img.width as usize + pos.x();
                if let Some(p) = img.data.get_mut(i) {
                    *p = Color::new(r, g, b);
                }
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(bytes));
    match result {
        Ok(image) => {
            let img = image.layer_data.channel_data.pixels;
            if img.width == 0 || img.height == 0 {
                return Err(IoError::invalid(path, "the EXR image is empty"));
            }
            Ok(img)
        }
        // no R, G, B: a grey image of one channel (`Y`, or the only one), as Mitsuba writes
        Err(e) => decode_exr_grey(path, bytes).unwrap_or_else(|| Err(invalid(e))),
    }
}

/// A one-channel OpenEXR image (its `Y` channel, or its only channel) as grey RGB; `None`
/// when the file has no such channel (the RGB reader's error is then the answer).
fn decode_exr_grey(path: &Path, bytes: &[u8]) -> Option<Result<Image, IoError>> {
    use exr::prelude::{ReadChannels, ReadLayers};
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(bytes))
        .ok()?;
    let layer = image.layer_data;
    let list = &layer.channel_data.list;
    let channel = list.iter().find(|c| c.name.eq("Y")).or_else(|| (list.len() == 1).then(|| &list[0]))?;
    let (w, h) = (layer.size.width(), layer.size.height());
    if w == 0 || h == 0 {
        return Some(Err(IoError::invalid(path, "the EXR image is empty")));
    }
    let data: Vec<Color> = channel.sample_data.values_as_f32().map(Color::splat).collect();
    if data.len() != w * h {
        return Some(Err(IoError::invalid(path, format!("the EXR channel holds {} values for {w}x{h} pixels", data.len()))));
    }
    Some(Ok(Image { width: w as u32, height: h as u32, data }))
}

/// The pixels as 8-bit sRGB RGB bytes, as the PNG output develops them ([`encode_srgb8`]).
pub fn srgb8_bytes(img: &Image) -> Vec<u8> {
    img.data.iter().flat_map(|c| [encode_srgb8(c.x), encode_srgb8(c.y), encode_srgb8(c.z)]).collect()
}

/// Write an 8-bit sRGB PNG (values clamped to `[0, 1]`, atomically).
pub fn write_png(path: &Path, img: &Image) -> Result<(), IoError> {
    check_image(path, img)?;
    let bytes = srgb8_bytes(img);
    let buf =
        image::RgbImage::from_raw(img.width, img.height, bytes).ok_or_else(|| IoError::invalid(path, "image buffer size mismatch"))?;
    write_atomically(path, |tmp| buf.save_with_format(tmp, image::ImageFormat::Png).map_err(|e| e.to_string()))
}

/// PNG bytes of 8-bit RGB pixels (`rgb.len() == 3 * width * height`), for embedding.
pub fn encode_png_rgb8(width: u32, height: u32, rgb: Vec<u8>) -> Result<Vec<u8>, String> {
    let buf = image::RgbImage::from_raw(width, height, rgb).ok_or("image buffer size mismatch")?;
    let mut out = std::io::Cursor::new(Vec::new());
    buf.write_to(&mut out, image::ImageFormat::Png).map_err(|e| e.to_string())?;
    Ok(out.into_inner())
}

/// Texels checked as colours are (a colour with NaN or a negative component is refused): a
/// non-finite texel is an error; negative texels, which filters and denoisers leave in HDR
/// files, are clamped to 0 with the warning returned (the values a colour may not have).
pub fn check_texels(path: &Path, img: &mut Image) -> Result<Option<String>, IoError> {
    let bad = img.data.iter().filter(|c| !c.is_finite()).count();
    if bad > 0 {
        let first = img.data.iter().position(|c| !c.is_finite()).unwrap_or(0);
        let (x, y) = (first % img.width.max(1) as usize, first / img.width.max(1) as usize);
        return Err(IoError::invalid(
            path,
            format!("{bad} texels hold NaN or infinite values (the first at x {x}, y {y}); a texture's values must be finite"),
        ));
    }
    let negative = img.data.iter().filter(|c| c.min_element() < 0.0).count();
    if negative == 0 {
        return Ok(None);
    }
    let lowest = img.data.iter().map(|c| c.min_element()).fold(0.0f32, f32::min);
    for c in &mut img.data {
        *c = c.max(Color::ZERO);
    }
    Ok(Some(format!("{}: {negative} texels have negative values (the lowest {lowest}); clamped to 0", path.display())))
}

/// [`read_image`] and [`check_texels`]: a texture as materials and lights read it, with the
/// warning of its negative texels if any.
pub fn read_texture(path: &Path) -> Result<(Image, Option<String>), IoError> {
    let mut img = read_image(path)?;
    let warning = check_texels(path, &mut img)?;
    Ok((img, warning))
}

/// The memory budget of a scene's images together, `new` added to `images` (each file is
/// checked alone when it is read; a small scene may name one large image many times: under
/// several names in Mitsuba, as many glTF images over one buffer view).
pub fn check_scene_texels(images: &[Image], new: &Image) -> Result<(), octolux::budget::BudgetError> {
    let texels = images.iter().map(|i| i.data.len() as u64).sum::<u64>() + new.data.len() as u64;
    octolux::budget::check_items(
        || format!("the scene's images together, with this one: {texels} texels"),
        texels,
        octolux::budget::TEXEL_BYTES,
    )
}

/// The image formats [`read_image`] reads, for messages.
const IMAGE_FORMATS: &str = "png, jpg, exr or hdr";

/// Read a texture as linear RGB: `.exr` and `.hdr` are linear, `.png`/`.jpg`/`.jpeg` are
/// sRGB-decoded. Alpha is dropped; grey images are replicated to RGB.
pub fn read_image(path: &Path) -> Result<Image, IoError> {
    crate::files::refuse_non_regular(path)?;
    let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()).unwrap_or_default();
    if !matches!(ext.as_str(), "exr" | "hdr" | "rgbe" | "pic" | "png" | "jpg" | "jpeg") {
        return Err(crate::files::unknown_format(path, "image", IMAGE_FORMATS));
    }
    let bytes = crate::files::read(path)?;
    decode_image(path, &bytes)
}

/// Decode image bytes as [`read_image`] does, the format chosen by `path`'s extension (which
/// also names the data in messages). The header's size is checked against the memory budget
/// ([`octolux::budget`]) before decoding, and the decoder's own allocations are capped by it.
pub fn decode_image(path: &Path, bytes: &[u8]) -> Result<Image, IoError> {
    let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()).unwrap_or_default();
    let srgb = match ext.as_str() {
        "exr" => return decode_exr(path, bytes),
        "hdr" | "rgbe" | "pic" => false,
        "png" | "jpg" | "jpeg" => true,
        _ => return Err(crate::files::unknown_format(path, "image", IMAGE_FORMATS)),
    };
    let decode_err = |e: image::ImageError| match e {
        image::ImageError::IoError(e) => IoError::os(path, e),
        image::ImageError::Limits(e) => IoError::invalid(
            path,
            format!("could not decode image: {e} (memory limit {})", octolux::budget::format_bytes(octolux::budget::memory_limit())),
        ),
        e => IoError::invalid(path, format!("could not decode image: {e}")),
    };
    // Mitsuba (and other writers) start Radiance files with `#?RGBE`, which the decoder does not
    // know; the format is the same as under `#?RADIANCE`
    let renamed;
    let bytes = match bytes.strip_prefix(b"#?RGBE") {
        Some(rest) if !srgb => {
            renamed = [&b"#?RADIANCE"[..], rest].concat();
            &renamed[..]
        }
        _ => bytes,
    };
    let open = || image::ImageReader::new(std::io::Cursor::new(bytes)).with_guessed_format().map_err(|e| IoError::os(path, e));
    let (w, h) = open()?.into_dimensions().map_err(decode_err)?;
    octolux::budget::check_image(w as u64, h as u64).map_err(|e| IoError::invalid(path, e.to_string()))?;
    let mut reader = open()?;
    let mut limits = image::Limits::no_limits();
    limits.max_alloc = Some(octolux::budget::memory_limit());
    reader.limits(limits);
    let decoded = reader.decode().map_err(decode_err)?;
    let (width, height) = (decoded.width(), decoded.height());
    if width == 0 || height == 0 {
        return Err(IoError::invalid(path, "the image is empty"));
    }
    let data = if srgb && matches!(decoded.color(), image::ColorType::Rgb8 | image::ColorType::Rgba8) {
        // 8-bit RGB(A): the 256 possible codes through a table, same values as below (grey
        // images are left to the decoder's own conversion to RGB)
        let lut = srgb8_to_linear_table();
        decoded.into_rgb8().pixels().map(|p| Color::new(lut[p.0[0] as usize], lut[p.0[1] as usize], lut[p.0[2] as usize])).collect()
    } else {
        let conv = |v: f32| if srgb { srgb_to_linear(v) } else { v };
        decoded.to_rgb32f().pixels().map(|p| Color::new(conv(p.0[0]), conv(p.0[1]), conv(p.0[2]))).collect()
    };
    Ok(Image { width, height, data })
}

/// [`srgb_to_linear`] of each 8-bit code as the decoder's conversion to float gives it (the
/// codes of a 256-texel ramp through `to_rgb32f`), so that a table lookup equals the
/// per-texel `powf` bit for bit.
fn srgb8_to_linear_table() -> &'static [f32; 256] {
    static TABLE: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let ramp = image::DynamicImage::ImageRgb8(image::RgbImage::from_fn(256, 1, |x, _| image::Rgb([x as u8; 3]))).to_rgb32f();
        std::array::from_fn(|i| srgb_to_linear(ramp.get_pixel(i as u32, 0).0[0]))
    })
}
