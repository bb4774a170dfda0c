//! Adaptive grids of SH irradiance probes, as the production engines bake them for dynamic
//! objects, built from the same photons as the octree: the comparison of issue 13, item 6
//! (`docs/guide/baking.md`, "Bytes against error"). Not a renderer path: a measuring stick for the
//! paper's representation (its §1 and §10 claim a compact volumetric description of incident
//! light; this is what the industry stores instead).
//!
//! # What the products do, and what is implemented here
//! - **Bricks** (Unreal's volumetric lightmap, Unity's Adaptive Probe Volumes): `4³` probes
//!   per brick, spanning the brick's cube (spacing = brick edge / 3; neighbouring bricks
//!   repeat their shared face's probes, as both store them). Bricks of the coarsest level
//!   cover the whole volume; a brick whose cube (grown by half a probe spacing) meets
//!   geometry is replaced by 8 bricks of half the edge, down to the finest level. Unity's
//!   brick sizes are powers of 3 of the minimum spacing and Unreal refines by 4 per level;
//!   here by 2 (an octree of bricks, [`BrickLayout`]). Only the leaf bricks are stored, with
//!   an index tree of 4-byte nodes (internal: first child; leaf: brick index) in place of
//!   Unreal's indirection texture and Unity's cell index. `root_scale` grows the lattice's
//!   cube past the scene's to tune the spacing continuously (equal-byte comparisons).
//! - **Probe value**: the SH projection of the incident radiance at the probe, order 1 (4
//!   coefficients per channel, Unity's default) or 2 (9, Unreal). The engines path trace from
//!   each probe; here the same photons as the octree's give it, by the beam estimate of their
//!   flights passing near the probe (`beams.rs`), kernel radius `radius_scale` × the probe's
//!   spacing.
//! - **Validity** (Unity): a probe whose sampling rays see more than `validity_threshold` of
//!   backfaces (default 0.25, Unity's) is inside geometry or outside the room: *invalid*.
//!   The caller gives the backface fraction (rays in the scene).
//! - **Dilation** (Unity; Unreal overwrites its inside-geometry samples from valid
//!   neighbours the same way): an invalid probe gets the `1/d²`-weighted mean of the valid
//!   (or already dilated) probes within `dilation_radius` of its spacings, `dilation_iterations`
//!   passes.
//! - **Query** (Unity's leak reduction "validity based"): the trilinear blend of the 8
//!   probes around the point in its brick, invalid probes' weights set to 0 and the rest
//!   renormalised (all 8 invalid: plain trilinear of their dilated values); irradiance for a
//!   normal by the cosine-lobe convolution (`sh.rs`). Not implemented: Unity's virtual offset
//!   (moving an invalid probe's capture point out of geometry; here an invalid probe is
//!   dilated instead), its normal- and view-bias of the sampling position and its
//!   normal-based weights, Unreal's sky bent normal and directional-light shadowing bytes.
//! - **Storage** (as Unreal's: L0 as a small float, the rest as 8-bit values normalised by
//!   it): per probe L0 as RGBE (4 bytes), each higher coefficient of each channel as a snorm8
//!   ratio to that channel's L0, one validity byte: 14 bytes at order 1 (Unity's APV: 16),
//!   29 at order 2 (Unreal: 28). [`ProbeGrid::bytes`] counts these, the index nodes and
//!   nothing else (the brick positions follow from the index).

mod beams;
use super::sh;
#[cfg(test)]
mod tests;

pub use beams::Flights;
pub use sh::ShOrder;

use crate::math::Bounds3;
use crate::photon::Photon;
use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use sh::PackedProbe;
pub use sh::MAX_COEFFS;

/// Probes per brick edge.
pub const BRICK: usize = 4;
/// Probes per brick.
pub const BRICK_PROBES: usize = BRICK * BRICK * BRICK;
/// Finest level allowed (`2^12` bricks per axis).
pub const MAX_LEVEL: u32 = 12;
/// Most probes a grid may hold.
pub const MAX_PROBES: usize = 1 << 26;
/// High bit of an index node: a leaf (the rest: brick index).
const LEAF: u32 = 1 << 31;

/// Settings of a probe grid (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ProbeSettings {
    pub order: ShOrder,
    /// Level of the bricks everywhere (edge = cube / 2^level).
    pub base_level: u32,
    /// Level of the bricks where geometry is.
    pub max_level: u32,
    /// The brick lattice's cube over the scene's bounding cube (≥ 1).
    pub root_scale: f32,
    /// Kernel radius of the beam estimate, in probe spacings.
    pub radius_scale: f32,
    /// Largest fraction of backfaces a valid probe's rays may see.
    pub validity_threshold: f32,
    pub dilation_iterations: u32,
    /// Search radius of the dilation, in the invalid probe's spacings.
    pub dilation_radius: f32,
    /// Drop invalid probes from the blend (Unity's validity-based leak reduction).
    pub leak_reduction: bool,
}

impl Default for ProbeSettings {
    fn default() -> Self {
        ProbeSettings {
            order: ShOrder::L1,
            base_level: 1,
            max_level: 3,
            root_scale: 1.0,
            radius_scale: 1.0,
            validity_threshold: 0.25,
            dilation_iterations: 2,
            dilation_radius: 1.75,
            leak_reduction: true,
        }
    }
}

/// Errors of a probe-grid build.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ProbeError {
    #[error("invalid probe settings: {0}")]
    InvalidSettings(String),
    #[error("invalid probe-grid bounds: {0:?}")]
    InvalidBounds(Bounds3),
    #[error("{photons} photons but {lengths} flight lengths")]
    LengthMismatch { photons: usize, lengths: usize },
    #[error("too many probes: {0} (at most {max})", max = MAX_PROBES)]
    TooManyProbes(usize),
}

impl ProbeSettings {
    pub fn validate(&self) -> Result<(), ProbeError> {
        let bad = |m: String| Err(ProbeError::InvalidSettings(m));
        if self.max_level < self.base_level || self.max_level > MAX_LEVEL {
            return bad(format!("levels {}..{} (need base ≤ max ≤ {MAX_LEVEL})", self.base_level, self.max_level));
        }
        if !(self.root_scale >= 1.0 && self.root_scale <= 16.0) {
            return bad(format!("root_scale {} (need 1..16)", self.root_scale));
        }
        if !(self.radius_scale > 0.0 && self.radius_scale <= 16.0) {
            return bad(format!("radius_scale {} (need (0, 16])", self.radius_scale));
        }
        if !(0.0..=1.0).contains(&self.validity_threshold) {
            return bad(format!("validity_threshold {} (need 0..1)", self.validity_threshold));
        }
        if !(self.dilation_radius >= 0.0 && self.dilation_radius <= 16.0) {
            return bad(format!("dilation_radius {} (need 0..16)", self.dilation_radius));
        }
        Ok(())
    }
}

/// Where the bricks are: the index tree and the leaf bricks (no values).
#[derive(Clone, Debug, PartialEq)]
pub struct BrickLayout {
    /// Minimum corner of the lattice's cube.
    pub origin: Vec3,
    /// Edge of the lattice's cube.
    pub size: f32,
    /// Index tree, 4 bytes per node: internal `first child` (8 consecutive nodes, child `c`
    /// the octant `(c & 1, (c >> 1) & 1, (c >> 2) & 1)`), leaf `LEAF | brick`.
    nodes: Vec<u32>,
    /// Leaf bricks: minimum corner and level.
    bricks: Vec<(Vec3, u32)>,
}

/// Conservative triangle–box overlap: the triangle's bounding box meets the box and its
/// plane passes through the box (two of the 13 separating axes of the exact test: a
/// triangle passing near a box corner may count as meeting it, so a few bricks too many are
/// refined, never too few).
fn triangle_meets_box(t: &[Vec3; 3], lo: Vec3, hi: Vec3) -> bool {
    let tmin = t[0].min(t[1]).min(t[2]);
    let tmax = t[0].max(t[1]).max(t[2]);
    if tmin.cmpgt(hi).any() || tmax.cmplt(lo).any() {
        return false;
    }
    let n = (t[1] - t[0]).cross(t[2] - t[0]);
    let c = 0.5 * (lo + hi);
    let h = 0.5 * (hi - lo);
    let r = h.x * n.x.abs() + h.y * n.y.abs() + h.z * n.z.abs();
    (n.dot(c - t[0])).abs() <= r
}

fn sphere_meets_box(c: Vec3, r: f32, lo: Vec3, hi: Vec3) -> bool {
    let nearest = c.clamp(lo, hi);
    let far = (c - lo).abs().max((c - hi).abs());
    (nearest - c).length_squared() <= r * r && far.length_squared() >= r * r
}

impl BrickLayout {
    /// Bricks over `bounds` (made a cube: same centre, largest extent × `root_scale`), refined
    /// where the triangles or spheres (centre, radius) are.
    pub fn new(bounds: Bounds3, triangles: &[[Vec3; 3]], spheres: &[(Vec3, f32)], s: &ProbeSettings) -> Result<BrickLayout, ProbeError> {
        s.validate()?;
        let e = bounds.extent().max_element();
        if bounds.is_empty() || !(e > 0.0) || !e.is_finite() || !bounds.min.is_finite() {
            return Err(ProbeError::InvalidBounds(bounds));
        }
        let size = e * (1.0 + 1e-5) * s.root_scale;
        let origin = bounds.center() - Vec3::splat(0.5 * size);
        let mut l = BrickLayout { origin, size, nodes: vec![0], bricks: Vec::new() };
        // (node, cell min, level, triangles meeting it, spheres meeting it)
        let mut stack =
            vec![(0usize, origin, 0u32, (0..triangles.len() as u32).collect::<Vec<_>>(), (0..spheres.len() as u32).collect::<Vec<_>>())];
        while let Some((node, lo, level, tris, sphs)) = stack.pop() {
            let edge = size / (1u32 << level) as f32;
            let grow = edge / (2.0 * (BRICK - 1) as f32);
            let (glo, ghi) = (lo - grow, lo + Vec3::splat(edge) + grow);
            let tris: Vec<u32> = tris.into_iter().filter(|&i| triangle_meets_box(&triangles[i as usize], glo, ghi)).collect();
            let sphs: Vec<u32> =
                sphs.into_iter().filter(|&i| sphere_meets_box(spheres[i as usize].0, spheres[i as usize].1, glo, ghi)).collect();
            let split = level < s.base_level || (level < s.max_level && (!tris.is_empty() || !sphs.is_empty()));
            if split {
                let first = l.nodes.len();
                l.nodes.extend_from_slice(&[0; 8]);
                l.nodes[node] = first as u32;
                for c in (0..8).rev() {
                    let off = Vec3::new((c & 1) as f32, ((c >> 1) & 1) as f32, ((c >> 2) & 1) as f32) * (0.5 * edge);
                    stack.push((first + c, lo + off, level + 1, tris.clone(), sphs.clone()));
                }
            } else {
                if (l.bricks.len() + 1) * BRICK_PROBES > MAX_PROBES {
                    return Err(ProbeError::TooManyProbes((l.bricks.len() + 1) * BRICK_PROBES));
                }
                l.nodes[node] = LEAF | l.bricks.len() as u32;
                l.bricks.push((lo, level));
            }
        }
        Ok(l)
    }

    pub fn bricks(&self) -> usize {
        self.bricks.len()
    }

    pub fn probes(&self) -> usize {
        self.bricks.len() * BRICK_PROBES
    }

    pub fn nodes(&self) -> usize {
        self.nodes.len()
    }

    /// Stored bytes of a grid on this layout: probes at `order`'s size plus 4 per index node.
    pub fn bytes(&self, order: ShOrder) -> usize {
        self.probes() * order.probe_bytes() + 4 * self.nodes.len()
    }

    /// Probe spacing of a brick of `level`.
    pub fn spacing(&self, level: u32) -> f32 {
        self.size / (1u32 << level) as f32 / (BRICK - 1) as f32
    }

    /// Position of probe `k` (`x + 4 y + 16 z`) of brick `b`.
    pub fn probe_position(&self, b: usize, k: usize) -> Vec3 {
        let (lo, level) = self.bricks[b];
        let ijk = Vec3::new((k % BRICK) as f32, ((k / BRICK) % BRICK) as f32, (k / (BRICK * BRICK)) as f32);
        lo + ijk * self.spacing(level)
    }

    /// The leaf brick holding `p` (clamped into the cube).
    pub fn brick_at(&self, p: Vec3) -> usize {
        let mut lo = self.origin;
        let mut edge = self.size;
        let p = p.clamp(self.origin, self.origin + Vec3::splat(self.size));
        let mut node = 0usize;
        loop {
            let v = self.nodes[node];
            if v & LEAF != 0 {
                return (v & !LEAF) as usize;
            }
            edge *= 0.5;
            let c = lo + Vec3::splat(edge);
            let (bx, by, bz) = (p.x >= c.x, p.y >= c.y, p.z >= c.z);
            lo += Vec3::new(bx as u32 as f32, by as u32 as f32, bz as u32 as f32) * edge;
            node = v as usize + (bx as usize | (by as usize) << 1 | (bz as usize) << 2);
        }
    }
}

/// Build statistics.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ProbeStats {
    pub bricks: usize,
    pub probes: usize,
    pub nodes: usize,
    /// [`ProbeGrid::bytes`].
    pub bytes: usize,
    pub invalid_probes: usize,
    /// Invalid probes the dilation gave a value.
    pub dilated_probes: usize,
    /// Mean photon flights per probe estimate.
    pub mean_flights: f64,
    /// Finest probe spacing (world units).
    pub min_spacing: f32,
    pub t_build_s: f64,
}

/// A built probe grid (`Send + Sync`): layout plus quantised probes.
#[derive(Clone, Debug)]
pub struct ProbeGrid {
    layout: BrickLayout,
    settings: ProbeSettings,
    /// Per probe: L0 (RGBE).
    l0: Vec<[u8; 4]>,
    /// Per probe, `3 (coefficients − 1)` snorm8 values (coefficient-major, then channel).
    higher: Vec<i8>,
    /// Per probe: 255 valid, 0 invalid.
    validity: Vec<u8>,
    stats: ProbeStats,
}

/// What a probe grid is built from.
#[derive(Clone, Copy, Debug)]
pub struct ProbeInputs<'a> {
    /// The photon pass's global photons (the octree's).
    pub photons: &'a [Photon],
    /// Per photon, the length of its last flight (see [`Flights`]).
    pub flight_lengths: &'a [f32],
}

impl ProbeGrid {
    /// Estimate, validate, dilate and quantise the probes of `layout`. `backface_fraction(p)`
    /// is the fraction of the sampling rays from `p` that meet a backface.
    pub fn build(
        layout: BrickLayout,
        inputs: ProbeInputs<'_>,
        settings: &ProbeSettings,
        backface_fraction: &(dyn Fn(Vec3) -> f32 + Sync),
    ) -> Result<ProbeGrid, ProbeError> {
        settings.validate()?;
        if inputs.photons.len() != inputs.flight_lengths.len() {
            return Err(ProbeError::LengthMismatch { photons: inputs.photons.len(), lengths: inputs.flight_lengths.len() });
        }
        let t0 = std::time::Instant::now();
        let n = layout.probes();
        let order = settings.order;
        // one flight grid per brick level (cell = that level's kernel radius), built in turn
        let mut levels: Vec<u32> = layout.bricks.iter().map(|b| b.1).collect();
        levels.sort_unstable();
        levels.dedup();
        let mut estimates: Vec<([Vec3; MAX_COEFFS], usize, bool)> = vec![([Vec3::ZERO; MAX_COEFFS], 0, true); n];
        for level in levels {
            let r = settings.radius_scale * layout.spacing(level);
            let flights = Flights::new(inputs.photons, inputs.flight_lengths, layout.origin, layout.size, r);
            estimates.par_iter_mut().enumerate().filter(|(i, _)| layout.bricks[i / BRICK_PROBES].1 == level).for_each(|(i, e)| {
                let p = layout.probe_position(i / BRICK_PROBES, i % BRICK_PROBES);
                let (c, used) = flights.estimate(p, r, order);
                *e = (c, used, backface_fraction(p) <= settings.validity_threshold);
            });
        }
        let mean_flights = estimates.iter().map(|e| e.1 as f64).sum::<f64>() / n.max(1) as f64;
        let valid: Vec<bool> = estimates.iter().map(|e| e.2).collect();
        let mut values: Vec<[Vec3; MAX_COEFFS]> = estimates.into_iter().map(|e| e.0).collect();
        let dilated_probes = dilate(&layout, &valid, &mut values, settings);
        let mut grid = ProbeGrid::from_probes(layout, settings, &values, &valid)?;
        grid.stats.dilated_probes = dilated_probes;
        grid.stats.mean_flights = mean_flights;
        grid.stats.t_build_s = t0.elapsed().as_secs_f64();
        Ok(grid)
    }

    /// A grid from given probe values (radiance SH coefficients, world order of
    /// [`BrickLayout::probe_position`]) and validities: quantised as stored, nothing dilated.
    pub fn from_probes(
        layout: BrickLayout,
        settings: &ProbeSettings,
        values: &[[Vec3; MAX_COEFFS]],
        valid: &[bool],
    ) -> Result<ProbeGrid, ProbeError> {
        settings.validate()?;
        let n = layout.probes();
        if values.len() != n || valid.len() != n {
            return Err(ProbeError::InvalidSettings(format!("{} values and {} validities for {n} probes", values.len(), valid.len())));
        }
        let order = settings.order;
        let k = order.coefficients();
        let finest = layout.bricks.iter().map(|b| b.1).max().unwrap_or(0);
        let mut grid = ProbeGrid {
            l0: Vec::with_capacity(n),
            higher: Vec::with_capacity(n * 3 * (k - 1)),
            validity: Vec::with_capacity(n),
            settings: *settings,
            stats: ProbeStats::default(),
            layout,
        };
        for (c, &v) in values.iter().zip(valid) {
            let p = sh::pack(c, order, v);
            grid.l0.push(p.l0);
            for h in &p.higher[..k - 1] {
                grid.higher.extend_from_slice(h);
            }
            grid.validity.push(p.validity);
        }
        grid.stats = ProbeStats {
            bricks: grid.layout.bricks(),
            probes: n,
            nodes: grid.layout.nodes(),
            bytes: grid.bytes(),
            invalid_probes: valid.iter().filter(|v| !**v).count(),
            min_spacing: grid.layout.spacing(finest),
            ..ProbeStats::default()
        };
        Ok(grid)
    }

    pub fn stats(&self) -> &ProbeStats {
        &self.stats
    }

    pub fn settings(&self) -> &ProbeSettings {
        &self.settings
    }

    pub fn layout(&self) -> &BrickLayout {
        &self.layout
    }

    /// Bytes held: the quantised probes and the index nodes (equal to
    /// [`BrickLayout::bytes`] of the layout at the grid's order).
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.l0.as_slice())
            + std::mem::size_of_val(self.higher.as_slice())
            + std::mem::size_of_val(self.validity.as_slice())
            + 4 * self.layout.nodes.len()
    }

    /// Probe `i`'s decoded coefficients and validity.
    pub fn probe(&self, i: usize) -> ([Vec3; MAX_COEFFS], bool) {
        let k = self.settings.order.coefficients();
        let mut p = PackedProbe { l0: self.l0[i], higher: [[0; 3]; MAX_COEFFS - 1], validity: self.validity[i] };
        for j in 0..k - 1 {
            let o = (i * (k - 1) + j) * 3;
            p.higher[j] = [self.higher[o], self.higher[o + 1], self.higher[o + 2]];
        }
        (sh::unpack(&p, self.settings.order), p.validity != 0)
    }

    /// The blended radiance coefficients at `p` (trilinear within `p`'s brick; invalid probes
    /// dropped and the weights renormalised when `leak_reduction` is on and any is valid).
    pub fn coefficients(&self, p: Vec3) -> [Vec3; MAX_COEFFS] {
        let b = self.layout.brick_at(p);
        let (lo, level) = self.layout.bricks[b];
        let u = ((p - lo) / self.layout.spacing(level)).clamp(Vec3::ZERO, Vec3::splat((BRICK - 1) as f32));
        let i = u.floor().min(Vec3::splat((BRICK - 2) as f32));
        let f = u - i;
        let base = b * BRICK_PROBES + i.x as usize + BRICK * i.y as usize + BRICK * BRICK * i.z as usize;
        let mut corners = [([Vec3::ZERO; MAX_COEFFS], false, 0.0f32); 8];
        let mut valid_weight = 0.0;
        for (c, corner) in corners.iter_mut().enumerate() {
            let (dx, dy, dz) = (c & 1, (c >> 1) & 1, (c >> 2) & 1);
            let w =
                (if dx == 1 { f.x } else { 1.0 - f.x }) * (if dy == 1 { f.y } else { 1.0 - f.y }) * (if dz == 1 { f.z } else { 1.0 - f.z });
            let (coef, valid) = self.probe(base + dx + BRICK * dy + BRICK * BRICK * dz);
            if valid {
                valid_weight += w;
            }
            *corner = (coef, valid, w);
        }
        let drop = self.settings.leak_reduction && valid_weight > 0.0;
        let total = if drop { valid_weight } else { 1.0 };
        let mut out = [Vec3::ZERO; MAX_COEFFS];
        for (coef, valid, w) in corners {
            if drop && !valid {
                continue;
            }
            for (o, c) in out.iter_mut().zip(coef.iter()) {
                *o += *c * (w / total);
            }
        }
        out
    }

    /// Irradiance (W m⁻², per channel) at `p` for the normal `n`.
    pub fn irradiance(&self, p: Vec3, n: Vec3) -> Vec3 {
        sh::irradiance(&self.coefficients(p), self.settings.order, n)
    }
}

/// Unity's dilation: each invalid probe takes the `1/d²`-weighted mean of the valid (or
/// already dilated) probes within `dilation_radius` of its spacings; `dilation_iterations`
/// passes. Returns how many invalid probes got a value.
fn dilate(layout: &BrickLayout, valid: &[bool], values: &mut [[Vec3; MAX_COEFFS]], s: &ProbeSettings) -> usize {
    if s.dilation_iterations == 0 || valid.iter().all(|v| *v) {
        return 0;
    }
    let finest = layout.bricks.iter().map(|b| b.1).max().unwrap_or(0);
    let bin = s.dilation_radius.max(1.0) * layout.spacing(finest);
    let key = |p: Vec3| {
        let q = ((p - layout.origin) / bin).floor();
        (q.x as i32, q.y as i32, q.z as i32)
    };
    let mut bins: std::collections::HashMap<(i32, i32, i32), Vec<u32>> = std::collections::HashMap::new();
    for i in 0..layout.probes() {
        bins.entry(key(layout.probe_position(i / BRICK_PROBES, i % BRICK_PROBES))).or_default().push(i as u32);
    }
    let mut has = valid.to_vec();
    let mut dilated = 0;
    for _ in 0..s.dilation_iterations {
        let updates: Vec<(usize, [Vec3; MAX_COEFFS])> = (0..layout.probes())
            .into_par_iter()
            .filter(|&i| !valid[i])
            .filter_map(|i| {
                let (b, k) = (i / BRICK_PROBES, i % BRICK_PROBES);
                let p = layout.probe_position(b, k);
                let r = s.dilation_radius * layout.spacing(layout.bricks[b].1);
                let (lo, hi) = (key(p - r), key(p + r));
                let (mut sum, mut wsum) = ([Vec3::ZERO; MAX_COEFFS], 0.0f32);
                for x in lo.0..=hi.0 {
                    for y in lo.1..=hi.1 {
                        for z in lo.2..=hi.2 {
                            for &j in bins.get(&(x, y, z)).map_or(&[][..], |v| v.as_slice()) {
                                let j = j as usize;
                                if j == i || !has[j] {
                                    continue;
                                }
                                let q = layout.probe_position(j / BRICK_PROBES, j % BRICK_PROBES);
                                let d2 = (q - p).length_squared();
                                if d2 > r * r {
                                    continue;
                                }
                                // a probe at the same place (a brick border) counts fully
                                let w = 1.0 / d2.max(1e-6 * r * r);
                                wsum += w;
                                for (a, c) in sum.iter_mut().zip(values[j].iter()) {
                                    *a += *c * w;
                                }
                            }
                        }
                    }
                }
                (wsum > 0.0).then(|| (i, sum.map(|c| c / wsum)))
            })
            .collect();
        for (i, v) in updates {
            if !has[i] {
                dilated += 1;
            }
            values[i] = v;
            has[i] = true;
        }
    }
    dilated
}

// Shared by the render threads, like the octree.
const _: () = {
    const fn assert_send_sync<T: Send + Sync>() {}
    assert_send_sync::<ProbeGrid>();
};
