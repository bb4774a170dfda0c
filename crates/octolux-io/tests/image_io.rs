//! Image I/O: bit-exact EXR round trip, sRGB PNG encoding of known values, texture decoding,
//! error reporting and atomic writes.

use octolux::image::Image;
use octolux::math::Color;
use octolux_io::image_io::{encode_srgb8, read_exr, read_image, srgb_to_linear, write_atomically, write_exr, write_png};
use octolux_io::IoError;
use std::path::{Path, PathBuf};

fn tmp_dir(test: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("image_io").join(test);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Files in `dir` other than `keep` (temporary files must not be left behind).
fn others(dir: &Path, keep: &[&str]) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !keep.contains(&n.as_str()))
        .collect()
}

#[test]
fn exr_round_trip_is_bit_exact() {
    let dir = tmp_dir("exr_round_trip");
    let (w, h) = (7u32, 5u32);
    let special = [0.0f32, -0.0, 1.0, -3.5, 1e-30, 1.17e-40, 65504.0, 1e30, 0.1, std::f32::consts::PI];
    let data: Vec<Color> = (0..w * h)
        .map(|i| {
            let f = |k: u32| {
                special[((i * 3 + k) as usize) % special.len()] * if (i + k).is_multiple_of(4) { 1.0 } else { (i + 1) as f32 * 0.37 }
            };
            Color::new(f(0), f(1), f(2))
        })
        .collect();
    let img = Image { width: w, height: h, data };
    let path = dir.join("out.exr");
    write_exr(&path, &img).unwrap();
    let back = read_exr(&path).unwrap();
    assert_eq!((back.width, back.height), (w, h));
    for (i, (a, b)) in img.data.iter().zip(&back.data).enumerate() {
        for k in 0..3 {
            assert_eq!(a[k].to_bits(), b[k].to_bits(), "pixel {i} channel {k}: wrote {} read {}", a[k], b[k]);
        }
    }
    // read_image dispatches .exr to the same linear reader.
    assert_eq!(read_image(&path).unwrap().data, back.data);
    assert!(others(&dir, &["out.exr"]).is_empty());
}

#[test]
fn srgb_encoding_of_known_values() {
    // Reference codes from the sRGB definition: 0.5 -> 0.7354 -> 188; 0.0031308 is the knee
    // (0.04045 -> 10.3 -> 10); 0.214 -> 0.49996 -> 127.49 -> 127 and 0.2158 -> 0.5019 -> 128;
    // out-of-range values clamp.
    let cases = [
        (0.0f32, 0u8),
        (1.0, 255),
        (0.5, 188),
        (0.003_130_8, 10),
        (0.214, 127),
        (0.2158, 128),
        (0.001, 3),
        (2.0, 255),
        (-1.0, 0),
        (f32::NAN, 0),
        (f32::INFINITY, 255),
    ];
    for (v, code) in cases {
        assert_eq!(encode_srgb8(v), code, "linear {v}");
    }
    let dir = tmp_dir("png_known_values");
    let data: Vec<Color> =
        cases.chunks(3).map(|c| Color::new(c[0].0, c.get(1).map_or(0.0, |x| x.0), c.get(2).map_or(0.0, |x| x.0))).collect();
    let img = Image { width: data.len() as u32, height: 1, data };
    let path = dir.join("known.png");
    write_png(&path, &img).unwrap();
    let decoded = image::open(&path).unwrap().to_rgb8();
    let bytes: Vec<u8> = decoded.pixels().flat_map(|p| p.0).collect();
    let expect: Vec<u8> = cases.chunks(3).flat_map(|c| [c[0].1, c.get(1).map_or(0, |x| x.1), c.get(2).map_or(0, |x| x.1)]).collect();
    assert_eq!(bytes, expect);
    assert!(others(&dir, &["known.png"]).is_empty());
}

#[test]
fn png_texture_is_decoded_to_linear() {
    let dir = tmp_dir("png_texture");
    // Row 0 at the top: a 2x2 image with distinct pixels.
    let data = vec![Color::new(0.5, 0.0, 1.0), Color::new(0.2, 0.04, 0.9), Color::splat(0.01), Color::new(1.0, 0.75, 0.3)];
    let img = Image { width: 2, height: 2, data: data.clone() };
    let path = dir.join("tex.png");
    write_png(&path, &img).unwrap();
    let back = read_image(&path).unwrap();
    assert_eq!((back.width, back.height), (2, 2));
    for (a, b) in data.iter().zip(&back.data) {
        // 8-bit quantisation of the encoded value: error below half a code step through the
        // transfer function's slope.
        for k in 0..3 {
            let step = srgb_to_linear((encode_srgb8(a[k]) as f32 + 0.5) / 255.0)
                - srgb_to_linear((encode_srgb8(a[k]) as f32 - 0.5).max(0.0) / 255.0);
            assert!((a[k] - b[k]).abs() <= step, "wrote {a} read {b}");
        }
    }
    assert_eq!(srgb_to_linear(1.0), 1.0);
    assert_eq!(srgb_to_linear(0.0), 0.0);
}

#[test]
fn missing_and_corrupt_files_are_reported() {
    let dir = tmp_dir("errors");
    let missing = dir.join("missing.exr");
    match read_exr(&missing) {
        Err(IoError::Os { file, .. }) => assert_eq!(file, missing),
        other => panic!("expected an OS error, got {other:?}"),
    }
    match read_image(&dir.join("missing.png")) {
        Err(IoError::Os { file, .. }) => assert_eq!(file, dir.join("missing.png")),
        other => panic!("expected an OS error, got {other:?}"),
    }
    for name in ["corrupt.exr", "corrupt.png", "corrupt.jpg"] {
        let path = dir.join(name);
        std::fs::write(&path, b"this is not an image at all").unwrap();
        let err = read_image(&path).unwrap_err();
        assert!(matches!(err, IoError::Invalid { .. }), "{name}: {err:?}");
        assert!(err.to_string().contains(name), "message names the file: {err}");
    }
    let err = read_image(&dir.join("texture.tga")).unwrap_err();
    assert!(err.to_string().contains("unsupported"), "{err}");
}

#[test]
fn failed_writes_leave_no_file_and_keep_the_previous_one() {
    let dir = tmp_dir("atomic");
    let img = Image { width: 2, height: 1, data: vec![Color::ONE, Color::ZERO] };
    // Into a folder that does not exist: an error, nothing created.
    assert!(write_exr(&dir.join("nope/out.exr"), &img).is_err());
    assert!(write_png(&dir.join("nope/out.png"), &img).is_err());
    assert!(!dir.join("nope").exists());
    // A writer failing halfway: the existing file keeps its content, no temporary remains.
    let path = dir.join("result.txt");
    std::fs::write(&path, b"complete old result").unwrap();
    let r = write_atomically(&path, |tmp| {
        std::fs::write(tmp, b"half").map_err(|e| e.to_string())?;
        Err("simulated failure".to_string())
    });
    assert!(r.unwrap_err().to_string().contains("simulated failure"));
    assert_eq!(std::fs::read(&path).unwrap(), b"complete old result");
    assert!(others(&dir, &["result.txt"]).is_empty(), "{:?}", others(&dir, &["result.txt"]));
    // Image size inconsistent with its data: an error before anything is written.
    let bad = Image { width: 3, height: 3, data: vec![Color::ONE; 4] };
    assert!(write_exr(&dir.join("bad.exr"), &bad).is_err());
    assert!(!dir.join("bad.exr").exists());
    // A successful write replaces the old file.
    write_png(&path, &img).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "the PNG replaced the old content");
    assert!(others(&dir, &["result.txt"]).is_empty());
}

/// PNG/JPEG textures in 8-bit RGB(A) go through a table of the 256 codes, the other layouts
/// (grey, grey+alpha, 16 bits) through `powf` per texel: all give the bits of the
/// straightforward conversion (the decoder's float values through `srgb_to_linear`).
#[test]
fn srgb_textures_equal_the_per_texel_conversion() {
    use image::{DynamicImage, ImageFormat};
    let (w, h) = (256u32, 3u32);
    let code = |x: u32, y: u32, c: u32| ((x * (1 + 2 * c) + 37 * y + 11 * c) % 256) as u8;
    let rgba8 = image::RgbaImage::from_fn(w, h, |x, y| image::Rgba([code(x, y, 0), code(x, y, 1), code(x, y, 2), code(x, y, 3)]));
    let images = [
        ("l8", DynamicImage::ImageRgba8(rgba8.clone()).into_luma8().into()),
        ("la8", DynamicImage::ImageLumaA8(DynamicImage::ImageRgba8(rgba8.clone()).into_luma_alpha8())),
        ("rgb8", DynamicImage::ImageRgb8(DynamicImage::ImageRgba8(rgba8.clone()).into_rgb8())),
        ("rgba8", DynamicImage::ImageRgba8(rgba8.clone())),
        (
            "rgb16",
            DynamicImage::ImageRgb16(image::ImageBuffer::from_fn(w, h, |x, y| {
                image::Rgb([(x * 257 + y) as u16, (65535 - x * 200) as u16, (x * 131) as u16])
            })),
        ),
    ];
    for (name, im) in images {
        for (ext, format) in [("png", ImageFormat::Png), ("jpg", ImageFormat::Jpeg)] {
            if ext == "jpg" && !matches!(name, "l8" | "rgb8") {
                continue; // JPEG holds 8-bit grey or RGB only
            }
            let mut bytes = std::io::Cursor::new(Vec::new());
            im.write_to(&mut bytes, format).unwrap();
            let bytes = bytes.into_inner();
            let read = octolux_io::image_io::decode_image(std::path::Path::new(&format!("t.{ext}")), &bytes).unwrap();
            let want: Vec<[u32; 3]> =
                image::load_from_memory(&bytes).unwrap().to_rgb32f().pixels().map(|p| p.0.map(|v| srgb_to_linear(v).to_bits())).collect();
            let got: Vec<[u32; 3]> = read.data.iter().map(|c| c.to_array().map(f32::to_bits)).collect();
            assert_eq!((read.width, read.height), (w, h), "{name} {ext}");
            assert!(got == want, "{name} {ext}: the texels differ from the per-texel conversion");
        }
    }
}
