//! The motion of an object inserted into baked lighting (issue 13, item 5; docs/guide/baking.md
//! "Inserted objects"): keyframes of position, rotation about the vertical axis and scale,
//! sampled at `fps` into numbered frames as a camera path is (`camera_path.rs`: frame `i` at
//! `t_first + (i − 1) / fps`, the last one not after `t_last`).
//!
//! Interpolation is linear between keys (position, angle, scale), the key itself at its time,
//! the first key before it and the last after it. The transform of a pose is
//! `translate(position) · rotate_y(rotate_y) · scale(scale)` applied to the object as loaded.

use glam::{Mat4, Vec3};
use serde::{Deserialize, Serialize};

/// Most frames a path may make.
pub const MAX_FRAMES: u64 = super::camera_path::MAX_FRAMES;
/// Largest scale of a keyframe, and the smallest is its inverse: an object a million times
/// larger or smaller than as loaded is a typo (`scale` 1e30 put every point of the object
/// beyond what single-precision intersection can resolve).
pub const MAX_SCALE: f32 = 1e6;

/// One keyframe (scene units, degrees, seconds).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectKeyframe {
    /// Seconds.
    pub time: f64,
    /// Where the object's origin goes (scene units).
    pub position: [f32; 3],
    /// Rotation about +y, degrees (default 0).
    #[serde(default)]
    pub rotate_y: f32,
    /// Uniform scale (default 1).
    #[serde(default = "one")]
    pub scale: f32,
}

fn one() -> f32 {
    1.0
}

fn default_fps() -> f64 {
    24.0
}

/// An object path file (JSON): `fps` and the keyframes, in increasing time.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectPath {
    /// Frames per second (default 24).
    #[serde(default = "default_fps")]
    pub fps: f64,
    pub keyframes: Vec<ObjectKeyframe>,
}

impl ObjectKeyframe {
    fn transform(&self) -> Mat4 {
        Mat4::from_translation(Vec3::from(self.position))
            * Mat4::from_rotation_y(self.rotate_y.to_radians())
            * Mat4::from_scale(Vec3::splat(self.scale))
    }
}

impl ObjectPath {
    /// Keys present, finite, in increasing time, scales positive; `fps` positive; at most
    /// [`MAX_FRAMES`] frames.
    pub fn validate(&self) -> Result<(), String> {
        super::camera_path::Timeline::check_keys("object", self.keyframes.iter().map(|k| k.time), self.fps)?;
        for (i, k) in self.keyframes.iter().enumerate() {
            let at = |m: String| Err(format!("keyframe {}: {m}", i + 1));
            if !(Vec3::from(k.position).is_finite() && k.rotate_y.is_finite()) {
                return at("position and rotate_y must be finite".into());
            }
            if !(k.scale.is_finite() && k.scale > 0.0) {
                return at(format!("scale {} must be a positive number", k.scale));
            }
            if !(k.scale >= 1.0 / MAX_SCALE && k.scale <= MAX_SCALE) {
                return at(format!("scale {:e} is out of range [{:e}, {MAX_SCALE:e}]", k.scale, 1.0 / MAX_SCALE));
            }
        }
        self.timeline().check()?;
        // every frame's transform, not only the keys'
        for i in 1..=self.frame_count() {
            let t = self.frame_time(i);
            let m = self.transform_at(t);
            if !(m.is_finite() && m.determinant() > 0.0) {
                return Err(format!("frame {i} (time {t} s): the interpolated transform is not a valid placement"));
            }
        }
        Ok(())
    }

    fn timeline(&self) -> super::camera_path::Timeline {
        super::camera_path::Timeline::new(self.keyframes.iter().map(|k| k.time), self.fps)
    }

    /// Frames of the path at `fps`.
    pub fn frame_count(&self) -> u64 {
        self.timeline().frame_count()
    }

    /// Time of frame `i` (from 1).
    pub fn frame_time(&self, i: u64) -> f64 {
        self.timeline().frame_time(i)
    }

    /// The object's transform at time `t` (module docs).
    pub fn transform_at(&self, t: f64) -> Mat4 {
        let keys = &self.keyframes;
        let (Some(first), Some(last)) = (keys.first(), keys.last()) else { return Mat4::IDENTITY };
        if !(t > first.time) {
            return first.transform();
        }
        if t >= last.time {
            return last.transform();
        }
        let k = keys.partition_point(|key| key.time <= t) - 1;
        let (a, b) = (&keys[k], &keys[k + 1]);
        let u = ((t - a.time) / (b.time - a.time)) as f32;
        let lerp = |x: f32, y: f32| x + (y - x) * u;
        ObjectKeyframe {
            time: t,
            position: std::array::from_fn(|j| lerp(a.position[j], b.position[j])),
            rotate_y: lerp(a.rotate_y, b.rotate_y),
            scale: lerp(a.scale, b.scale),
        }
        .transform()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn path() -> ObjectPath {
        serde_json::from_str(
            r#"{"fps": 4, "keyframes": [{"time": 0, "position": [0, 0, 0]},
                {"time": 1, "position": [2, 0, 0], "rotate_y": 90, "scale": 3}]}"#,
        )
        .unwrap()
    }

    #[test]
    fn frames_and_interpolation() {
        let p = path();
        p.validate().unwrap();
        assert_eq!(p.frame_count(), 5);
        assert_eq!(p.frame_time(3), 0.5);
        let m = p.transform_at(0.5);
        // half-way: at x = 1, rotated 45°, scale 2
        let o = m.transform_point3(Vec3::ZERO);
        assert!((o - Vec3::new(1.0, 0.0, 0.0)).length() < 1e-6, "{o}");
        let x = m.transform_vector3(Vec3::X);
        assert!((x.length() - 2.0).abs() < 1e-5 && (x.x - x.z.abs()).abs() < 1e-5, "{x}");
        assert_eq!(p.transform_at(-1.0), Mat4::IDENTITY);
        assert_eq!(p.transform_at(7.0), p.keyframes[1].transform());
    }

    #[test]
    fn bad_paths_are_refused() {
        let mut p = path();
        p.keyframes[1].time = 0.0;
        assert!(p.validate().unwrap_err().contains("keyframe 2"));
        let mut p = path();
        p.keyframes[0].scale = 0.0;
        assert!(p.validate().unwrap_err().contains("scale"));
        let mut p = path();
        p.keyframes[1].scale = 1e30;
        assert_eq!(p.validate().unwrap_err(), "keyframe 2: scale 1e30 is out of range [1e-6, 1e6]");
        let mut p = path();
        p.fps = f64::NAN;
        assert!(p.validate().unwrap_err().contains("fps"));
        assert!(serde_json::from_str::<ObjectPath>(r#"{"keyframes": [], "speed": 1}"#).is_err());
    }
}
