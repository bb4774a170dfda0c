//! The octree updated by the photons that moved, without a pass over the others (issue 26,
//! item 2: "subtract their old contributions from the leaf sums and add the new ones";
//! `integrators/octree/rebake.rs`, docs/guide/baking.md "Inserted objects").
//!
//! A valid leaf's estimate (`estimate.rs`) is a sum over the photons of its gathering box, each
//! weighted by what the leaf's box, settings and lit surfaces fix ([`LeafWeights`]). Given those
//! sums in f64 ([`LeafSums`], kept from a full [`Octree::refit_with_sums`]), the photons
//! removed and added by a re-bake update them: each moved photon is found in its own leaf, and
//! in every neighbour whose enlarged box gathers it by the build's own tests (the neighbour's box
//! reaches the photon's cell, then the whole cell lies inside it or the photon passes the
//! half-open test on the axes where the cell sticks out), and its terms are subtracted or added.
//! The leaves no moved photon reaches keep their value. A leaf is estimated again from its
//! photons, as [`Octree::refit`] does, where the sums cannot follow:
//! - its box meets a box where the surfaces changed (its lit areas change);
//! - it had no photons before (no sums; it gathers unmoved photons of its neighbours too);
//! - the moved photons change its lit sides: the geometry-area estimator lights a group of
//!   coplanar triangles on its back where photons arrived from behind, and on its front unless
//!   it is lit on its back alone (`geometry.rs`, `lit_areas`); the sums keep each group's
//!   photons counted per side (`GroupHits`), and the sides change when a count reaches or
//!   leaves zero;
//! - its box meets an analytic sphere (whose lit part follows its photons) and a moved photon.
//!
//! Those leaves take the photons of the leaves their boxes meet (a pass over the positions, in
//! their order) and are estimated from them by the build's sort and gather: the same photons in
//! the same order as in a full refit, so the same bits. The updated sums differ from a full refit's only by the
//! order of their f64 additions (test `an_incremental_update_equals_a_rebake_on_the_same_topology`:
//! values within 1e-5 of a leaf's largest). The update needs leaf boxes that do not depend on
//! the counts (`Enlarge::All`, or no enlargement); the result keeps no sampled photons for the
//! leak test (each sample is the mean: `OctreeParts::without_leak_samples`).

use super::build::{assemble, assign_counts, sort_assign_estimate, LeafOut, Leaves};
use super::cells::LeafBuild;
use super::estimate::{LeafEstimate, LeafState};
use super::sort::{KeyFn, PhotonRec, RecNg};
use super::{Enlarge, Estimator, Octree, OctreeError, RefitStats, Split, Surfaces, NO_VALUE};
use crate::math::Bounds3;
use crate::photon::Photon;
use glam::Vec3;
use rayon::prelude::*;

/// The sums behind a tree's valid leaves, by node (module docs). They describe the tree
/// [`Octree::refit_with_sums`] or the last [`Octree::refit_incremental`] returned, with the
/// photons it was given; pass them only with that tree.
pub struct LeafSums {
    states: Vec<Option<Box<LeafState>>>,
    /// The smallest depth of a valid leaf (the widest gathering margin).
    min_depth: u32,
}

/// The photons removed (`sign` −1) and added (+1), numbered in that order, with their own
/// leaves ([`NOWHERE`] outside the tree, as the build drops them).
struct Moved<'a> {
    removed: &'a [Photon],
    added: &'a [Photon],
    node: Vec<u32>,
    cosine_min: Option<f32>,
}

const NOWHERE: u32 = u32::MAX;

impl Moved<'_> {
    #[inline]
    fn photon(&self, i: u32) -> (&Photon, f64) {
        let i = i as usize;
        match self.removed.get(i) {
            Some(ph) => (ph, -1.0),
            None => (&self.added[i - self.removed.len()], 1.0),
        }
    }

    #[inline]
    fn rec(&self, i: u32) -> RecNg {
        RecNg::from_photon(self.photon(i).0, self.cosine_min)
    }
}

impl Octree {
    /// Whether [`Octree::refit_incremental`] can follow this tree's estimates: its leaves' boxes
    /// do not depend on their photon counts.
    pub fn updates_incrementally(&self) -> bool {
        self.settings.enlarge == Enlarge::All || !(self.settings.epsilon > 0.0)
    }

    /// [`Octree::refit`] of every leaf, with the sums an incremental update starts from.
    pub fn refit_with_sums(
        &self,
        photons: &[Photon],
        surfaces: Option<Surfaces<'_>>,
    ) -> Result<(Octree, RefitStats, LeafSums), OctreeError> {
        let (tree, stats, states) = self.refit_capture(photons, surfaces, None, true)?;
        let mut by_node: Vec<Option<Box<LeafState>>> = (0..tree.nodes.len()).map(|_| None).collect();
        for (node, s) in states {
            by_node[node as usize] = Some(s);
        }
        let min_depth = tree.stats.depth_histogram.iter().position(|&n| n > 0).unwrap_or(0) as u32;
        Ok((tree, stats, LeafSums { states: by_node, min_depth }))
    }

    /// This tree (with `sums`, module docs) updated for `photons`, which are its photons less
    /// `removed` plus `added`; `boxes`: where the surfaces changed (`surfaces` are the scene's
    /// now). Equals [`Octree::refit`] of `photons` up to the order of the sums' additions.
    /// `sums` then describe the tree returned. A tree that cannot be updated so
    /// ([`Octree::updates_incrementally`]), or sums found not to describe it (another node
    /// count, a photon removed from a leaf without one), give a full refit.
    pub fn refit_incremental(
        &self,
        sums: &mut LeafSums,
        photons: &[Photon],
        removed: &[Photon],
        added: &[Photon],
        surfaces: Option<Surfaces<'_>>,
        boxes: &[Bounds3],
    ) -> Result<(Octree, RefitStats), OctreeError> {
        let settings = &self.settings;
        if settings.estimator == Estimator::GeometryArea && surfaces.is_none() {
            return Err(OctreeError::MissingGeometry);
        }
        if photons.len() > u32::MAX as usize {
            return Err(OctreeError::TooManyPhotons(photons.len()));
        }
        let full = |sums: &mut LeafSums| {
            let (t, st, s) = self.refit_with_sums(photons, surfaces)?;
            *sums = s;
            Ok((t, st))
        };
        if !self.updates_incrementally() || sums.states.len() != self.nodes.len() || removed.len() + added.len() > u32::MAX as usize {
            return full(sums);
        }
        let cosine_min = (settings.estimator == Estimator::Cosine).then_some(settings.min_cos);
        let hi = self.origin + Vec3::splat(self.size);
        let mut moved = Moved { removed, added, node: Vec::new(), cosine_min };
        moved.node = (0..(removed.len() + added.len()) as u32)
            .into_par_iter()
            .map(|i| {
                let ph = moved.photon(i).0;
                let inside = ph.is_finite() && ph.p.cmpge(self.origin).all() && ph.p.cmple(hi).all();
                inside.then(|| self.leaf_node(ph.p)).flatten().map_or(NOWHERE, |(n, ..)| n)
            })
            .collect();
        // the leaves' own counts now
        let mut own: Vec<u32> = self.nodes.iter().map(|n| if n.is_leaf() { n.photons } else { 0 }).collect();
        for (i, &node) in (0u32..).zip(&moved.node) {
            if node == NOWHERE {
                continue;
            }
            let c = &mut own[node as usize];
            match (moved.photon(i).1 > 0.0, c.checked_sub(1)) {
                (true, _) => *c += 1,
                (false, Some(k)) => *c = k,
                // a photon removed that the tree never held: not this tree's sums
                (false, None) => return full(sums),
            }
        }
        let (at, reached) = self.route(&moved, &sums.states, sums.min_depth);
        // the moved photons leaf `node` gathers
        let range = |node: usize| &reached[at[node] as usize..at[node + 1] as usize];
        let tree = assign_counts(&self.nodes, &own);

        // estimated again: the leaves whose boxes meet where the surfaces changed, ...
        let meets = |b: &Bounds3, c: &Bounds3| b.min.cmple(c.max).all() && c.min.cmple(b.max).all();
        let spheres = surfaces.map_or(&[][..], |s| s.spheres);
        let (mut boxed, mut near_sphere) = (vec![false; self.nodes.len()], vec![false; self.nodes.len()]);
        for leaf in &tree.valid {
            let b = self.gather_bound(leaf.depth, leaf.ijk);
            boxed[leaf.node as usize] = boxes.iter().any(|c| meets(&b, c));
            near_sphere[leaf.node as usize] = spheres.iter().any(|s| {
                let r = Vec3::splat(s.radius.abs());
                meets(&b, &Bounds3 { min: s.center - r, max: s.center + r })
            });
        }
        // ... those whose lit sides the moved photons change (their groups' photons counted per
        // side; not where the leaf is estimated again anyway) ...
        let sides_changed: Vec<bool> = sums
            .states
            .par_iter_mut()
            .enumerate()
            .map(|(node, st)| {
                let Some(st) = st.as_mut().filter(|_| !range(node).is_empty() && !boxed[node]) else { return false };
                for &i in range(node) {
                    let (ph, sign) = moved.photon(i);
                    st.weights.count_sides(ph.p, ph.ng, sign as i32);
                }
                st.weights.sides_changed()
            })
            .collect();
        // ... those without sums, and those near an analytic sphere that a moved photon reaches
        let mut fresh = vec![false; self.nodes.len()];
        for leaf in &tree.valid {
            let node = leaf.node as usize;
            fresh[node] =
                sums.states[node].is_none() || sides_changed[node] || boxed[node] || (near_sphere[node] && !range(node).is_empty());
        }
        let mut estimates = self.estimate_fresh(photons, surfaces, &tree.valid, &fresh);
        if tree.valid.iter().any(|l| fresh[l.node as usize] && estimates[l.node as usize].is_none()) {
            return full(sums);
        }

        // the others: their sums updated in place
        let uses_ng = settings.estimator == Estimator::GeometryArea || settings.split == Split::Normal;
        let valid_now: Vec<bool> = own.iter().zip(&self.nodes).map(|(&c, n)| n.is_leaf() && c > 0).collect();
        sums.states.par_iter_mut().enumerate().for_each(|(node, st)| {
            if let (Some(st), false, true) = (st, fresh[node], valid_now[node]) {
                for &i in range(node) {
                    update(st, &moved, i, node as u32, uses_ng);
                }
            }
        });
        let mut stats = RefitStats::default();
        let mut kept = Vec::new();
        let mut outs = Vec::with_capacity(tree.valid.len());
        for leaf in &tree.valid {
            let node = leaf.node as usize;
            // (a leaf with sums that is not fresh was valid in this tree: it has a value)
            match (estimates[node].take(), &sums.states[node]) {
                (Some(mut e), _) => {
                    stats.estimated += 1;
                    kept.extend(e.state.take().map(|s| (node, s)));
                    outs.push(LeafOut::New(e));
                }
                (None, Some(st)) if !range(node).is_empty() => {
                    stats.updated += 1;
                    let cmin = self.view().cell_min(leaf.depth, leaf.ijk);
                    outs.push(LeafOut::New(Box::new(st.estimate(cmin, self.cell_size[leaf.depth as usize]))));
                }
                (None, Some(_)) if self.nodes[node].value() != NO_VALUE => {
                    stats.copied += 1;
                    outs.push(LeafOut::Old(self, self.nodes[node].value()));
                }
                // sums that do not describe this tree
                _ => return full(sums),
            }
        }
        // the sums follow the tree: the fresh leaves' states, none where no photon is left
        for (node, st) in sums.states.iter_mut().enumerate() {
            if !valid_now[node] {
                *st = None;
            }
        }
        for (node, s) in kept {
            sums.states[node] = Some(s);
        }
        sums.min_depth = tree.valid.iter().map(|l| l.depth).min().unwrap_or(0);
        let n_kept = own.iter().map(|&c| c as usize).sum();
        let mut out = assemble(tree, n_kept, outs, self.frame(photons.len()), settings);
        out.leak_samples = false;
        for a in &mut out.anchors {
            a.samples = [a.mean; super::ANCHOR_SAMPLES];
        }
        Ok((out, stats))
    }

    /// The moved photons each leaf's sums take (module docs), by leaf: leaf `node` takes the
    /// moved photons `reached[at[node]..at[node + 1]]`, returned as `(at, reached)`. Only
    /// leaves with sums take any.
    fn route(&self, moved: &Moved, states: &[Option<Box<LeafState>>], min_depth: u32) -> (Vec<u32>, Vec<u32>) {
        let view = self.view();
        let eps = self.settings.epsilon;
        let enlarged = eps > 0.0;
        let mut order: Vec<(u32, u32)> = moved.node.iter().zip(0u32..).filter(|(&n, _)| n != NOWHERE).map(|(&n, i)| (n, i)).collect();
        order.par_sort_unstable();
        let groups: Vec<&[(u32, u32)]> = order.chunk_by(|a, b| a.0 == b.0).collect();
        // no leaf's box reaches farther from its cell than the shallowest leaf's
        let margin = if enlarged { 0.5 * eps * self.cell_size[min_depth as usize] * 1.001 + 1e-6 * self.size } else { 0.0 };
        let pairs: Vec<(u32, u32)> = groups
            .par_iter()
            .flat_map_iter(|g| {
                let Some((o, d, ijk)) = self.leaf_node(moved.photon(g[0].1).0.p) else { return Vec::new() };
                let cmin = view.cell_min(d, ijk);
                // the cell's far corner as the gather's visit computes it, and as its whole-cell test does
                let cmax_visit = view.cell_min(d, [ijk[0] + 1, ijk[1] + 1, ijk[2] + 1]);
                let cmax = cmin + Vec3::splat(self.cell_size[d as usize]);
                let mut out = Vec::new();
                if states[o as usize].is_some() {
                    out.extend(g.iter().map(|&(_, i)| (o, i)));
                }
                if !enlarged {
                    return out;
                }
                view.visit(cmin - Vec3::splat(margin), cmax_visit + Vec3::splat(margin), |l, ld, lijk, _| {
                    if l == o || states[l as usize].is_none() {
                        return;
                    }
                    // `estimate.rs`: the leaf's box, whether its visit reaches `o`, whole or cut
                    let s = self.cell_size[ld as usize];
                    let c = view.cell_min(ld, lijk) + Vec3::splat(0.5 * s);
                    let half = Vec3::splat(0.5 * s * (1.0 + eps));
                    let (emin, emax) = (c - half, c + half);
                    if !(emin.cmplt(cmax_visit).all() && emax.cmpgt(cmin).all()) {
                        return;
                    }
                    if cmin.cmpge(emin).all() && cmax.cmple(emax).all() {
                        out.extend(g.iter().map(|&(_, i)| (l, i)));
                        return;
                    }
                    let cut = (cmin.cmplt(emin) | cmax.cmpgt(emax)).bitmask();
                    for &(_, i) in g.iter() {
                        let p = moved.photon(i).0.p;
                        if (0..3).all(|a| (cut >> a) & 1 == 0 || (p[a] >= emin[a] && p[a] < emax[a])) {
                            out.push((l, i));
                        }
                    }
                });
                out
            })
            .collect();
        // grouped by leaf (a counting sort: within a leaf, the order of the list above, which
        // depends on nothing but the photons)
        let mut at = vec![0u32; self.nodes.len() + 1];
        pairs.iter().for_each(|&(l, _)| at[l as usize + 1] += 1);
        for k in 1..at.len() {
            at[k] += at[k - 1];
        }
        let mut next = at.clone();
        let mut reached = vec![0u32; pairs.len()];
        for &(l, i) in &pairs {
            reached[next[l as usize] as usize] = i;
            next[l as usize] += 1;
        }
        (at, reached)
    }

    /// The estimates of the leaves `fresh` marks among `valid`, by node, from the photons inside
    /// their boxes (in their order: the build's sort and gather then see what a full refit sees).
    fn estimate_fresh(
        &self,
        photons: &[Photon],
        surfaces: Option<Surfaces<'_>>,
        valid: &[LeafBuild],
        fresh: &[bool],
    ) -> Vec<Option<Box<LeafEstimate>>> {
        let mut out: Vec<Option<Box<LeafEstimate>>> = (0..self.nodes.len()).map(|_| None).collect();
        let boxes: Vec<Bounds3> = valid.iter().filter(|l| fresh[l.node as usize]).map(|l| self.gather_bound(l.depth, l.ijk)).collect();
        if boxes.is_empty() {
            return out;
        }
        let mut all = Bounds3::EMPTY;
        boxes.iter().for_each(|b| {
            all.extend(b.min);
            all.extend(b.max)
        });
        // the leaves those boxes meet: their photons are the ones the estimates can gather
        let mut near = vec![false; self.nodes.len()];
        let view = self.view();
        for b in &boxes {
            view.visit(b.min, b.max, |node, _, _, _| near[node as usize] = true);
        }
        let inside = |p: Vec3| p.cmpge(all.min).all() && p.cmple(all.max).all();
        let subset: Vec<Photon> =
            photons.par_iter().filter(|ph| inside(ph.p) && self.leaf_node(ph.p).is_some_and(|(n, ..)| near[n as usize])).copied().collect();
        // the triangles near them (the build's lists per leaf are then the same, in the same order)
        let near_tris: Vec<[Vec3; 3]> = surfaces.map_or(Vec::new(), |s| {
            s.triangles
                .par_iter()
                .filter(|t| {
                    let (lo, hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
                    lo.cmple(all.max).all() && all.min.cmple(hi).all()
                })
                .copied()
                .collect()
        });
        let surfaces = surfaces.map(|s| Surfaces { triangles: &near_tris, spheres: s.spheres });
        let kf = KeyFn { origin: self.origin, inv_quant: self.inv_quant, h: self.h_max };
        let select = |l: &LeafBuild| fresh[l.node as usize];
        let which = Leaves::Fixed { topology: &self.nodes, select: &select, capture: true };
        let (tree, _, est) = sort_assign_estimate(&subset, kf, self.size, &self.cell_size, &self.settings, surfaces, which);
        for (l, e) in tree.valid.iter().zip(est) {
            if let Some(e) = e {
                out[l.node as usize] = Some(Box::new(e));
            }
        }
        out
    }
}

/// Moved photon `i`'s terms added to (or taken from) the sums of leaf `node`.
fn update(st: &mut LeafState, moved: &Moved, i: u32, node: u32, uses_ng: bool) {
    let (ph, sign) = moved.photon(i);
    let rec = moved.rec(i);
    st.weights.add_signed(&mut st.totals, &rec, sign);
    let step = |c: u32| (c as i64 + sign as i64).max(0) as u32;
    st.gathered = step(st.gathered);
    if moved.node[i as usize] == node {
        // the anchor's sums (`estimate.rs`: the incident direction when there is no normal)
        st.own = step(st.own);
        st.pos += ph.p.as_dvec3() * sign;
        let ng = if uses_ng { rec.ng() } else { Vec3::ZERO };
        let n = if ng == Vec3::ZERO { rec.w().normalize_or_zero() } else { ng };
        st.nrm += n.as_dvec3() * sign;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::caches::octree::test_photons::box_photons as photons;
    use crate::caches::octree::{LeafValueParts, OctreeSettings, Storage};

    fn full_values(t: &Octree) -> Vec<[glam::Mat3; 6]> {
        match t.to_parts().values {
            LeafValueParts::Full(v) => v,
            LeafValueParts::Compressed(_) => panic!("full storage"),
        }
    }

    /// With the cosine estimator (the photon's weight folded into its direction, the octant
    /// sums): 600 photons replaced update the sums to what a refit of the new photons gives
    /// (within 1e-5 of each leaf's largest entry), without estimating a leaf from its photons.
    /// Sums of another tree (another node count) give the full refit.
    #[test]
    fn updated_sums_give_the_refit_and_sums_of_another_tree_a_full_one() {
        let settings = OctreeSettings { storage: Storage::Full, estimator: Estimator::Cosine, n_max: 40, n_min: 10, ..Default::default() };
        let unit = Bounds3 { min: Vec3::ZERO, max: Vec3::ONE };
        let old = photons(6000, 7);
        let tree = Octree::build(&old, unit, &settings, None).unwrap();
        let (t1, _, mut sums) = tree.refit_with_sums(&old, None).unwrap();
        let added = photons(600, 8);
        let now: Vec<Photon> = old[600..].iter().chain(&added).copied().collect();
        let (t2, st) = t1.refit_incremental(&mut sums, &now, &old[..600], &added, None, &[]).unwrap();
        let (want, _) = t1.refit(&now, None, None).unwrap();
        assert!(st.updated > 100 && st.estimated == 0, "{st:?}");
        assert_eq!(t2.to_parts().nodes, want.to_parts().nodes);
        let (a, b) = (full_values(&t2), full_values(&want));
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(&b) {
            let scale = y.iter().map(|m| m.abs().to_cols_array().into_iter().fold(0.0f32, f32::max)).fold(0.0f32, f32::max);
            for (mx, my) in x.iter().zip(y) {
                let d = (*mx - *my).abs().to_cols_array().into_iter().fold(0.0f32, f32::max);
                assert!(d <= 1e-5 * scale, "{d} of {scale}");
            }
        }
        // sums of a tree of another topology
        let other = Octree::build(&old, unit, &OctreeSettings { n_max: 80, ..settings.clone() }, None).unwrap();
        let (_, _, mut wrong) = other.refit_with_sums(&old, None).unwrap();
        let (t3, st) = t1.refit_incremental(&mut wrong, &now, &old[..600], &added, None, &[]).unwrap();
        assert!(st.updated == 0 && st.copied == 0 && st.estimated == t3.stats().valid_leaves, "{st:?}");
        assert!(full_values(&t3) == b, "the full refit's values");
    }
}
