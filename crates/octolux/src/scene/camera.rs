//! Perspective pinhole camera with Mitsuba 3's conventions: camera space looks along +z with
//! +y up and +x to the *left* of the image; `fov` is measured along `fov_axis`.

use crate::math::RayDifferential;
use glam::{Mat4, Vec2, Vec3};
use serde::{Deserialize, Serialize};

/// Which image axis `fov` refers to (Mitsuba's `fov_axis`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum FovAxis {
    #[default]
    X,
    Y,
    Diagonal,
    Smaller,
    Larger,
}

/// Camera description.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraDesc {
    /// Camera-to-world transform (Mitsuba `to_world`, usually from `lookat`).
    pub to_world: Mat4,
    /// Field of view in degrees along `fov_axis`.
    pub fov_deg: f32,
    pub fov_axis: FovAxis,
    /// Distance of the near clipping plane along the view axis.
    pub near_clip: f32,
}

impl Default for CameraDesc {
    fn default() -> Self {
        CameraDesc { to_world: Mat4::IDENTITY, fov_deg: 39.3077, fov_axis: FovAxis::X, near_clip: 1e-2 }
    }
}

/// Mitsuba's `lookat` transform: camera at `origin` looking at `target`.
pub fn look_at(origin: Vec3, target: Vec3, up: Vec3) -> Mat4 {
    let dir = (target - origin).normalize();
    let left = up.normalize().cross(dir).normalize();
    let new_up = dir.cross(left);
    Mat4::from_cols(left.extend(0.0), new_up.extend(0.0), dir.extend(0.0), origin.extend(1.0))
}

impl CameraDesc {
    pub fn validate(&self) -> Result<(), String> {
        if !(self.fov_deg.is_finite() && self.fov_deg > 0.0 && self.fov_deg < 180.0) {
            return Err(format!("field of view {} degrees is outside (0, 180)", self.fov_deg));
        }
        if !self.to_world.is_finite() || self.to_world.determinant().abs() < 1e-12 {
            return Err("to_world transform is singular or not finite".into());
        }
        if !(self.near_clip.is_finite() && self.near_clip >= 0.0) {
            return Err(format!("near_clip {} must be finite and non-negative", self.near_clip));
        }
        Ok(())
    }

    /// A warning when `near_clip` lies beyond every point of `scene` (the geometry's bounds):
    /// a valid value that renders only what is at infinity (`near_clip` 1e30 gave a black
    /// image, exit 0).
    pub fn near_clip_warning(&self, scene: &crate::math::Bounds3) -> Option<String> {
        if !(scene.min.is_finite() && scene.max.is_finite()) {
            return None;
        }
        let eye = self.to_world.transform_point3(Vec3::ZERO);
        let farthest = (0..8)
            .map(|i| {
                let c = Vec3::new(
                    if i & 1 == 0 { scene.min.x } else { scene.max.x },
                    if i & 2 == 0 { scene.min.y } else { scene.max.y },
                    if i & 4 == 0 { scene.min.z } else { scene.max.z },
                );
                (c - eye).length()
            })
            .fold(0.0f32, f32::max);
        (self.near_clip >= farthest).then(|| {
            format!(
                "near_clip {} is beyond the whole scene (its farthest point is {farthest} away): no surface can be seen",
                self.near_clip
            )
        })
    }
}

/// A camera ready to generate rays for a film of a given size.
#[derive(Clone, Debug)]
pub struct Camera {
    origin: Vec3,
    /// World-space images of the camera x (left), y (up) and z (forward) axes, normalised.
    left: Vec3,
    up: Vec3,
    forward: Vec3,
    tan_half_x: f32,
    tan_half_y: f32,
    inv_width: f32,
    inv_height: f32,
    near_clip: f32,
}

/// A camera's frame ([`Camera::frame`]).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct CameraFrame {
    pub origin: Vec3,
    pub left: Vec3,
    pub up: Vec3,
    pub forward: Vec3,
    pub tan_half_x: f32,
    pub tan_half_y: f32,
    pub near_clip: f32,
}

impl Camera {
    pub fn new(desc: &CameraDesc, width: u32, height: u32) -> Camera {
        let aspect = width as f32 / height as f32;
        let t = (desc.fov_deg.to_radians() * 0.5).tan();
        let axis = match desc.fov_axis {
            FovAxis::Smaller => {
                if aspect > 1.0 {
                    FovAxis::Y
                } else {
                    FovAxis::X
                }
            }
            FovAxis::Larger => {
                if aspect > 1.0 {
                    FovAxis::X
                } else {
                    FovAxis::Y
                }
            }
            a => a,
        };
        let tan_half_x = match axis {
            FovAxis::Y => t * aspect,
            FovAxis::Diagonal => t * aspect / (1.0 + aspect * aspect).sqrt(),
            _ => t,
        };
        let m = desc.to_world;
        Camera {
            origin: m.transform_point3(Vec3::ZERO),
            left: m.transform_vector3(Vec3::X).normalize(),
            up: m.transform_vector3(Vec3::Y).normalize(),
            forward: m.transform_vector3(Vec3::Z).normalize(),
            tan_half_x,
            tan_half_y: tan_half_x / aspect,
            inv_width: 1.0 / width as f32,
            inv_height: 1.0 / height as f32,
            near_clip: desc.near_clip,
        }
    }

    /// The camera's frame and the tangents of its half fields of view, as a rasteriser needs
    /// them to project as [`Camera::generate_ray`] traces: a point at `(l, u, f)` along
    /// (`left`, `up`, `forward`) from `origin` lands at film `x = W (1 − l / (f tan_half_x)) / 2`,
    /// `y = H (1 − u / (f tan_half_y)) / 2` (pixels from the top-left corner).
    pub fn frame(&self) -> CameraFrame {
        CameraFrame {
            origin: self.origin,
            left: self.left,
            up: self.up,
            forward: self.forward,
            tan_half_x: self.tan_half_x,
            tan_half_y: self.tan_half_y,
            near_clip: self.near_clip,
        }
    }

    /// Primary ray through continuous film position `film` (pixels; (0,0) is the top-left
    /// corner of the image, x to the right, y down). Returns origin, unit direction and the
    /// ray's `tmin` (the near clip plane, measured along the ray).
    #[inline]
    pub fn generate_ray(&self, film: Vec2) -> (Vec3, Vec3, f32) {
        let x = (1.0 - 2.0 * film.x * self.inv_width) * self.tan_half_x;
        let y = (1.0 - 2.0 * film.y * self.inv_height) * self.tan_half_y;
        let d = (self.left * x + self.up * y + self.forward).normalize();
        let tmin = self.near_clip / d.dot(self.forward);
        (self.origin, d, tmin)
    }

    /// The ray differential of the primary ray through `film`: the rays one pixel step to the
    /// right and one down, their direction offsets scaled by `scale` (Mitsuba 0.6 scales them by
    /// `1/sqrt(spp)`: `scaleDifferential`). The pinhole's offset rays share its origin.
    #[inline]
    pub fn ray_differential(&self, film: Vec2, scale: f32) -> RayDifferential {
        let (o, d, _) = self.generate_ray(film);
        let (_, dx, _) = self.generate_ray(film + Vec2::X);
        let (_, dy, _) = self.generate_ray(film + Vec2::Y);
        RayDifferential { o_x: o, d_x: d + (dx - d) * scale, o_y: o, d_y: d + (dy - d) * scale }
    }

    /// The angle a pixel subtends at the image centre, radians (`2 tan(fov_y / 2) / height`): the
    /// spread of a camera ray's cone (`integrators::pathloop`).
    pub fn pixel_spread(&self) -> f32 {
        2.0 * self.tan_half_y * self.inv_height
    }

    pub fn position(&self) -> Vec3 {
        self.origin
    }
    pub fn forward(&self) -> Vec3 {
        self.forward
    }

    /// Inverse of `generate_ray`: film position of a world point, if in front of the camera.
    pub fn project(&self, p: Vec3) -> Option<Vec2> {
        let v = p - self.origin;
        let z = v.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let x = v.dot(self.left) / z / self.tan_half_x;
        let y = v.dot(self.up) / z / self.tan_half_y;
        Some(Vec2::new((1.0 - x) * 0.5 / self.inv_width, (1.0 - y) * 0.5 / self.inv_height))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_ray_looks_at_target_and_left_is_left() {
        let desc = CameraDesc {
            to_world: look_at(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, Vec3::Y),
            fov_deg: 40.0,
            fov_axis: FovAxis::X,
            near_clip: 0.0,
        };
        let cam = Camera::new(&desc, 200, 100);
        let (o, d, _) = cam.generate_ray(Vec2::new(100.0, 50.0));
        assert!((o - Vec3::new(0.0, 0.0, 4.0)).length() < 1e-6);
        assert!((d - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
        // Looking down -z with +y up, image right is world +x.
        let (_, d_right, _) = cam.generate_ray(Vec2::new(200.0, 50.0));
        assert!(d_right.x > 0.0);
        let (_, d_top, _) = cam.generate_ray(Vec2::new(100.0, 0.0));
        assert!(d_top.y > 0.0);
        // Horizontal field of view is 40 degrees.
        let ang = d_right.angle_between(d).to_degrees();
        assert!((ang - 20.0).abs() < 1e-3, "{ang}");
        let p = o + d_right * 3.0;
        let f = cam.project(p).unwrap();
        assert!((f - Vec2::new(200.0, 50.0)).length() < 1e-3);
    }

    #[test]
    fn fov_axis_y_and_smaller() {
        let desc = CameraDesc { fov_deg: 30.0, fov_axis: FovAxis::Smaller, ..Default::default() };
        let cam = Camera::new(&desc, 300, 100);
        let (_, d, _) = cam.generate_ray(Vec2::new(150.0, 0.0));
        let (_, c, _) = cam.generate_ray(Vec2::new(150.0, 50.0));
        assert!((d.angle_between(c).to_degrees() - 15.0).abs() < 1e-3);
    }
}
