//! Rough plastic (Mitsuba 3's `roughplastic`, `nonlinear = false`): the tabulated directional
//! transmittance and internal reflectance of the rough dielectric interface, cached per
//! `(alpha, eta)`, and the per-evaluation quantities `eval`, `pdf` and `sample` share.

use super::fresnel::{fresnel_dielectric, refract};
use super::microfacet::Ggx;
use super::{channel_mean, Texture};
use crate::image::Image;
use crate::math::{gauss_legendre, reflect, Color};
use crate::sampling::square_to_cosine_hemisphere_pdf;
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
    pub(crate) fn compute(alpha: f32, eta: f32) -> PlasticTables {
        let ggx = Ggx::new(alpha);
        let mus: Vec<f32> = (0..PLASTIC_TABLE_RES).map(|i| (i as f32 / (PLASTIC_TABLE_RES - 1) as f32).max(1e-6)).collect();
        // Integrate over the visible-normal sample space [0,1]² like Mitsuba's
        // eval_transmittance / eval_reflectance (Gauss–Legendre, 32² or 128² nodes).
        let quad = |eta_q: f32, mu: f32, transmit: bool| -> f64 {
            let res = if eta_q > 1.0 { 32 } else { 128 };
            let (nodes, weights) = gauss_legendre(res);
            let wi = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
            let mut acc = 0.0f64;
            for (ny, wy) in nodes.iter().zip(&weights) {
                for (nx, wx) in nodes.iter().zip(&weights) {
                    let u = Vec2::new((0.5 * nx + 0.5) as f32, (0.5 * ny + 0.5) as f32);
                    let m = ggx.sample_visible(wi, u);
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
        let mut external_transmittance = [0.0f32; PLASTIC_TABLE_RES];
        for (t, &mu) in external_transmittance.iter_mut().zip(&mus) {
            *t = quad(eta, mu, true) as f32;
        }
        let internal = mus.iter().map(|&mu| quad(1.0 / eta, mu, false) * mu as f64).sum::<f64>() / PLASTIC_TABLE_RES as f64 * 2.0;
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

type TableEntry = (u32, u32, &'static PlasticTables);

/// Tables for `(alpha, eta)`: computed once per process (under a global lock) and then found
/// through a per-thread list without locking. Tables are leaked: there is one per distinct
/// rough-plastic parameter pair, a handful per scene.
pub(crate) fn plastic_tables(alpha: f32, eta: f32) -> &'static PlasticTables {
    use std::cell::RefCell;
    use std::sync::Mutex;
    static GLOBAL: Mutex<Vec<TableEntry>> = Mutex::new(Vec::new());
    thread_local! {
        static LOCAL: RefCell<Vec<TableEntry>> = const { RefCell::new(Vec::new()) };
    }
    let key = (alpha.to_bits(), eta.to_bits());
    let find = |v: &[TableEntry]| v.iter().find(|e| (e.0, e.1) == key).map(|e| e.2);
    if let Some(t) = LOCAL.with(|l| find(&l.borrow())) {
        return t;
    }
    let t = {
        let mut g = GLOBAL.lock().unwrap_or_else(|e| e.into_inner());
        match find(&g) {
            Some(t) => t,
            None => {
                let t: &'static PlasticTables = Box::leak(Box::new(PlasticTables::compute(alpha, eta)));
                g.push((key.0, key.1, t));
                t
            }
        }
    };
    LOCAL.with(|l| l.borrow_mut().push((key.0, key.1, t)));
    t
}

/// Per-evaluation quantities of a rough plastic that eval, pdf and sample share.
pub(crate) struct PlasticLocal {
    kd: Color,
    pub(crate) ggx: Ggx,
    tables: &'static PlasticTables,
    /// Probability of sampling the specular lobe for this `wo`.
    pub(crate) prob_specular: f32,
    t_o: f32,
}

impl PlasticLocal {
    #[inline]
    pub(crate) fn new(images: &[Image], uv: Vec2, kd: &Texture, ks: Color, alpha: f32, eta: f32, wo: Vec3) -> PlasticLocal {
        let kd = kd.eval(images, uv);
        let tables = plastic_tables(alpha, eta);
        let (dm, sm) = (channel_mean(kd), channel_mean(ks));
        let ssw = if dm + sm > 0.0 { sm / (dm + sm) } else { 0.5 };
        let t_o = tables.transmittance(wo.z);
        let ps = (1.0 - t_o) * ssw;
        let pd = t_o * (1.0 - ssw);
        let prob_specular = if ps + pd > 0.0 { ps / (ps + pd) } else { 0.5 };
        PlasticLocal { kd, ggx: Ggx::new(alpha), tables, prob_specular, t_o }
    }

    #[inline]
    pub(crate) fn eval(&self, ks: Color, eta: f32, wo: Vec3, wi: Vec3) -> Color {
        let h = (wo + wi).normalize();
        let f = fresnel_dielectric(wo.dot(h), eta).0;
        let spec = ks * (f * self.ggx.d(h) * self.ggx.g1(wo, h) * self.ggx.g1(wi, h) / (4.0 * wo.z));
        let t_i = self.tables.transmittance(wi.z);
        let diff = self.kd / (1.0 - self.tables.internal_reflectance) * (FRAC_1_PI / (eta * eta) * wi.z * self.t_o * t_i);
        spec + diff
    }

    #[inline]
    pub(crate) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.prob_specular * self.ggx.reflection_pdf(wo, wi) + (1.0 - self.prob_specular) * square_to_cosine_hemisphere_pdf(wi)
    }
}
