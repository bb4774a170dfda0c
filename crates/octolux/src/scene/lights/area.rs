//! The geometry of area lights prepared for sampling by area, and what the light set derives
//! from any light: its emitted power, its spot falloff and its bounds for the light tree
//! ([`super`]'s module documentation).

use super::tree::LightBounds;
use super::*;

/// Geometry of an area light prepared for sampling by area.
#[derive(Clone, Debug)]
pub enum AreaGeometry {
    Triangles { tris: Vec<[Vec3; 3]>, normals: Vec<Vec3>, cdf: Distribution1D, area: f32 },
    Sphere { center: Vec3, radius: f32, flip: bool },
}

/// Mitsuba's spot falloff: 1 inside the beam, linear in angle down to 0 at the cutoff.
#[inline]
pub(super) fn spot_falloff(cos_theta: f32, cos_cutoff: f32, cos_falloff_start: f32) -> f32 {
    if cos_theta <= cos_cutoff {
        0.0
    } else if cos_theta >= cos_falloff_start {
        1.0
    } else {
        let c = cos_cutoff.clamp(-1.0, 1.0).acos();
        let b = cos_falloff_start.clamp(-1.0, 1.0).acos();
        if c > b {
            ((c - cos_theta.clamp(-1.0, 1.0).acos()) / (c - b)).clamp(0.0, 1.0)
        } else {
            1.0
        }
    }
}

/// Emitted power of a light (see the module documentation); `scene_radius` is the radius of
/// the scene bounding sphere.
pub(super) fn light_power(l: &Light, geom: Option<&AreaGeometry>, env: Option<&Environment>, scene_radius: f32) -> Color {
    match l {
        Light::Area { radiance, .. } => *radiance * (PI * geom.map_or(0.0, AreaGeometry::area)),
        Light::Point { intensity, .. } => *intensity * (4.0 * PI),
        Light::Spot { intensity, cos_cutoff, cos_falloff_start, .. } => {
            let c = (cos_cutoff.clamp(-1.0, 1.0) as f64).acos();
            let b = (cos_falloff_start.clamp(-1.0, 1.0) as f64).acos().min(c);
            let f = if c - b > 1e-6 { 1.0 - (c.sin() - b.sin()) / (c - b) } else { 1.0 - c.cos() };
            *intensity * (2.0 * std::f64::consts::PI * f) as f32
        }
        Light::Directional { irradiance, .. } => *irradiance * (PI * scene_radius * scene_radius),
        Light::Constant { radiance } => *radiance * (4.0 * PI * PI * scene_radius * scene_radius),
        Light::Envmap { .. } | Light::Sunsky(_) => env.map_or(Color::ZERO, |e| e.integral() * (PI * scene_radius * scene_radius)),
    }
}

impl AreaGeometry {
    /// Prepare a shape for sampling by area; `None` when it has no area.
    pub fn new(shape: &ShapeDesc) -> Option<AreaGeometry> {
        match &shape.geometry {
            Geometry::Sphere { center, radius } => {
                if radius.is_finite() && *radius > 0.0 && center.is_finite() {
                    Some(AreaGeometry::Sphere { center: *center, radius: *radius, flip: shape.flip_normals })
                } else {
                    None
                }
            }
            Geometry::Mesh(m) => {
                let mut tris = Vec::with_capacity(m.indices.len());
                let mut normals = Vec::with_capacity(m.indices.len());
                let mut areas = Vec::with_capacity(m.indices.len());
                for t in &m.indices {
                    let (Some(&a), Some(&b), Some(&c)) =
                        (m.positions.get(t[0] as usize), m.positions.get(t[1] as usize), m.positions.get(t[2] as usize))
                    else {
                        continue;
                    };
                    let cr = (b - a).cross(c - a);
                    let len = cr.length();
                    if not_positive(len) || !len.is_finite() {
                        continue;
                    }
                    let n = cr / len;
                    tris.push([a, b, c]);
                    normals.push(if shape.flip_normals { -n } else { n });
                    areas.push(0.5 * len);
                }
                let cdf = Distribution1D::new(&areas)?;
                let area = cdf.total() as f32;
                Some(AreaGeometry::Triangles { tris, normals, cdf, area })
            }
        }
    }

    /// Total area (m², in scene units squared).
    #[inline]
    pub fn area(&self) -> f32 {
        match self {
            AreaGeometry::Triangles { area, .. } => *area,
            AreaGeometry::Sphere { radius, .. } => 4.0 * PI * radius * radius,
        }
    }

    /// A point uniformly distributed by area (density `1 / area()`) and the emitting side's
    /// normal there (negated for `flip_normals`). The one place area-light points are drawn,
    /// for next-event estimation and for photon emission alike.
    #[inline]
    pub fn sample_point(&self, u: Vec2) -> (Vec3, Vec3) {
        match self {
            AreaGeometry::Triangles { tris, normals, cdf, .. } => {
                let (ti, ux) = if tris.len() == 1 {
                    (0, u.x)
                } else {
                    let (ti, _, ux) = cdf.sample(u.x);
                    (ti, ux)
                };
                let b = square_to_uniform_triangle(Vec2::new(ux, u.y));
                let [a, b1, c] = tris[ti];
                (a * (1.0 - b.x - b.y) + b1 * b.x + c * b.y, normals[ti])
            }
            AreaGeometry::Sphere { center, radius, flip } => {
                let n = square_to_uniform_sphere(u);
                (*center + n * *radius, if *flip { -n } else { n })
            }
        }
    }

    /// For a sphere that emits outwards seen from the outside point `p`: `1 - cos θ_max` of
    /// the cone it subtends (next-event estimation samples that cone uniformly). `None` for
    /// triangles, flipped spheres and points inside (sampled by area).
    #[inline]
    pub(super) fn visible_cone(&self, p: Vec3) -> Option<f32> {
        let AreaGeometry::Sphere { center, radius, flip: false } = self else { return None };
        let d2 = (*center - p).length_squared();
        let r2 = radius * radius;
        if d2 <= r2 {
            return None;
        }
        let sin2_max = r2 / d2;
        let cos_max = (1.0 - sin2_max).max(0.0).sqrt();
        Some(sin2_max / (1.0 + cos_max))
    }
}

/// The light tree's bounds of a light with a position (tree module docs): `None` for the
/// lights at infinity and area lights without geometry.
pub(super) fn light_bounds(l: &Light, geom: Option<&AreaGeometry>) -> Option<LightBounds> {
    const FULL: (Vec3, f32, f32) = (Vec3::Z, -1.0, 0.0);
    match l {
        Light::Area { radiance, .. } => match geom? {
            AreaGeometry::Sphere { center, radius, .. } => {
                let r = Vec3::splat(*radius);
                // seen from any direction, a sphere's intensity is L · π r²
                let (axis, cos_o, cos_e) = FULL;
                Some(LightBounds::new(*center - r, *center + r, axis, cos_o, cos_e, *radiance * (PI * radius * radius)))
            }
            AreaGeometry::Triangles { tris, normals, area, .. } => {
                let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
                let mut sum = Vec3::ZERO;
                for (t, n) in tris.iter().zip(normals) {
                    for v in t {
                        lo = lo.min(*v);
                        hi = hi.max(*v);
                    }
                    sum += *n * (0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length());
                }
                let axis = sum.normalize_or_zero();
                let (axis, cos_o) = if axis == Vec3::ZERO {
                    (Vec3::Z, -1.0)
                } else {
                    // a little slack for rounding: the bound must hold every normal
                    let c = normals.iter().map(|n| n.dot(axis)).fold(1.0f32, f32::min);
                    (axis, (c - 1e-4).max(-1.0))
                };
                Some(LightBounds::new(lo, hi, axis, cos_o, 0.0, *radiance * *area))
            }
        },
        Light::Point { position, intensity } => {
            let (axis, cos_o, cos_e) = FULL;
            Some(LightBounds::new(*position, *position, axis, cos_o, cos_e, *intensity))
        }
        Light::Spot { position, frame, intensity, cos_cutoff, cos_falloff_start } => {
            let c = cos_cutoff.clamp(-1.0, 1.0).acos();
            let b = cos_falloff_start.clamp(-1.0, 1.0).acos().min(c);
            Some(LightBounds::new(*position, *position, frame.n, b.cos(), (c - b).cos(), *intensity))
        }
        Light::Directional { .. } | Light::Constant { .. } | Light::Envmap { .. } | Light::Sunsky(_) => None,
    }
}

/// False for NaN, zero and negative values.
#[inline]
pub(super) fn not_positive(x: f32) -> bool {
    x.is_nan() || x <= 0.0
}
