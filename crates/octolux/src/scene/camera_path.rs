//! Camera animation (issue 13, docs/guide/baking.md): a path of keyframes, interpolated, sampled at
//! `fps` into numbered frames rendered from one baked lighting solution.
//!
//! Interpolation: position and target follow a Catmull-Rom spline through the keyframes
//! (cubic Hermite segments whose tangent at a key is the finite difference of its neighbours
//! over their time span, `(P[k+1] − P[k−1]) / (t[k+1] − t[k−1])`, one-sided at the ends, so
//! uneven key times are honoured and the motion is C¹); `up` and `fov` are interpolated
//! linearly. At a key's time the key is returned as it is (bit for bit); before the first
//! key the first, after the last the last.
//!
//! Frames are numbered from 1: frame `i` is at time `t_first + (i − 1) / fps`, and the last
//! frame is the last one not after `t_last` (a frame within 1e-9 s of a key takes the key).

use super::camera::{look_at, CameraDesc};
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// Most frames a path may make (a typo in `fps` should not ask for a billion renders).
pub const MAX_FRAMES: u64 = 1_000_000;

/// The frames of keyframes from their first to their last time at `fps` (camera and object
/// paths alike): frame 1 at the first key, then one every `1/fps` seconds.
pub(crate) struct Timeline {
    t0: f64,
    span: f64,
    fps: f64,
}

impl Timeline {
    pub(crate) fn new(mut times: impl Iterator<Item = f64>, fps: f64) -> Timeline {
        let t0 = times.next().unwrap_or(0.0);
        let t1 = times.last().unwrap_or(t0);
        Timeline { t0, span: t1 - t0, fps }
    }

    /// A keyframe at least, finite times in increasing order, a positive `fps` (`what`: the
    /// path's kind, for the message, which names the key from 1).
    pub(crate) fn check_keys(what: &str, times: impl Iterator<Item = f64>, fps: f64) -> Result<(), String> {
        if !(fps.is_finite() && fps > 0.0) {
            return Err(format!("fps {fps} must be a positive number"));
        }
        let mut prev: Option<f64> = None;
        for (i, t) in times.enumerate() {
            if !t.is_finite() {
                return Err(format!("keyframe {}: time {t} is not finite", i + 1));
            }
            if let Some(p) = prev.filter(|&p| t <= p) {
                return Err(format!("keyframe {}: time {t} is not after the previous keyframe's {p}", i + 1));
            }
            prev = Some(t);
        }
        if prev.is_none() {
            return Err(format!("the {what} path has no keyframe"));
        }
        Ok(())
    }

    /// At most [`MAX_FRAMES`] frames.
    pub(crate) fn check(&self) -> Result<(), String> {
        let frames = self.span * self.fps + 1.0;
        if frames > MAX_FRAMES as f64 {
            return Err(format!("the path makes {frames:.0} frames at {} fps (at most {MAX_FRAMES})", self.fps));
        }
        Ok(())
    }

    pub(crate) fn frame_count(&self) -> u64 {
        ((self.span * self.fps + 1e-9).floor() as u64 + 1).min(MAX_FRAMES)
    }

    pub(crate) fn frame_time(&self, i: u64) -> f64 {
        self.t0 + (i.max(1) - 1) as f64 / self.fps
    }
}

/// One keyframe: where the camera is and looks at a time (scene units, degrees, seconds).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Keyframe {
    /// Seconds.
    pub time: f64,
    /// Camera position (scene units).
    pub position: [f32; 3],
    /// The point looked at.
    pub target: [f32; 3],
    /// Up direction (default +y).
    #[serde(default = "default_up")]
    pub up: [f32; 3],
    /// Field of view in degrees along the scene camera's `fov_axis`.
    pub fov: f32,
}

fn default_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}

fn default_fps() -> f64 {
    24.0
}

/// A camera path file (JSON or TOML): `fps` and the keyframes, in increasing time.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraPath {
    /// Frames per second (default 24).
    #[serde(default = "default_fps")]
    pub fps: f64,
    pub keyframes: Vec<Keyframe>,
}

/// The camera at one time: position, target, up (not normalised), fov in degrees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraPose {
    pub position: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    pub fov: f32,
}

impl CameraPose {
    /// A usable camera: finite, the target away from the position, `up` neither zero nor
    /// along the view direction, the fov in (0, 180) degrees.
    pub fn check(&self) -> Result<(), String> {
        if !(self.position.is_finite() && self.target.is_finite() && self.up.is_finite()) {
            return Err("position, target and up must be finite".into());
        }
        let dir = self.target - self.position;
        if dir.length() <= 1e-6 * (1.0 + self.position.abs().max_element()) {
            return Err("target is the position".into());
        }
        if self.up.length() == 0.0 || dir.normalize().cross(self.up).length() <= 1e-4 * self.up.length() {
            return Err("up is zero or along the view direction".into());
        }
        if !(self.fov.is_finite() && self.fov > 0.0 && self.fov < 180.0) {
            return Err(format!("fov {} degrees is outside (0, 180)", self.fov));
        }
        Ok(())
    }

    /// The camera description: `base`'s fov axis and near clip, this pose's transform and fov.
    pub fn camera(&self, base: &CameraDesc) -> CameraDesc {
        CameraDesc { to_world: look_at(self.position, self.target, self.up), fov_deg: self.fov, ..base.clone() }
    }
}

impl Keyframe {
    pub fn pose(&self) -> CameraPose {
        CameraPose { position: self.position.into(), target: self.target.into(), up: self.up.into(), fov: self.fov }
    }
}

impl CameraPath {
    /// Check the path: a keyframe at least, finite increasing times, a positive `fps`, at most
    /// [`MAX_FRAMES`] frames, every key a valid camera ([`CameraPose::check`]), and then every
    /// frame's interpolated pose too: valid keys can still put a frame between them where the
    /// position meets the target or `up` interpolates to zero (a black frame, exit 0). The
    /// message names the key (from 1) or the frame and its time.
    pub fn validate(&self) -> Result<(), String> {
        Timeline::check_keys("camera", self.keyframes.iter().map(|k| k.time), self.fps)?;
        for (i, k) in self.keyframes.iter().enumerate() {
            k.pose().check().map_err(|m| format!("keyframe {}: {m}", i + 1))?;
        }
        self.timeline().check()?;
        for i in 1..=self.frame_count() {
            let t = self.frame_time(i);
            self.pose_at(t).check().map_err(|m| format!("frame {i} (time {t} s, between keyframes): {m}"))?;
        }
        Ok(())
    }

    fn timeline(&self) -> Timeline {
        Timeline::new(self.keyframes.iter().map(|k| k.time), self.fps)
    }

    /// Number of frames (a validated path).
    pub fn frame_count(&self) -> u64 {
        self.timeline().frame_count()
    }

    /// Time of frame `i` (from 1).
    pub fn frame_time(&self, i: u64) -> f64 {
        let t = self.timeline().frame_time(i);
        // a frame on a key takes the key exactly
        self.keyframes.iter().map(|k| k.time).find(|&kt| (kt - t).abs() < 1e-9).unwrap_or(t)
    }

    /// The pose at time `t` (module docs).
    pub fn pose_at(&self, t: f64) -> CameraPose {
        let keys = &self.keyframes;
        let (Some(first), Some(last)) = (keys.first(), keys.last()) else {
            return CameraPose { position: Vec3::ZERO, target: Vec3::NEG_Z, up: Vec3::Y, fov: 45.0 };
        };
        if !(t > first.time) {
            return first.pose();
        }
        if t >= last.time {
            return last.pose();
        }
        // segment k: keys[k].time <= t < keys[k + 1].time
        let k = keys.partition_point(|key| key.time <= t) - 1;
        let (a, b) = (&keys[k], &keys[k + 1]);
        if t == a.time {
            return a.pose();
        }
        let dt = b.time - a.time;
        let u = (t - a.time) / dt;
        // Catmull-Rom tangents (per second), one-sided at the ends
        let tangent = |j: usize, f: &dyn Fn(&Keyframe) -> Vec3| -> Vec3 {
            let (lo, hi) = (j.saturating_sub(1), (j + 1).min(keys.len() - 1));
            (f(&keys[hi]) - f(&keys[lo])) / (keys[hi].time - keys[lo].time) as f32
        };
        let hermite = |f: &dyn Fn(&Keyframe) -> Vec3| -> Vec3 {
            let (u2, u3) = (u * u, u * u * u);
            let h00 = (2.0 * u3 - 3.0 * u2 + 1.0) as f32;
            let h10 = ((u3 - 2.0 * u2 + u) * dt) as f32;
            let h01 = (-2.0 * u3 + 3.0 * u2) as f32;
            let h11 = ((u3 - u2) * dt) as f32;
            h00 * f(a) + h10 * tangent(k, f) + h01 * f(b) + h11 * tangent(k + 1, f)
        };
        let lerp = |x: f32, y: f32| x + (y - x) * u as f32;
        let (pa, pb) = (a.pose(), b.pose());
        CameraPose {
            position: hermite(&|key| key.position.into()),
            target: hermite(&|key| key.target.into()),
            up: pa.up.lerp(pb.up, u as f32),
            fov: lerp(pa.fov, pb.fov),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(time: f64, x: f32, fov: f32) -> Keyframe {
        Keyframe { time, position: [x, 1.0, 4.0], target: [0.0, 1.0, 0.0], up: [0.0, 1.0, 0.0], fov }
    }

    fn path() -> CameraPath {
        CameraPath { fps: 10.0, keyframes: vec![key(0.0, -1.0, 40.0), key(0.35, 0.3, 50.0), key(1.0, 2.0, 45.0), key(1.5, 2.1, 30.0)] }
    }

    #[test]
    fn keyframes_are_reproduced_exactly() {
        let p = path();
        p.validate().unwrap();
        let base = CameraDesc::default();
        for k in &p.keyframes {
            assert_eq!(p.pose_at(k.time), k.pose());
            assert_eq!(p.pose_at(k.time).camera(&base), k.pose().camera(&base));
        }
        // on both sides of a key the spline tends to it (continuity)
        let k = &p.keyframes[1];
        for dt in [1e-4, -1e-4] {
            let q = p.pose_at(k.time + dt);
            assert!((q.position - k.pose().position).length() < 1e-2, "{q:?}");
            assert!((q.fov - k.fov).abs() < 0.05);
        }
        // before and after: the end keys
        assert_eq!(p.pose_at(-5.0), p.keyframes[0].pose());
        assert_eq!(p.pose_at(9.0), p.keyframes[3].pose());
    }

    #[test]
    fn a_uniform_straight_motion_stays_straight_and_frames_are_counted() {
        let p = CameraPath { fps: 4.0, keyframes: (0..4).map(|i| key(i as f64, i as f32, 40.0)).collect() };
        p.validate().unwrap();
        assert_eq!(p.frame_count(), 13);
        for i in 1..=13 {
            let t = p.frame_time(i);
            assert!((t - (i - 1) as f64 / 4.0).abs() < 1e-12);
            // Catmull-Rom reproduces a linear motion (the end tangents included)
            assert!((p.pose_at(t).position.x - t as f32).abs() < 1e-5, "{t}: {:?}", p.pose_at(t));
        }
        // uneven key times: the frame on the key is the key
        let q = path();
        assert_eq!(q.frame_count(), 16);
        assert_eq!(q.frame_time(11), 1.0);
    }

    #[test]
    fn bad_paths_are_refused_naming_the_key() {
        let cases: Vec<(CameraPath, &str)> = vec![
            (CameraPath { fps: 24.0, keyframes: vec![] }, "no keyframe"),
            (CameraPath { fps: 0.0, ..path() }, "fps"),
            (CameraPath { fps: 1e9, ..path() }, "frames"),
            (CameraPath { fps: 24.0, keyframes: vec![key(0.0, 0.0, 40.0), key(0.0, 1.0, 40.0)] }, "keyframe 2: time"),
            (CameraPath { fps: 24.0, keyframes: vec![key(0.0, 0.0, 190.0)] }, "keyframe 1: fov"),
            (CameraPath { fps: 24.0, keyframes: vec![Keyframe { up: [0.0, 0.0, 1.0], ..key(0.0, 0.0, 40.0) }] }, "up"),
            (CameraPath { fps: 24.0, keyframes: vec![Keyframe { target: [0.0, 1.0, 4.0], ..key(0.0, 0.0, 40.0) }] }, "target"),
            (CameraPath { fps: 24.0, keyframes: vec![Keyframe { time: f64::NAN, ..key(0.0, 0.0, 40.0) }] }, "not finite"),
        ];
        for (p, word) in cases {
            let e = p.validate().expect_err(word);
            assert!(e.contains(word), "{e} should say {word}");
        }
        // valid keys, and a frame between them where the position meets the target, or where
        // `up` interpolates to zero (both rendered black frames)
        let k = |time: f64, x: f32, up: [f32; 3]| Keyframe { time, position: [x, 0.0, 0.0], target: [1.0, 0.0, 0.0], up, fov: 40.0 };
        let meets = CameraPath { fps: 2.0, keyframes: vec![k(0.0, 0.0, [0.0, 1.0, 0.0]), k(1.0, 2.0, [0.0, 1.0, 0.0])] };
        assert_eq!(meets.validate().unwrap_err(), "frame 2 (time 0.5 s, between keyframes): target is the position");
        let flips = CameraPath { fps: 2.0, keyframes: vec![k(0.0, 0.0, [0.0, 1.0, 0.0]), k(1.0, 0.0, [0.0, -1.0, 0.0])] };
        assert_eq!(flips.validate().unwrap_err(), "frame 2 (time 0.5 s, between keyframes): up is zero or along the view direction");
        let parsed: CameraPath =
            serde_json::from_str(r#"{"keyframes": [{"time": 0, "position": [0,0,1], "target": [0,0,0], "fov": 40}]}"#).unwrap();
        assert_eq!((parsed.fps, parsed.keyframes[0].up), (24.0, [0.0, 1.0, 0.0]));
        assert!(serde_json::from_str::<CameraPath>(r#"{"keyframes": [], "fsp": 3}"#).is_err());
    }
}
