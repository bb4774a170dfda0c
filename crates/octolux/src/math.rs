//! Small geometric helpers on top of `glam`: colours, orthonormal frames, bounding boxes,
//! rays, spherical directions and robust ray-origin offsetting.
//!
//! Conventions: all directions are unit vectors in world space unless a name says `local`;
//! in a local shading frame the normal is +z. `wo`/`wi` point away from the surface.

use glam::{Vec2, Vec3};
use serde::{Deserialize, Serialize};

/// Linear RGB radiometric quantity (radiance W/(m² sr), power W, reflectance, ...).
pub type Color = Vec3;

/// Rec. 709 luminance of a linear RGB colour.
#[inline]
pub fn luminance(c: Color) -> f32 {
    0.212671 * c.x + 0.715160 * c.y + 0.072169 * c.z
}

/// Largest component.
#[inline]
pub fn max_component(c: Color) -> f32 {
    c.x.max(c.y).max(c.z)
}

/// A ray `o + t d` valid for `t` in `[tmin, tmax]`. `d` need not be normalised for
/// intersection, but every producer in octolux normalises it so that `t` is a distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub o: Vec3,
    pub d: Vec3,
    pub tmin: f32,
    pub tmax: f32,
}

impl Ray {
    #[inline]
    pub fn new(o: Vec3, d: Vec3) -> Self {
        Ray { o, d, tmin: 0.0, tmax: f32::INFINITY }
    }
    #[inline]
    pub fn segment(o: Vec3, d: Vec3, tmax: f32) -> Self {
        Ray { o, d, tmin: 0.0, tmax }
    }
    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + self.d * t
    }
}

/// The two offset rays of a camera ray one (scaled) pixel step away along the film's x and y
/// (Mitsuba's `RayDifferential`): origins and unit directions, world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayDifferential {
    pub o_x: Vec3,
    pub d_x: Vec3,
    pub o_y: Vec3,
    pub d_y: Vec3,
}

/// Offset a point leaving a surface with geometric normal `ng` towards direction `w`, so that
/// the new ray does not re-hit the surface it starts on. The offset scales with the magnitude
/// of the coordinates (floating-point error grows with them): `1e-4 * (1 + max |p_i|)`.
#[inline]
pub fn offset_origin(p: Vec3, ng: Vec3, w: Vec3) -> Vec3 {
    let eps = 1e-4 * (1.0 + p.abs().max_element());
    if ng.dot(w) >= 0.0 {
        p + ng * eps
    } else {
        p - ng * eps
    }
}

/// `n` turned to the side of `w` (`w` pointing away from the surface): `n` when `n·w ≥ 0`,
/// `-n` otherwise. The one spelling of "the normal on the viewer's (or the light's) side".
#[inline]
pub fn facing(n: Vec3, w: Vec3) -> Vec3 {
    if n.dot(w) >= 0.0 {
        n
    } else {
        -n
    }
}

/// Orthonormal basis; `n` is the local +z axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// Frame around a unit normal (Duff et al. 2017, "Building an orthonormal basis, revisited").
    #[inline]
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// Axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Bounds3 {
    pub min: Vec3,
    pub max: Vec3,
}

impl Default for Bounds3 {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Bounds3 {
    pub const EMPTY: Bounds3 = Bounds3 { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }
    #[inline]
    pub fn extend(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }
    #[inline]
    pub fn union(&self, o: &Bounds3) -> Bounds3 {
        Bounds3 { min: self.min.min(o.min), max: self.max.max(o.max) }
    }
    #[inline]
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }
    #[inline]
    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }
    #[inline]
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }
    /// Centre and radius of a sphere enclosing the box.
    pub fn bounding_sphere(&self) -> (Vec3, f32) {
        let c = self.center();
        (c, (self.max - c).length())
    }
    /// Whether the segment `a`–`b` meets the box (slab test on the closed segment).
    #[inline]
    pub fn meets_segment(&self, a: Vec3, b: Vec3) -> bool {
        let bx = self;
        let d = b - a;
        let (mut t0, mut t1, mut within) = (0.0f32, 1.0f32, true);
        // no exit per axis: the parameters only narrow, so one test at the end says the same
        // (and a flight's outcome per axis is not predictable: a branch each mispredicts)
        for k in 0..3 {
            if d[k] == 0.0 {
                within &= a[k] >= bx.min[k] && a[k] <= bx.max[k];
                continue;
            }
            let inv = 1.0 / d[k];
            let (lo, hi) = ((bx.min[k] - a[k]) * inv, (bx.max[k] - a[k]) * inv);
            t0 = t0.max(lo.min(hi));
            t1 = t1.min(lo.max(hi));
        }
        within && t0 <= t1
    }
    /// Volume of the intersection with another box (0 when disjoint).
    #[inline]
    pub fn overlap_volume(&self, o: &Bounds3) -> f32 {
        let d = (self.max.min(o.max) - self.min.max(o.min)).max(Vec3::ZERO);
        d.x * d.y * d.z
    }
}

/// Unit direction from spherical angles (theta from +z, phi from +x towards +y).
#[inline]
pub fn spherical_direction(sin_theta: f32, cos_theta: f32, phi: f32) -> Vec3 {
    let (s, c) = phi.sin_cos();
    Vec3::new(sin_theta * c, sin_theta * s, cos_theta)
}

/// Reflect `wo` about the normal `n` (both pointing away from the surface).
#[inline]
pub fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    2.0 * wo.dot(n) * n - wo
}

/// Barycentric interpolation helper: `(1-u-v) a + u b + v c`.
#[inline]
pub fn bary<T>(a: T, b: T, c: T, uv: Vec2) -> T
where
    T: std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>,
{
    a * (1.0 - uv.x - uv.y) + b * uv.x + c * uv.y
}

/// Gauss–Legendre nodes and weights on [-1, 1] (Newton iteration on `P_n`), in f64.
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    for i in 0..n.div_ceil(2) {
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            // P_n(x) and P_n'(x) by the three-term recurrence
            let (mut p0, mut p1) = (1.0f64, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            let pn = if n == 0 {
                1.0
            } else if n == 1 {
                x
            } else {
                p1
            };
            let pn1 = if n == 1 { 1.0 } else { p0 };
            dp = n as f64 * (x * pn - pn1) / (x * x - 1.0);
            let dx = pn / dp;
            x -= dx;
            if dx.abs() < 1e-15 {
                break;
            }
        }
        let w = 2.0 / ((1.0 - x * x) * dp * dp);
        nodes[i] = -x;
        weights[i] = w;
        nodes[n - 1 - i] = x;
        weights[n - 1 - i] = w;
    }
    (nodes, weights)
}

/// `atan2(y, x)` within 2e-5 rad (a minimax polynomial for `atan` on [0, 1] and the octant's
/// symmetries); 0 for `(0, 0)`. For finding a cell, whose borders are then tested exactly.
#[inline]
pub fn atan2_approx(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    let z = if hi > 0.0 { lo / hi } else { 0.0 };
    let z2 = z * z;
    let mut r =
        z * (0.999_977_26 + z2 * (-0.332_623_47 + z2 * (0.193_543_46 + z2 * (-0.116_432_87 + z2 * (0.052_653_32 - 0.011_721_2 * z2)))));
    if ay > ax {
        r = std::f32::consts::FRAC_PI_2 - r;
    }
    if x < 0.0 {
        r = std::f32::consts::PI - r;
    }
    if y < 0.0 {
        -r
    } else {
        r
    }
}

/// `acos(x)` within 1e-4 rad for `x` in [-1, 1] (Abramowitz & Stegun 4.4.45). For finding a
/// cell, whose borders are then tested exactly.
#[inline]
pub fn acos_approx(x: f32) -> f32 {
    let a = x.abs().min(1.0);
    let r = (1.0 - a).sqrt() * (1.570_728_8 + a * (-0.212_114_4 + a * (0.074_261 - 0.018_729_3 * a)));
    if x < 0.0 {
        std::f32::consts::PI - r
    } else {
        r
    }
}

/// `(sin δ, cos δ)` for `|δ| ≤ 0.1` (Taylor to the eighth power: the next terms are below
/// 3e-15).
#[inline]
pub fn sin_cos_small(d: f64) -> (f64, f64) {
    let d2 = d * d;
    let s = d * (1.0 - d2 / 6.0 * (1.0 - d2 / 20.0 * (1.0 - d2 / 42.0)));
    let c = 1.0 - d2 / 2.0 * (1.0 - d2 / 12.0 * (1.0 - d2 / 30.0 * (1.0 - d2 / 56.0)));
    (s, c)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The approximations against libm in f64, over their whole domains.
    #[test]
    fn approximations_stay_within_their_stated_errors() {
        let (mut e_atan, mut e_acos, mut e_sc) = (0.0f64, 0.0f64, 0.0f64);
        for i in 0..=20_000 {
            let a = std::f64::consts::TAU * i as f64 / 20_000.0 - std::f64::consts::PI;
            for r in [1e-3f64, 1.0, 7.5] {
                let (y, x) = ((r * a.sin()) as f32, (r * a.cos()) as f32);
                e_atan = e_atan.max((atan2_approx(y, x) as f64 - (y as f64).atan2(x as f64)).abs());
            }
            let x = (-1.0 + 2.0 * i as f64 / 20_000.0) as f32;
            e_acos = e_acos.max((acos_approx(x) as f64 - (x as f64).acos()).abs());
            let d = 0.1 * (2.0 * i as f64 / 20_000.0 - 1.0);
            let (s, c) = sin_cos_small(d);
            e_sc = e_sc.max((s - d.sin()).abs()).max((c - d.cos()).abs());
        }
        assert!(e_atan < 2e-5, "atan2: {e_atan}");
        assert!(e_acos < 1e-4, "acos: {e_acos}");
        assert!(e_sc < 1e-13, "sin_cos_small: {e_sc}");
        assert_eq!(atan2_approx(0.0, 0.0), 0.0);
        assert!((atan2_approx(0.0, -1.0) - std::f32::consts::PI).abs() < 1e-6);
    }

    #[test]
    fn frame_is_orthonormal_for_many_normals() {
        for i in 0..1000 {
            let z = -1.0 + 2.0 * (i as f32 + 0.5) / 1000.0;
            let phi = i as f32 * 2.399963;
            let r = (1.0 - z * z).sqrt();
            let n = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            let f = Frame::from_normal(n);
            assert!((f.s.length() - 1.0).abs() < 1e-4);
            assert!((f.t.length() - 1.0).abs() < 1e-4);
            assert!(f.s.dot(f.t).abs() < 1e-4 && f.s.dot(n).abs() < 1e-4 && f.t.dot(n).abs() < 1e-4);
            assert!((f.s.cross(f.t) - n).length() < 1e-4, "right-handed");
            let v = Vec3::new(0.3, -0.5, 0.8);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
    }

    #[test]
    fn overlap_volume_of_boxes() {
        let a = Bounds3 { min: Vec3::ZERO, max: Vec3::ONE };
        let b = Bounds3 { min: Vec3::splat(0.5), max: Vec3::splat(2.0) };
        assert!((a.overlap_volume(&b) - 0.125).abs() < 1e-7);
        let c = Bounds3 { min: Vec3::splat(3.0), max: Vec3::splat(4.0) };
        assert_eq!(a.overlap_volume(&c), 0.0);
    }

    #[test]
    fn gauss_legendre_is_exact_for_polynomials() {
        for n in [1usize, 2, 5, 32, 128] {
            let (x, w) = gauss_legendre(n);
            assert!((w.iter().sum::<f64>() - 2.0).abs() < 1e-12, "n {n}");
            // ∫ x^k over [-1,1] = 2/(k+1) for even k, exact up to degree 2n-1
            for k in (0..2 * n).step_by(2).take(8) {
                let q: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(k as i32)).sum();
                assert!((q - 2.0 / (k as f64 + 1.0)).abs() < 1e-11, "n {n} k {k}: {q}");
            }
            assert!(x.windows(2).all(|p| p[0] < p[1]));
        }
    }

    /// The slab test against the segment's points: a segment that has one of 64 evenly spaced
    /// points inside the box meets it, and one that passes no closer than 1e-3 of the box (its
    /// distance found by 4 096 points) does not. Segments with zero components (in a plane of
    /// the axes, along an axis) included, and segments leaving a face outwards; at least 2 000
    /// of each answer.
    #[test]
    fn a_segment_meets_a_box_when_a_point_of_it_does() {
        let bx = Bounds3 { min: Vec3::new(-1.0, -0.5, 0.0), max: Vec3::new(1.0, 0.5, 2.0) };
        let mut s = crate::sampling::Sampler::new(4, 0, 0);
        let mut pick = || Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * 6.0 - 3.0;
        let (mut meets, mut misses) = (0, 0);
        for k in 0..20_000 {
            let a = pick();
            let mut b = pick();
            if k % 3 == 0 {
                b[k % 3] = a[k % 3]; // a zero component
            }
            if k % 7 == 0 {
                b.x = a.x;
                b.y = a.y; // along z
            }
            let at = |t: f32| a + (b - a) * t;
            let sampled = (0..=63).any(|i| bx.contains(at(i as f32 / 63.0)));
            let outside = |p: Vec3| (bx.min - p).max(p - bx.max).max(Vec3::ZERO).length();
            let far = (0..=4095).map(|i| outside(at(i as f32 / 4095.0))).fold(f32::INFINITY, f32::min) > 1e-3;
            let got = bx.meets_segment(a, b);
            if sampled {
                assert!(got, "{a} to {b} has a point in the box");
                meets += 1;
            } else if far {
                assert!(!got, "{a} to {b} passes outside the box");
                misses += 1;
            }
            // touching the faces from the box's own planes
            let on = Vec3::new(bx.max.x, a.y.clamp(-0.5, 0.5), a.z.clamp(0.0, 2.0));
            assert!(bx.meets_segment(on, on + Vec3::X), "a segment from a face outwards");
        }
        assert!(meets > 2_000 && misses > 2_000, "{meets} meet, {misses} miss");
    }
}
