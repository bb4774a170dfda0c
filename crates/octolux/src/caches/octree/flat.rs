//! The query's leaves as flat lists (the §7 blend, without the tree walk; issue 14 item 4,
//! `docs/performance.md` "The octree's query").
//!
//! A query at `P` blends the valid leaves that the box `V = P ± h` meets ([`Octree::irradiance`]).
//! `V` is centred in the leaf `L` holding `P`, so every leaf it meets meets `L`'s cell grown by
//! `h`. Per leaf, this module keeps the valid leaves that grown cell meets (in the tree's
//! depth-first order, which is the order of the valid leaves' indices), and per valid leaf the
//! cell bounds the traversal tests and the anchors the leak test reads ([`QueryLeaf`], decoded
//! once). A query then locates `L` (a descent on the quantised position, no recursion), and
//! loops over `L`'s list, with the traversal's own test and overlap volume for each entry:
//! the same leaves, in the same order, with the same weights, bit for bit (the test
//! `flat_visit_equals_the_tree_walk`). Points outside the root cube take the tree walk.
//!
//! Built from the node array once per tree, at the first query or by
//! [`Octree::prepare_query`] (render time, not stored in cache files).
//!
//! Why the traversal's test is the cell's own bounds: the walk enters a child when the box
//! starts below the parent's centre (lower half) or ends above it (upper half), per axis, so it
//! reaches a leaf exactly when `qmin < upper` and `qmax > min` on every axis, where `min` and
//! `upper` are the cell's corners computed as `origin + ijk · size / 2^d` (a corner shared by
//! cells of different depths is the same `f32` at every depth: the scalings are powers of two).

use super::cells::quantize;
use super::{Octree, QueryLeaf, NO_VALUE};
use glam::Vec3;
use rayon::prelude::*;

/// The bounds of a valid leaf's cell as the query tests them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct FlatCell {
    /// `cell_min(depth, ijk)`.
    pub min: Vec3,
    /// `cell_min(depth, ijk + 1)`: what the traversal compares `qmin` with.
    pub upper: Vec3,
    /// `min + cell size`: what the overlap volume is computed with (as the traversal does).
    pub max: Vec3,
}

/// Per leaf, the valid leaves its query boxes can meet; per valid leaf, its bounds and anchors.
#[derive(Clone, Debug, Default)]
pub(super) struct FlatQuery {
    /// Per node: the start of its list in `lists` (`start[node + 1]` ends it; empty for
    /// internal nodes).
    start: Vec<u32>,
    /// Valid leaf indices, ascending within each list.
    lists: Vec<u32>,
    /// Per valid leaf.
    cells: Vec<FlatCell>,
    /// Per valid leaf: its anchors in world space, as [`Octree`]'s `query_leaf` decodes them.
    pub leaves: Vec<QueryLeaf>,
}

impl FlatQuery {
    pub(super) fn new(tree: &Octree) -> FlatQuery {
        let view = tree.view();
        let mut all = Vec::with_capacity(tree.stats.leaves);
        view.visit(Vec3::NEG_INFINITY, Vec3::INFINITY, |node, depth, ijk, _| all.push((node, depth, ijk)));
        let n_valid = tree.anchors.len();
        let mut cells = vec![FlatCell { min: Vec3::ZERO, upper: Vec3::ZERO, max: Vec3::ZERO }; n_valid];
        let mut leaves = Vec::with_capacity(n_valid);
        for &(node, depth, ijk) in &all {
            let v = tree.nodes[node as usize].value();
            if v == NO_VALUE {
                continue;
            }
            let min = view.cell_min(depth, ijk);
            let upper = view.cell_min(depth, [ijk[0] + 1, ijk[1] + 1, ijk[2] + 1]);
            cells[v as usize] = FlatCell { min, upper, max: min + Vec3::splat(tree.cell_size[depth as usize]) };
            debug_assert_eq!(leaves.len(), v as usize, "valid leaves are numbered in depth-first order");
            leaves.push(tree.query_leaf(v as usize, depth, ijk));
        }
        // a query point is located by quantisation, which may put a point within an ulp of a
        // face into the neighbouring cell: the margin covers it
        let reach = tree.query_half * (1.0 + 1e-3) + 1e-3 * tree.cell_size[tree.h_max as usize];
        let lists: Vec<Vec<u32>> = all
            .par_iter()
            .map(|&(_, depth, ijk)| {
                let min = view.cell_min(depth, ijk);
                let g = Vec3::splat(reach);
                let mut l = Vec::new();
                view.visit(min - g, min + Vec3::splat(tree.cell_size[depth as usize]) + g, |node, _, _, _| {
                    let v = tree.nodes[node as usize].value();
                    if v != NO_VALUE {
                        l.push(v);
                    }
                });
                l
            })
            .collect();
        let mut count = vec![0u32; tree.nodes.len() + 1];
        for (&(node, _, _), l) in all.iter().zip(&lists) {
            count[node as usize + 1] = l.len() as u32;
        }
        for i in 1..count.len() {
            count[i] += count[i - 1];
        }
        let mut flat = vec![0u32; count[tree.nodes.len()] as usize];
        for (&(node, _, _), l) in all.iter().zip(&lists) {
            let a = count[node as usize] as usize;
            flat[a..a + l.len()].copy_from_slice(l);
        }
        FlatQuery { start: count, lists: flat, cells, leaves }
    }

    /// Bytes held at render time (not in the cache file).
    pub(super) fn bytes(&self) -> usize {
        std::mem::size_of_val(self.start.as_slice())
            + std::mem::size_of_val(self.lists.as_slice())
            + std::mem::size_of_val(self.cells.as_slice())
            + std::mem::size_of_val(self.leaves.as_slice())
    }

    /// Entries of all lists.
    pub(super) fn entries(&self) -> usize {
        self.lists.len()
    }

    /// Call `f(value, γ)` for every valid leaf the box `[qmin, qmax]` (centred on `p`, half
    /// side at most the tree's `query_half`) meets, in depth-first order; `false` (nothing
    /// called) when `p` lies outside the root cube (the caller then walks the tree).
    #[inline]
    pub(super) fn visit<F: FnMut(usize, f32)>(&self, tree: &Octree, p: Vec3, qmin: Vec3, qmax: Vec3, mut f: F) -> bool {
        let Some(node) = tree.locate(p) else { return false };
        let (a, b) = (self.start[node as usize] as usize, self.start[node as usize + 1] as usize);
        for &v in &self.lists[a..b] {
            let c = &self.cells[v as usize];
            if qmin.cmplt(c.upper).all() && qmax.cmpgt(c.min).all() {
                let o = c.max.min(qmax) - c.min.max(qmin);
                f(v as usize, o.x * o.y * o.z);
            }
        }
        true
    }
}

impl Octree {
    /// The leaf node whose (half-open) cell holds `p`, `None` outside the root cube: a descent
    /// on `p`'s quantised coordinates.
    #[inline]
    pub(super) fn locate(&self, p: Vec3) -> Option<u32> {
        let o = self.origin;
        let e = o + Vec3::splat(self.size);
        if !(p.cmpge(o).all() && p.cmplt(e).all()) {
            return None;
        }
        let q = quantize(p, self.origin, self.inv_quant, self.h_max);
        let mut node = 0u32;
        let mut s = self.h_max;
        loop {
            let n = self.nodes[node as usize];
            if n.is_leaf() || s == 0 {
                return Some(node);
            }
            s -= 1;
            let c = ((q[0] >> s) & 1) | (((q[1] >> s) & 1) << 1) | (((q[2] >> s) & 1) << 2);
            node = n.link + c;
        }
    }

    /// The flat query lists ([`FlatQuery`]), built at the first call.
    #[inline]
    pub(super) fn flat(&self) -> &FlatQuery {
        self.flat.get_or_init(|| FlatQuery::new(self))
    }

    /// Build the query's flat lists now rather than at the first query (render-time data,
    /// module `flat.rs`). Returns the bytes they hold.
    pub fn prepare_query(&self) -> usize {
        self.flat().bytes()
    }

    /// Entries of the flat query lists and their bytes (diagnostics; builds them if needed).
    pub fn query_lists(&self) -> (usize, usize) {
        let f = self.flat();
        (f.entries(), f.bytes())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::caches::octree::{Depth, OctreeSettings};
    use crate::math::{Bounds3, Color};
    use crate::photon::Photon;
    use crate::sampling::Sampler;

    /// The tree walk of the query (the reference): `(value, γ bits)` in visiting order.
    fn walk(tree: &Octree, p: Vec3) -> Vec<(usize, u32)> {
        let h = Vec3::splat(tree.query_half);
        let mut out = Vec::new();
        tree.view().visit(p - h, p + h, |node, _, _, g| {
            let v = tree.nodes[node as usize].value();
            if v != NO_VALUE {
                out.push((v as usize, g.to_bits()));
            }
        });
        out
    }

    fn flat(tree: &Octree, p: Vec3) -> Option<Vec<(usize, u32)>> {
        let h = Vec3::splat(tree.query_half);
        let mut out = Vec::new();
        tree.flat().visit(tree, p, p - h, p + h, |v, g| out.push((v, g.to_bits()))).then_some(out)
    }

    /// Photons on a few planes and in a clump (leaves of many depths next to each other),
    /// queried at random points, at points on cell faces of every depth (where the
    /// quantisation and the traversal's comparisons are closest) and outside the cube: the flat
    /// lists give the leaves of the tree walk, in its order, with its weights, bit for bit.
    #[test]
    fn flat_visit_equals_the_tree_walk() {
        let mut s = Sampler::new(7, 0, 0);
        let mut photons = Vec::new();
        for i in 0..60_000 {
            let u = s.next_2d();
            let p = match i % 4 {
                0 => Vec3::new(u.x, 0.1, u.y),
                1 => Vec3::new(0.3 + 0.05 * u.x, u.y, 0.7),
                2 => Vec3::new(0.6, 0.2 + 0.1 * u.x, 0.2 + 0.1 * u.y),
                _ => Vec3::new(0.62 + 0.02 * u.x, 0.3 + 0.02 * u.y, 0.25 + 0.02 * s.next_1d()),
            };
            photons.push(Photon { p, wi: Vec3::Y, power: Color::ONE, ng: Vec3::Y });
        }
        let bounds = Bounds3 { min: Vec3::new(0.0, 0.0, 0.0), max: Vec3::new(1.0, 0.9, 1.0) };
        for (h_max, n_max, alpha) in [(3, 200, 1.5), (6, 40, 1.5), (8, 20, 1.5), (7, 30, 4.0), (0, 10, 1.5)] {
            let settings = OctreeSettings { h_max: Depth::Fixed(h_max), n_max, alpha, ..OctreeSettings::default() };
            let tree = Octree::build(&photons, bounds, &settings, None).unwrap();
            let (entries, bytes) = tree.query_lists();
            assert!(entries >= tree.stats().valid_leaves && bytes > 0);
            let b = tree.bounds();
            let ext = b.max - b.min;
            let mut met = 0usize;
            let mut check = |p: Vec3| {
                let w = walk(&tree, p);
                match flat(&tree, p) {
                    Some(f) => assert_eq!(f, w, "h_max {h_max}, p {p:?}"),
                    None => assert!(!(p.cmpge(b.min).all() && p.cmplt(b.max).all()), "{p:?} inside, not located"),
                }
                met += w.len();
            };
            for _ in 0..20_000 {
                let u = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d());
                check(b.min + u * ext);
                // on a face of a cell at a random depth, on one or more axes
                let d = (s.next_1d() * (tree.h_max() + 1) as f32) as u32;
                let c = tree.cell_size[d as usize];
                let mut p = b.min + u * ext;
                for a in 0..3 {
                    if s.next_1d() < 0.6 {
                        p[a] = b.min[a] + ((p[a] - b.min[a]) / c).round() * c;
                    }
                }
                check(p);
                // just outside the cube
                check(b.min - Vec3::splat(0.1 * tree.query_size()) + u * ext * Vec3::new(1.0, 0.0, 1.0));
            }
            check(b.min);
            check(b.max);
            assert!(met > 1000, "the queries met leaves ({met})");
        }
    }
}
