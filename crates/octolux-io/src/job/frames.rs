//! The frames of an animation (issue 13): a camera path file (`--camera-path`, interpolated
//! by `octolux::scene::camera_path`) or the `<sensor>`s of the scene file (`--sensors`), each
//! frame written as `OUT_0001.exr` (and its `.png`, `.json`) by the output rules of
//! [`super::output`]. `--frames A..B` keeps frames A to B (both included), so frames can be
//! spread over machines: a frame's image depends only on the lighting (one cache), its camera
//! and `--seed`, never on the other frames.

use super::{bail, Result};
use octolux::scene::camera::CameraDesc;
use octolux::scene::camera_path::CameraPath;
use octolux::scene::object_path::ObjectPath;
use serde::Serialize;
use std::path::Path;

/// One frame to render.
#[derive(Clone, Debug)]
pub struct Frame {
    /// From 1.
    pub index: u64,
    pub camera: CameraDesc,
    /// Seconds along the camera path (none for sensors).
    pub time_s: Option<f64>,
}

/// What `OUT_i.json` says of its frame.
#[derive(Serialize, Debug, Clone)]
pub struct FrameInfo {
    pub index: u64,
    /// Frames of the whole animation.
    pub count: u64,
    pub time_s: Option<f64>,
    /// `camera path FILE`, `sensors` or `object path FILE`.
    pub source: String,
}

/// The frames asked for.
pub struct Plan {
    pub frames: Vec<Frame>,
    /// Frames of the whole animation (numbers are padded for it).
    pub count: u64,
    pub source: String,
}

/// Read a camera path file (JSON or TOML by extension), validated, every frame's pose
/// included (`crate::paths`); errors name the file.
pub fn read_camera_path(path: &Path) -> Result<CameraPath> {
    crate::paths::read_camera_path(path).map_err(|e| super::JobError(format!("camera path {e}")))
}

/// What chooses the frames of a render.
pub struct PlanRequest<'a> {
    /// The scene as named (for messages).
    pub scene: &'a str,
    pub camera_path: Option<&'a Path>,
    pub sensors: bool,
    /// The inserted object's path file (`--insert-path`).
    pub insert_path: Option<&'a Path>,
    /// Frames A to B (from 1, both included).
    pub frames: Option<(u64, u64)>,
}

/// The frames `args` ask for (`None`: a single image), checked before any long work. `sensors`
/// are the scene file's cameras, `base` the scene's camera (its fov axis and near clip serve
/// the path's cameras).
pub fn plan(args: &PlanRequest, sensors: &[CameraDesc], base: &CameraDesc, object: Option<&ObjectPath>) -> Result<Option<Plan>> {
    let (count, source, camera_at): (u64, String, Box<dyn Fn(u64) -> Frame>) = if let Some(file) = args.camera_path {
        let path = read_camera_path(file)?;
        let count = path.frame_count();
        let base = base.clone();
        let at = move |i: u64| {
            let t = path.frame_time(i);
            Frame { index: i, camera: path.pose_at(t).camera(&base), time_s: Some(t) }
        };
        (count, format!("camera path {}", file.display()), Box::new(at))
    } else if args.sensors {
        if sensors.is_empty() {
            bail!("--sensors: scene '{}' has no <sensor> (only a Mitsuba XML file has sensors)", args.scene);
        }
        let cams = sensors.to_vec();
        let at = move |i: u64| Frame { index: i, camera: cams[(i - 1) as usize].clone(), time_s: None };
        (sensors.len() as u64, "sensors".to_string(), Box::new(at))
    } else if let (Some(path), Some(file)) = (object, args.insert_path) {
        let (path, base) = (path.clone(), base.clone());
        let at = move |i: u64| Frame { index: i, camera: base.clone(), time_s: Some(path.frame_time(i)) };
        (object.map_or(1, ObjectPath::frame_count), format!("object path {}", file.display()), Box::new(at))
    } else {
        if args.frames.is_some() {
            bail!("--frames needs --camera-path, --sensors or --insert-path");
        }
        return Ok(None);
    };
    let (a, b) = args.frames.unwrap_or((1, count));
    if b > count {
        bail!("--frames {a}..{b}: the {source} makes {count} frames");
    }
    Ok(Some(Plan { frames: (a..=b).map(camera_at).collect(), count, source }))
}

/// The frames of a camera path, or of the scene's sensors (the scene is then loaded), as
/// [`plan`] counts them: for a front end that spreads the frames over machines.
pub fn frame_count(scene: &super::SceneSpec, camera_path: Option<&Path>, sensors: bool, fe: &dyn super::Frontend) -> Result<u64> {
    match (camera_path, sensors) {
        (Some(_), true) => bail!("give a camera path or the sensors, not both"),
        (Some(p), false) => Ok(read_camera_path(p)?.frame_count()),
        (None, true) => {
            let loaded = super::load(scene, fe)?;
            let req = PlanRequest { scene: &scene.scene, camera_path: None, sensors: true, insert_path: None, frames: None };
            Ok(plan(&req, &loaded.sensors, &loaded.desc.camera, None)?.map_or(1, |p| p.count))
        }
        (None, false) => bail!("no frames: give a camera path or the sensors"),
    }
}
