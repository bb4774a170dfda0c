//! Plastics: a diffuse base under a dielectric coating of relative IOR `eta`, Mitsuba 3's
//! `plastic` (smooth coating) and `roughplastic` (microfacet coating, Beckmann or GGX).
//!
//! Smooth (`plastic.cpp`): a Dirac reflection of weight `F(cos θ_o)·ks`, and the diffuse lobe
//! `kd / (1 - Fdr_int) · cos θ_i / (π η²) · (1 - F(cos θ_o)) (1 - F(cos θ_i))`, `Fdr_int` the
//! diffuse Fresnel reflectance of the interface seen from inside
//! ([`fresnel_diffuse_reflectance`]`(1/η)`). The specular lobe is sampled with probability
//! `F·s / (F·s + (1 - F)(1 - s))`, `s = mean(ks) / (mean(kd) + mean(ks))`.
//!
//! Rough (`roughplastic.cpp`): specular `F D G / (4 cos θ_o)`, diffuse
//! `kd / (1 - R_int) · T(θ_i) T(θ_o) cos θ_i / (π η²)` with `T` the tabulated directional
//! transmittance of the rough interface and `R_int` its internal reflectance, tabulated like
//! Mitsuba 3 (Gauss–Legendre over the visible-normal sample space, 64 entries in cos θ; the
//! nodes' normals from `Microfacet::sample_visible_grid`, docs/lab/2026-11-30-performance.md "Time to first
//! sample") and cached per `(distribution, alpha, eta)`. `R_int` is Mitsuba's estimate
//! `mean_i 2 μ_i R(μ_i)` over 64 equally spaced `μ_i ∈ [0,1]`, about 1.5% below the exact
//! hemispherical integral; we keep it for agreement. The specular lobe is sampled with
//! probability `(1 - T(θ_o))·s / (…)`.
//!
//! `nonlinear = true` (both): the denominator `1 - Fdr` becomes `1 - kd·Fdr` per channel
//! (internal scattering changes the albedo's hue, as in Mitsuba).
//! For a bitmap `kd` the texel at `uv` stands in for Mitsuba's bitmap mean in `s` (a sampling
//! heuristic only: the estimate stays unbiased).

use super::fresnel::{fresnel_dielectric, fresnel_diffuse_reflectance, refract};
use super::microfacet::{Microfacet, MicrofacetKind};
use super::{channel_mean, reflect_z, BsdfSample, Lobe, TexCoord, Texture};
use crate::image::Image;
use crate::math::{gauss_legendre, reflect, Color};
use crate::sampling::{square_to_cosine_hemisphere, square_to_cosine_hemisphere_pdf};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Number of entries of the rough-plastic transmittance table (Mitsuba's
/// `MI_ROUGH_TRANSMITTANCE_RES`).
pub(crate) const PLASTIC_TABLE_RES: usize = 64;

/// Tabulated rough-interface quantities of a rough plastic.
#[derive(Debug)]
pub(crate) struct PlasticTables {
    /// Directional transmittance into the layer, at `cos θ = i / (RES - 1)`.
    pub(crate) external_transmittance: [f32; PLASTIC_TABLE_RES],
    /// Hemispherical (cosine-weighted) reflectance of the interface seen from inside.
    pub(crate) internal_reflectance: f32,
}

impl PlasticTables {
    pub(crate) fn compute(kind: MicrofacetKind, alpha: f32, eta: f32) -> PlasticTables {
        Self::compute_in(kind, alpha, eta, false)
    }

    /// [`PlasticTables::compute`], its 64 angles in parallel when `parallel` (only outside the
    /// lock of [`plastic_tables`], see [`precompute_plastic_tables`]); the same bits either way.
    fn compute_in(kind: MicrofacetKind, alpha: f32, eta: f32, parallel: bool) -> PlasticTables {
        use rayon::prelude::*;
        let ggx = Microfacet::isotropic(kind, alpha);
        let mus: Vec<f32> = (0..PLASTIC_TABLE_RES).map(|i| (i as f32 / (PLASTIC_TABLE_RES - 1) as f32).max(1e-6)).collect();
        // Integrate over the visible-normal sample space [0,1]² like Mitsuba's
        // eval_transmittance / eval_reflectance (Gauss–Legendre, 32² or 128² nodes).
        let rule = |n: usize| {
            let (nodes, weights) = gauss_legendre(n);
            let us: Vec<f32> = nodes.iter().map(|x| (0.5 * x + 0.5) as f32).collect();
            (us, weights)
        };
        let (gl32, gl128) = (rule(32), rule(128));
        let quad = |eta_q: f32, mu: f32, transmit: bool| -> f64 {
            let (us, weights) = if eta_q > 1.0 { &gl32 } else { &gl128 };
            let wi = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
            // the micro-normals of the whole grid at once (their costly parts per coordinate)
            let mut normals = Vec::new();
            ggx.sample_visible_grid(wi, us, us, &mut normals);
            let mut acc = 0.0f64;
            for (row, wy) in normals.chunks_exact(us.len()).zip(weights.iter()) {
                for (&m, wx) in row.iter().zip(weights.iter()) {
                    let (f, cos_t, _, eta_ti) = fresnel_dielectric(wi.dot(m), eta_q);
                    let v = if transmit {
                        let wo = refract(wi, m, cos_t, eta_ti);
                        if wo.z * wi.z >= 0.0 {
                            0.0
                        } else {
                            ggx.g1(wo, m) * (1.0 - f)
                        }
                    } else {
                        let wo = reflect(wi, m);
                        if wo.z <= 0.0 || wi.z <= 0.0 {
                            0.0
                        } else {
                            ggx.g1(wo, m) * f
                        }
                    };
                    acc += v as f64 * wx * wy * 0.25;
                }
            }
            acc
        };
        let row = |&mu: &f32| (quad(eta, mu, true) as f32, quad(1.0 / eta, mu, false) * mu as f64);
        let rows: Vec<(f32, f64)> = if parallel { mus.par_iter().map(row).collect() } else { mus.iter().map(row).collect() };
        let mut external_transmittance = [0.0f32; PLASTIC_TABLE_RES];
        for (t, r) in external_transmittance.iter_mut().zip(&rows) {
            *t = r.0;
        }
        let internal = rows.iter().map(|r| r.1).sum::<f64>() / PLASTIC_TABLE_RES as f64 * 2.0;
        PlasticTables { external_transmittance, internal_reflectance: internal as f32 }
    }

    /// Linear interpolation in the table (Mitsuba's `lerp_gather`).
    #[inline]
    pub(crate) fn transmittance(&self, cos_theta: f32) -> f32 {
        let x = cos_theta.clamp(0.0, 1.0) * (PLASTIC_TABLE_RES - 1) as f32;
        let i = (x as usize).min(PLASTIC_TABLE_RES - 2);
        let w = x - i as f32;
        let t = &self.external_transmittance;
        t[i] * (1.0 - w) + t[i + 1] * w
    }
}

type TableEntry = ((MicrofacetKind, u32, u32), &'static PlasticTables);

/// Every table computed in this process (leaked: a handful per scene).
static GLOBAL_TABLES: std::sync::Mutex<Vec<TableEntry>> = std::sync::Mutex::new(Vec::new());

/// Tables for `(kind, alpha, eta)`: computed once per process (under a global lock) and then found
/// through a per-thread list without locking. Tables are leaked: there is one per distinct
/// rough-plastic parameter pair, a handful per scene.
pub(crate) fn plastic_tables(kind: MicrofacetKind, alpha: f32, eta: f32) -> &'static PlasticTables {
    use std::cell::RefCell;
    thread_local! {
        static LOCAL: RefCell<Vec<TableEntry>> = const { RefCell::new(Vec::new()) };
    }
    let key = (kind, alpha.to_bits(), eta.to_bits());
    let find = |v: &[TableEntry]| v.iter().find(|e| e.0 == key).map(|e| e.1);
    if let Some(t) = LOCAL.with(|l| find(&l.borrow())) {
        return t;
    }
    let t = {
        let mut g = GLOBAL_TABLES.lock().unwrap_or_else(|e| e.into_inner());
        match find(&g) {
            Some(t) => t,
            None => {
                let t: &'static PlasticTables = Box::leak(Box::new(PlasticTables::compute(kind, alpha, eta)));
                g.push((key, t));
                t
            }
        }
    };
    LOCAL.with(|l| l.borrow_mut().push((key, t)));
    t
}

/// Compute, in parallel, the tables of every rough plastic in `materials` (nested ones
/// included) that the process does not have yet, so that rendering finds them ready instead of
/// computing them one after the other under [`plastic_tables`]'s lock (about 0.2 s each for
/// Beckmann, whose visible-normal sampling calls `erfinv`). Call it outside any rayon task
/// (scene preparation): the tables are computed without the lock, then published under it. The
/// tables are the same bits either way.
pub(crate) fn precompute_plastic_tables(materials: &[super::Material]) {
    use rayon::prelude::*;
    fn keys(m: &super::Material, out: &mut Vec<(MicrofacetKind, f32, f32)>) {
        use super::Material as M;
        match m {
            M::RoughPlastic { distribution, eta, .. } => out.push((distribution.kind, distribution.alpha_u, *eta)),
            M::TwoSided { front: a, back: b } | M::Blend { first: a, second: b, .. } => {
                keys(a, out);
                keys(b, out);
            }
            M::Mask { nested, .. } | M::BumpMap { nested, .. } | M::NormalMap { nested, .. } => keys(nested, out),
            _ => {}
        }
    }
    let mut wanted = Vec::new();
    materials.iter().for_each(|m| keys(m, &mut wanted));
    let bits = |&(k, a, e): &(MicrofacetKind, f32, f32)| (k, a.to_bits(), e.to_bits());
    {
        let g = GLOBAL_TABLES.lock().unwrap_or_else(|e| e.into_inner());
        wanted.retain(|w| !g.iter().any(|e| e.0 == bits(w)));
    }
    let mut distinct: Vec<(MicrofacetKind, f32, f32)> = Vec::new();
    for w in wanted {
        if !distinct.iter().any(|d| bits(d) == bits(&w)) {
            distinct.push(w);
        }
    }
    let wanted = distinct;
    let computed: Vec<PlasticTables> = wanted.par_iter().map(|&(k, a, e)| PlasticTables::compute_in(k, a, e, true)).collect();
    let mut g = GLOBAL_TABLES.lock().unwrap_or_else(|e| e.into_inner());
    for (w, t) in wanted.iter().zip(computed) {
        if !g.iter().any(|e| e.0 == bits(w)) {
            g.push((bits(w), Box::leak(Box::new(t))));
        }
    }
}

/// The diffuse base's albedo divided by `1 - R` (linear) or `1 - kd·R` (nonlinear), `R` the
/// internal reflectance of the coating.
#[inline]
fn diffuse_term(kd: Color, internal_reflectance: f32, nonlinear: bool) -> Color {
    if nonlinear {
        kd / (Color::ONE - kd * internal_reflectance)
    } else {
        kd / (1.0 - internal_reflectance)
    }
}

/// Probability of picking the specular lobe from the specular weight `s` and the specular
/// (`spec`) and diffuse (`diff`) energies of the coating seen from `wo`.
#[inline]
fn specular_probability(kd: Color, ks: Color, spec: f32, diff: f32) -> f32 {
    let (dm, sm) = (channel_mean(kd), channel_mean(ks));
    let ssw = if dm + sm > 0.0 { sm / (dm + sm) } else { 0.5 };
    let (ps, pd) = (spec * ssw, diff * (1.0 - ssw));
    if ps + pd > 0.0 {
        ps / (ps + pd)
    } else {
        0.5
    }
}

/// Per-evaluation quantities of a rough plastic that eval, pdf and sample share.
pub(crate) struct PlasticLocal {
    kd: Color,
    distribution: Microfacet,
    tables: &'static PlasticTables,
    /// Probability of sampling the specular lobe for this `wo`.
    prob_specular: f32,
    t_o: f32,
    nonlinear: bool,
}

impl PlasticLocal {
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn new(
        images: &[Image],
        uv: TexCoord,
        kd: &Texture,
        ks: Color,
        distribution: &Microfacet,
        eta: f32,
        nonlinear: bool,
        wo: Vec3,
    ) -> PlasticLocal {
        let kd = kd.eval(images, uv);
        let tables = plastic_tables(distribution.kind, distribution.alpha_u, eta);
        let t_o = tables.transmittance(wo.z);
        let prob_specular = specular_probability(kd, ks, 1.0 - t_o, t_o);
        PlasticLocal { kd, distribution: *distribution, tables, prob_specular, t_o, nonlinear }
    }

    #[inline]
    pub(crate) fn eval(&self, ks: Color, eta: f32, wo: Vec3, wi: Vec3) -> Color {
        let (spec, diff) = self.eval_parts(ks, eta, wo, wi);
        spec + diff
    }

    /// [`PlasticLocal::eval`]'s two terms apart: `(coating, base)`, for the cache's split of the
    /// lobes (`split.rs`).
    #[inline]
    pub(crate) fn eval_parts(&self, ks: Color, eta: f32, wo: Vec3, wi: Vec3) -> (Color, Color) {
        let d = &self.distribution;
        let h = (wo + wi).normalize();
        let f = fresnel_dielectric(wo.dot(h), eta).0;
        let spec = ks * (f * d.d(h) * d.g(wo, wi, h) / (4.0 * wo.z));
        let t_i = self.tables.transmittance(wi.z);
        let diff =
            diffuse_term(self.kd, self.tables.internal_reflectance, self.nonlinear) * (FRAC_1_PI / (eta * eta) * wi.z * self.t_o * t_i);
        (spec, diff)
    }

    /// The coating's roughness.
    #[inline]
    pub(crate) fn alpha(&self) -> f32 {
        self.distribution.alpha_u
    }

    #[inline]
    pub(crate) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.prob_specular * self.distribution.reflection_pdf(wo, wi) + (1.0 - self.prob_specular) * square_to_cosine_hemisphere_pdf(wi)
    }

    /// A direction from the specular lobe (`u_lobe < prob_specular`) or the diffuse one.
    #[inline]
    pub(crate) fn sample_direction(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> (Vec3, Lobe) {
        if u_lobe < self.prob_specular {
            (reflect(wo, self.distribution.sample_visible(wo, u)), Lobe::Glossy)
        } else {
            (square_to_cosine_hemisphere(u), Lobe::Diffuse)
        }
    }
}

/// Smooth plastic: `f cos θ_i` of the diffuse lobe (the Dirac lobe is only sampled).
#[inline]
pub(crate) fn smooth_eval(kd: Color, eta: f32, nonlinear: bool, wo: Vec3, wi: Vec3) -> Color {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return Color::ZERO;
    }
    let (f_o, f_i) = (fresnel_dielectric(wo.z, eta).0, fresnel_dielectric(wi.z, eta).0);
    diffuse_term(kd, fresnel_diffuse_reflectance(1.0 / eta), nonlinear)
        * (square_to_cosine_hemisphere_pdf(wi) / (eta * eta) * (1.0 - f_o) * (1.0 - f_i))
}

/// Smooth plastic: probability of sampling the Dirac lobe from `wo` (`wo.z > 0`).
#[inline]
fn smooth_specular_probability(kd: Color, ks: Color, eta: f32, wo: Vec3) -> f32 {
    let f = fresnel_dielectric(wo.z, eta).0;
    specular_probability(kd, ks, f, 1.0 - f)
}

/// Smooth plastic: density of sampling `wi` through the diffuse lobe.
#[inline]
pub(crate) fn smooth_pdf(kd: Color, ks: Color, eta: f32, wo: Vec3, wi: Vec3) -> f32 {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    (1.0 - smooth_specular_probability(kd, ks, eta, wo)) * square_to_cosine_hemisphere_pdf(wi)
}

/// Smooth plastic: the Dirac reflection or a diffuse direction.
#[inline]
pub(crate) fn smooth_sample(kd: Color, ks: Color, eta: f32, nonlinear: bool, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
    if wo.z <= 0.0 {
        return None;
    }
    let p_spec = smooth_specular_probability(kd, ks, eta, wo);
    if u_lobe < p_spec {
        let f = fresnel_dielectric(wo.z, eta).0;
        return Some(BsdfSample { wi: reflect_z(wo), weight: ks * (f / p_spec), pdf: p_spec, lobe: Lobe::Specular, eta: 1.0 });
    }
    let wi = square_to_cosine_hemisphere(u);
    let pdf = (1.0 - p_spec) * square_to_cosine_hemisphere_pdf(wi);
    if !(pdf > 0.0) || !pdf.is_finite() {
        return None;
    }
    let weight = smooth_eval(kd, eta, nonlinear, wo, wi) / pdf;
    Some(BsdfSample { wi, weight, pdf, lobe: Lobe::Diffuse, eta: 1.0 })
}
