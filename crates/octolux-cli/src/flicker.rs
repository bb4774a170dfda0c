//! `octolux flicker FRAMES --reference REF [--scene S --camera-path P]`: the temporal stability
//! of a frame sequence against a reference sequence of the same frames
//! ([`octolux::flicker`], issue 13 item 3, docs/guide/baking.md). Frames are the `NAME_0001.exr`,
//! `NAME_0002.exr`, ... files of a folder, as `render --camera-path` writes them; the two
//! folders must hold the same frame numbers. With the scene and its camera path, static world
//! points (seen through the first frame's pixels) are reprojected into every frame, hidden ones
//! dropped by a visibility ray, and the spread of their values over frames is measured too.

use crate::args::{FlickerArgs, SceneArgs};
use anyhow::{bail, Context, Result};
use glam::Vec2;
use octolux::accel::BackendKind;
use octolux::flicker::{measure, Track};
use octolux::image::Image;
use octolux::math::Ray;
use octolux::scene::camera::Camera;
use octolux::scene::Scene;
use serde_json::json;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The frame number of `NAME_0012.exr` (12), if the name has that form.
fn frame_number(path: &Path) -> Option<u64> {
    if !path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
        return None;
    }
    let stem = path.file_stem()?.to_str()?;
    let (_, digits) = stem.rsplit_once('_')?;
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    digits.parse().ok()
}

/// The numbered frames of a folder, by number; two files with one number are an error.
fn list_frames(dir: &Path) -> Result<BTreeMap<u64, PathBuf>> {
    let mut frames = BTreeMap::new();
    for e in std::fs::read_dir(dir).with_context(|| format!("cannot read frame folder {}", dir.display()))? {
        let p = e.with_context(|| format!("cannot read frame folder {}", dir.display()))?.path();
        if let Some(i) = frame_number(&p) {
            if let Some(other) = frames.insert(i, p.clone()) {
                bail!("{} and {} both claim frame {i}: keep one sequence per folder", other.display(), p.display());
            }
        }
    }
    if frames.len() < 2 {
        bail!("{} holds {} numbered frames (NAME_0001.exr, ...): a flicker measure needs at least 2", dir.display(), frames.len());
    }
    Ok(frames)
}

fn read(path: &Path) -> Result<Image> {
    let img = octolux_io::image_io::read_exr(path).with_context(|| format!("cannot read {}", path.display()))?;
    if img.data.iter().any(|c| !c.is_finite()) {
        bail!("{} holds non-finite values (NaN or infinity)", path.display());
    }
    Ok(img)
}

/// Static points seen through a grid of about `count` pixels of the first frame, and their film
/// positions in every frame (`None` where the visibility ray stops short of them).
fn tracks(args: &FlickerArgs, scene_name: &str, indices: &[u64], w: u32, h: u32) -> Result<Vec<Track>> {
    let Some(path_file) = &args.camera_path else {
        bail!("--scene needs --camera-path: the cameras of the frames");
    };
    let path = octolux_io::job::frames::read_camera_path(path_file)?;
    if let Some(&i) = indices.iter().find(|&&i| i == 0 || i > path.frame_count()) {
        bail!("frame {i} is not a frame of camera path {} ({} frames)", path_file.display(), path.frame_count());
    }
    let loaded = crate::load(&SceneArgs { scene: scene_name.to_string(), define: args.define.clone(), allow_outside_uris: false })?;
    let base = loaded.desc.camera.clone();
    let scene = Scene::prepare(loaded.desc, BackendKind::Auto).with_context(|| format!("cannot prepare scene '{scene_name}'"))?;
    let cams: Vec<Camera> = indices.iter().map(|&i| Camera::new(&path.pose_at(path.frame_time(i)).camera(&base), w, h)).collect();
    let stride = ((w as f64 * h as f64 / args.points.max(1) as f64).sqrt().floor() as u32).max(1);
    let mut out = Vec::new();
    for y in (stride / 2..h).step_by(stride as usize) {
        for x in (stride / 2..w).step_by(stride as usize) {
            let (o, d, tmin) = cams[0].generate_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let Some(hit) = scene.intersect(&Ray { o, d, tmin, tmax: f32::INFINITY }) else { continue };
            if hit.light.is_some() {
                continue; // emitters are exact in every method
            }
            let track = cams
                .iter()
                .map(|cam| {
                    let film = cam.project(hit.p)?;
                    let v = hit.p - cam.position();
                    let dist = v.length();
                    let back = scene.intersect(&Ray::new(cam.position(), v / dist))?;
                    ((back.t - dist).abs() <= 1e-3 * dist + 1e-4).then_some(film)
                })
                .collect();
            out.push(track);
        }
    }
    Ok(out)
}

pub fn cmd_flicker(args: &FlickerArgs) -> Result<()> {
    let frames = list_frames(&args.frames)?;
    let refs = list_frames(&args.reference)?;
    let indices: Vec<u64> = frames.keys().copied().collect();
    if let Some(i) = indices.iter().find(|i| !refs.contains_key(i)) {
        bail!("frame {i} ({}) has no reference in {}", frames[i].display(), args.reference.display());
    }
    let a: Vec<Image> = frames.values().map(|p| read(p)).collect::<Result<_>>()?;
    let r: Vec<Image> = indices.iter().map(|i| read(&refs[i])).collect::<Result<_>>()?;
    let tracks = match &args.scene {
        Some(s) => tracks(args, s, &indices, a[0].width, a[0].height)?,
        None if args.camera_path.is_some() => bail!("--camera-path needs --scene: static points are found in the scene"),
        None => Vec::new(),
    };
    let report =
        measure(&a, &r, &tracks, args.border).with_context(|| format!("cannot measure the frames of {}", args.frames.display()))?;
    let out = json!({
        "frames": args.frames.display().to_string(),
        "reference": args.reference.display().to_string(),
        "first": indices[0],
        "last": indices[indices.len() - 1],
        "border": args.border,
        "tracks": tracks.len(),
        "flicker": report,
    });
    crate::print_out(&serde_json::to_string_pretty(&out)?)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_numbers_from_names() {
        assert_eq!(frame_number(Path::new("d/out_0012.exr")), Some(12));
        assert_eq!(frame_number(Path::new("a_b_3.EXR")), Some(3));
        assert_eq!(frame_number(Path::new("out_0012.png")), None);
        assert_eq!(frame_number(Path::new("out.exr")), None);
        assert_eq!(frame_number(Path::new("out_.exr")), None);
        assert_eq!(frame_number(Path::new("out_1x.exr")), None);
    }
}
