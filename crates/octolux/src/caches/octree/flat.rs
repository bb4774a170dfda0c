//! The query's leaves as flat lists (the §7 blend, without the tree walk; issue 14 item 4,
//! `docs/lab/2026-11-30-performance.md` "The octree's query").
//!
//! A query at `P` blends the valid leaves that the box `V = P ± h` meets ([`Octree::irradiance`]).
//! `V` is centred in the leaf `L` holding `P`, so every leaf it meets meets `L`'s cell grown by
//! `h`. Per leaf, this module keeps the valid leaves that grown cell meets (in the tree's
//! depth-first order, which is the order of the valid leaves' indices), and per valid leaf the
//! cell bounds the traversal tests, the anchors the leak test reads ([`QueryLeaf`]) and, for
//! compressed storage, the factors `D` and `C` of its six matrices (`compress.rs`), each decoded
//! once instead of at every leaf met. A query then locates `L` (a grid of the nodes at depth
//! 5, then a descent on the quantised position: no recursion), and loops over `L`'s list, with the traversal's own test and overlap volume for each entry:
//! the same leaves, in the same order, with the same weights, bit for bit (the test
//! `flat_visit_equals_the_tree_walk`). Points outside the root cube take the tree walk.
//!
//! Built from the node array once per tree, at the first query or by
//! [`Octree::prepare_query`] (render time, not stored in cache files). The per-leaf part
//! (bounds, anchors, decoded factors, the grid) is built first and alone where only single
//! leaves are read ([`Octree::prepare_leaf_query`]); the lists, most of the build's time, at
//! the first blend.
//!
//! Why the traversal's test is the cell's own bounds: the walk enters a child when the box
//! starts below the parent's centre (lower half) or ends above it (upper half), per axis, so it
//! reaches a leaf exactly when `qmin < upper` and `qmax > min` on every axis, where `min` and
//! `upper` are the cell's corners computed as `origin + ijk · size / 2^d` (a corner shared by
//! cells of different depths is the same `f32` at every depth: the scalings are powers of two).

use super::cells::quantize;
use super::compress::{decompress_factors, MATRIX_BYTES};
use super::{LeafValues, Octree, QueryLeaf, NO_VALUE};
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
    /// The lists of the blend, built at its first query ([`FlatLists`]): a read of one leaf
    /// alone (`mode = unbiased`) does not need them, and they are most of the build's time.
    lists: std::sync::OnceLock<FlatLists>,
    /// Per valid leaf.
    cells: Vec<FlatCell>,
    /// Per valid leaf: its anchors in world space, as [`Octree`]'s `query_leaf` decodes them.
    pub leaves: Vec<QueryLeaf>,
    /// Per valid leaf of a compressed tree, per matrix: `[D, C]` with `M ≈ D Cᵀ`, decoded as
    /// the query did per leaf met (`compress.rs`; empty for full storage).
    pub decoded: Vec<[[Vec3; 2]; 6]>,
    /// Per cell of the grid at depth `grid_depth` (x fastest): the node on the path to its
    /// leaves at that depth, or the leaf holding it when that leaf is larger.
    grid: Vec<u32>,
    grid_depth: u32,
}

/// Per leaf, the valid leaves its query boxes can meet.
#[derive(Clone, Debug, Default)]
struct FlatLists {
    /// Per node: the start of its list in `lists` (`start[node + 1]` ends it; empty for
    /// internal nodes).
    start: Vec<u32>,
    /// Valid leaf indices, ascending within each list.
    lists: Vec<u32>,
}

/// Depth of [`FlatQuery`]'s grid of nodes, at most (4 bytes per cell: 128 KiB).
const GRID_DEPTH: u32 = 5;

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
        let decoded = match &tree.values {
            LeafValues::Compressed(c) => c
                .iter()
                .map(|leaf| {
                    std::array::from_fn(|k| {
                        let (d, c) = decompress_factors(&leaf[k * MATRIX_BYTES..(k + 1) * MATRIX_BYTES]);
                        [d, c]
                    })
                })
                .collect(),
            LeafValues::Full(_) => Vec::new(),
        };
        let grid_depth = tree.h_max.min(GRID_DEPTH);
        let side = 1u32 << grid_depth;
        let mut grid = vec![0u32; (side * side * side) as usize];
        fill_grid(tree, 0, 0, [0; 3], grid_depth, &mut grid);
        FlatQuery { lists: std::sync::OnceLock::new(), cells, leaves, decoded, grid, grid_depth }
    }

    /// The blend's lists, built at the first call.
    fn lists(&self, tree: &Octree) -> &FlatLists {
        self.lists.get_or_init(|| FlatLists::new(tree))
    }
}

impl FlatLists {
    fn new(tree: &Octree) -> FlatLists {
        let view = tree.view();
        let mut all = Vec::with_capacity(tree.stats.leaves);
        view.visit(Vec3::NEG_INFINITY, Vec3::INFINITY, |node, depth, ijk, _| all.push((node, depth, ijk)));
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
        FlatLists { start: count, lists: flat }
    }
}

impl FlatQuery {
    /// Bytes held at render time (not in the cache file).
    pub(super) fn bytes(&self) -> usize {
        self.lists.get().map_or(0, |l| std::mem::size_of_val(l.start.as_slice()) + std::mem::size_of_val(l.lists.as_slice()))
            + std::mem::size_of_val(self.cells.as_slice())
            + std::mem::size_of_val(self.leaves.as_slice())
            + std::mem::size_of_val(self.decoded.as_slice())
            + std::mem::size_of_val(self.grid.as_slice())
    }

    /// Call `f(value, γ)` for every valid leaf the box `[qmin, qmax]` (centred on `p`, half
    /// side at most the tree's `query_half`) meets, in depth-first order; `false` (nothing
    /// called) when `p` lies outside the root cube (the caller then walks the tree).
    #[inline]
    pub(super) fn visit<F: FnMut(usize, f32)>(&self, tree: &Octree, p: Vec3, qmin: Vec3, qmax: Vec3, mut f: F) -> bool {
        let Some(node) = self.locate(tree, p) else { return false };
        let l = self.lists(tree);
        let (a, b) = (l.start[node as usize] as usize, l.start[node as usize + 1] as usize);
        for &v in &l.lists[a..b] {
            let c = &self.cells[v as usize];
            if qmin.cmplt(c.upper).all() && qmax.cmpgt(c.min).all() {
                let o = c.max.min(qmax) - c.min.max(qmin);
                f(v as usize, o.x * o.y * o.z);
            }
        }
        true
    }
}

impl FlatQuery {
    /// The leaf node whose (half-open) cell holds `p`, `None` outside the root cube: the grid's
    /// node for `p`'s quantised coordinates, then a descent on them.
    #[inline]
    pub(super) fn locate(&self, tree: &Octree, p: Vec3) -> Option<u32> {
        let o = tree.origin;
        let e = o + Vec3::splat(tree.size);
        if !(p.cmpge(o).all() && p.cmplt(e).all()) {
            return None;
        }
        let q = quantize(p, tree.origin, tree.inv_quant, tree.h_max);
        let mut s = tree.h_max - self.grid_depth;
        let side = 1usize << self.grid_depth;
        let g = |a: usize| (q[a] >> s) as usize;
        let mut node = self.grid[g(0) + side * (g(1) + side * g(2))];
        loop {
            let n = tree.nodes[node as usize];
            if n.is_leaf() || s == 0 {
                return Some(node);
            }
            s -= 1;
            let c = ((q[0] >> s) & 1) | (((q[1] >> s) & 1) << 1) | (((q[2] >> s) & 1) << 2);
            node = n.link + c;
        }
    }
}

/// Fill the grid cells under `node` (cell at `depth`, `ijk`): the node at `grid_depth`, or the
/// leaf above it.
fn fill_grid(tree: &Octree, node: u32, depth: u32, ijk: [u32; 3], grid_depth: u32, grid: &mut [u32]) {
    let n = tree.nodes[node as usize];
    let side = 1u32 << grid_depth;
    if n.is_leaf() || depth == grid_depth {
        let k = grid_depth - depth;
        let lo = ijk.map(|i| i << k);
        for z in lo[2]..lo[2] + (1 << k) {
            for y in lo[1]..lo[1] + (1 << k) {
                for x in lo[0]..lo[0] + (1 << k) {
                    grid[(x + side * (y + side * z)) as usize] = node;
                }
            }
        }
        return;
    }
    for c in 0..8u32 {
        let cijk = [2 * ijk[0] + (c & 1), 2 * ijk[1] + ((c >> 1) & 1), 2 * ijk[2] + ((c >> 2) & 1)];
        fill_grid(tree, n.link + c, depth + 1, cijk, grid_depth, grid);
    }
}

impl Octree {
    /// The flat query lists ([`FlatQuery`]), built at the first call.
    #[inline]
    pub(super) fn flat(&self) -> &FlatQuery {
        self.flat.get_or_init(|| FlatQuery::new(self))
    }

    /// Build the query's flat lists now rather than at the first query (render-time data,
    /// module `flat.rs`). Returns the bytes they hold.
    pub fn prepare_query(&self) -> usize {
        self.flat().lists(self);
        self.flat().bytes()
    }

    /// Build now what a read of one leaf alone needs ([`Octree::leaf_incident_matrix`]: the
    /// per-leaf part of the flat query, not the blend's lists). Returns the bytes held.
    pub fn prepare_leaf_query(&self) -> usize {
        self.flat().bytes()
    }

    /// Entries of the flat query lists and the bytes of the flat query (diagnostics); `None`
    /// while the lists are not built (no blend was read).
    pub fn query_lists(&self) -> Option<(usize, usize)> {
        let f = self.flat.get()?;
        Some((f.lists.get()?.lists.len(), f.bytes()))
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
            let settings = OctreeSettings { h_max: Depth::Fixed(h_max), n_max, n_min: 5, alpha, ..OctreeSettings::default() };
            let tree = Octree::build(&photons, bounds, &settings, None).unwrap();
            assert_eq!(tree.query_lists(), None, "the lists are built at the first blend");
            tree.prepare_query();
            let (entries, bytes) = tree.query_lists().unwrap();
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
