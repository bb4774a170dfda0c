//! The octree coarse to fine, for progressive transmission: the paper's future work (§10,
//! "progressive transmission of the lighting through the octree's levels"); issue 28
//! (`octolux view` streams these levels to a browser, which evaluates them on the GPU).
//!
//! Level `d` holds the nodes at depth `d`, in breadth-first order: the root; then the 8
//! children of each internal node of the level before, in order. Levels `0..=d` are a complete
//! octree on their own: its nodes at depth `d` are its leaves, and an internal node of the full
//! tree stands there for its subtree with the volume-weighted mean of its valid leaves' matrices,
//! per matrix over the leaves that have it (the facing bits): `Σ_k γ_k M_k / Σ_k γ_k` with
//! `γ_k` the leaf's cell volume, which is the §7 blend of the full tree over a query box equal
//! to the node's cell. Its facing bits are those some leaf under it has. A valid leaf carries
//! its own 36 bytes, so the last prefix is the full tree, value for value.
//!
//! Values are always the paper's 36-byte leaves (`compress.rs`); a tree of full matrices is
//! compressed for the stream. Sums are f64.

use super::compress::{compress_leaf, decompress_matrix, CompressedLeaf, FullLeaf, MATRIX_BYTES};
use super::{LeafValues, Octree, ALL_FACING, NO_VALUE};
use glam::{DMat3, Mat3};

/// What a node of a level is in the full tree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum LevelKind {
    /// An internal node: a leaf of this prefix, its children come in the next level.
    Internal = 0,
    /// A valid leaf (photons in its cell).
    Valid = 1,
    /// An atmospheric leaf (no value).
    Atmospheric = 2,
}

/// One node of a [`Level`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LevelNode {
    pub kind: LevelKind,
    /// The matrices that carry a value (bits `+X, −X, +Y, −Y, +Z, −Z`); 0 for atmospheric.
    pub facing: u8,
    /// The six matrices (zero for atmospheric).
    pub value: CompressedLeaf,
}

/// The nodes at one depth (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Level {
    pub depth: u32,
    pub nodes: Vec<LevelNode>,
}

/// Per node: `Σ γ M_k` and `Σ γ` per matrix over its valid leaves.
#[derive(Clone, Copy)]
struct Sums {
    m: [DMat3; 6],
    w: [f64; 6],
}

/// No leaf yet (glam's `Default` for a matrix is the identity, not zero).
const NO_SUMS: Sums = Sums { m: [DMat3::ZERO; 6], w: [0.0; 6] };

impl Octree {
    /// The tree as levels, coarse to fine (module docs).
    pub fn levels(&self) -> Vec<Level> {
        let n = self.nodes.len();
        let mut sums = vec![NO_SUMS; n];
        // children lie after their parent (allocated depth-first): from the last node back
        let depths = self.node_depths();
        for id in (0..n).rev() {
            let node = self.nodes[id];
            if node.is_leaf() {
                let v = node.value();
                if v == NO_VALUE {
                    continue;
                }
                let gamma = (self.cell_size[depths[id] as usize] as f64).powi(3);
                let bits = self.facing.get(v as usize).copied().unwrap_or(ALL_FACING);
                for (k, m) in self.leaf_full(v as usize).iter().enumerate() {
                    if bits & (1 << k) != 0 {
                        sums[id].m[k] = m.as_dmat3() * gamma;
                        sums[id].w[k] = gamma;
                    }
                }
            } else {
                let mut s = NO_SUMS;
                for c in 0..8 {
                    let child = sums[node.link as usize + c];
                    for k in 0..6 {
                        s.m[k] += child.m[k];
                        s.w[k] += child.w[k];
                    }
                }
                sums[id] = s;
            }
        }
        let mut levels = Vec::new();
        let mut frontier = vec![0u32];
        let mut depth = 0u32;
        while !frontier.is_empty() {
            let mut next = Vec::new();
            let nodes = frontier
                .iter()
                .map(|&id| {
                    let node = self.nodes[id as usize];
                    if !node.is_leaf() {
                        next.extend(node.link..node.link + 8);
                        let s = &sums[id as usize];
                        let mean: FullLeaf =
                            std::array::from_fn(|k| if s.w[k] > 0.0 { (s.m[k] * (1.0 / s.w[k])).as_mat3() } else { Mat3::ZERO });
                        let facing = (0..6).filter(|&k| s.w[k] > 0.0).fold(0u8, |b, k| b | (1 << k));
                        return LevelNode { kind: LevelKind::Internal, facing, value: compress_leaf(&mean) };
                    }
                    let v = node.value();
                    if v == NO_VALUE {
                        return LevelNode { kind: LevelKind::Atmospheric, facing: 0, value: [0; 36] };
                    }
                    let facing = self.facing.get(v as usize).copied().unwrap_or(ALL_FACING);
                    let value = match &self.values {
                        LeafValues::Compressed(c) => c[v as usize],
                        LeafValues::Full(f) => compress_leaf(&f[v as usize]),
                    };
                    LevelNode { kind: LevelKind::Valid, facing, value }
                })
                .collect();
            levels.push(Level { depth, nodes });
            frontier = next;
            depth += 1;
        }
        levels
    }

    /// The six matrices of valid leaf `v`, decompressed.
    fn leaf_full(&self, v: usize) -> FullLeaf {
        match &self.values {
            LeafValues::Compressed(c) => std::array::from_fn(|k| decompress_matrix(&c[v][k * MATRIX_BYTES..(k + 1) * MATRIX_BYTES])),
            LeafValues::Full(f) => f[v],
        }
    }

    /// The depth of every node.
    fn node_depths(&self) -> Vec<u32> {
        let mut depth = vec![0u32; self.nodes.len()];
        for id in 0..self.nodes.len() {
            let node = self.nodes[id];
            if !node.is_leaf() {
                for c in 0..8 {
                    depth[node.link as usize + c] = depth[id] + 1;
                }
            }
        }
        depth
    }

    /// The edge of a cell at `depth` (scene units).
    pub fn cell_edge(&self, depth: u32) -> f32 {
        self.cell_size[depth.min(super::MAX_DEPTH) as usize]
    }

    /// Minimum corner of the root cube (scene units).
    pub fn origin(&self) -> glam::Vec3 {
        self.origin
    }

    /// The `alpha` of the query box (its side over the smallest leaf's edge).
    pub fn alpha(&self) -> f32 {
        self.settings.alpha
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::caches::octree::{Estimator, OctreeSettings};
    use crate::math::Bounds3;
    use crate::photon::Photon;
    use crate::sampling::{square_to_uniform_sphere, Sampler};
    use glam::Vec3;

    fn tree() -> Octree {
        let mut s = Sampler::new(3, 0, 0);
        let photons: Vec<Photon> = (0..8000)
            .map(|i| {
                let (u, v) = (s.next_1d(), s.next_1d());
                let (p, ng) = if i % 2 == 0 { (Vec3::new(u, 0.0, v), Vec3::Y) } else { (Vec3::new(0.0, u, v), Vec3::X) };
                let mut wi = square_to_uniform_sphere(s.next_2d());
                if wi.dot(ng) < 0.0 {
                    wi = -wi;
                }
                Photon { p, wi, power: Vec3::new(1.0, 0.5, 0.25) * 1e-3, ng }
            })
            .collect();
        let settings = OctreeSettings { estimator: Estimator::Cosine, n_max: 40, n_min: 10, ..Default::default() };
        Octree::build(&photons, Bounds3 { min: Vec3::ZERO, max: Vec3::ONE }, &settings, None).unwrap()
    }

    #[test]
    fn the_levels_are_the_tree_breadth_first_and_its_leaves_value_for_value() {
        let t = tree();
        let levels = t.levels();
        assert_eq!(levels.iter().map(|l| l.nodes.len()).sum::<usize>(), t.nodes.len());
        assert_eq!(levels.len() as u32, t.stats().max_depth + 1);
        let LeafValues::Compressed(values) = &t.values else { panic!("compressed") };
        let mut valid: Vec<CompressedLeaf> =
            levels.iter().flat_map(|l| &l.nodes).filter(|n| n.kind == LevelKind::Valid).map(|n| n.value).collect();
        let mut own = values.clone();
        valid.sort();
        own.sort();
        assert_eq!(valid, own, "every valid leaf's own 36 bytes");
        // each level has 8 nodes per internal node of the level before
        for w in levels.windows(2) {
            assert_eq!(w[1].nodes.len(), 8 * w[0].nodes.iter().filter(|n| n.kind == LevelKind::Internal).count());
        }
    }

    #[test]
    fn a_coarse_node_holds_the_blend_of_its_leaves_over_its_cell() {
        // the root's +Y matrix against the volume-weighted mean of the valid leaves' +Y
        let t = tree();
        let root = t.levels()[0].nodes[0];
        assert_eq!(root.kind, LevelKind::Internal);
        let (mut sum, mut w) = (DMat3::ZERO, 0.0f64);
        let b = t.bounds();
        t.view().visit(b.min, b.max, |node, depth, _, _| {
            let v = t.nodes[node as usize].value();
            if v != NO_VALUE && t.facing.get(v as usize).copied().unwrap_or(ALL_FACING) & (1 << 2) != 0 {
                let g = (t.cell_size[depth as usize] as f64).powi(3);
                sum += t.leaf_full(v as usize)[2].as_dmat3() * g;
                w += g;
            }
        });
        let want = (sum * (1.0 / w)).as_mat3();
        let got = decompress_matrix(&root.value[2 * MATRIX_BYTES..3 * MATRIX_BYTES]);
        let e = (got.transpose() * Vec3::Y, want.transpose() * Vec3::Y);
        assert!(want.transpose().mul_vec3(Vec3::Y).x > 0.0);
        assert!((e.0 - e.1).abs().max_element() <= 0.01 * e.1.max_element(), "{e:?}");
        assert_ne!(root.facing & (1 << 2), 0);
    }
}
