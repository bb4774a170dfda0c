//! The octree coarse to fine, for progressive transmission: the paper's future work (§10,
//! "progressive transmission of the lighting through the octree's levels"); issue 28
//! (`octolux view` streams it to a browser, which evaluates it on the GPU).
//!
//! # Every prefix an octree
//! The stream is the root, then *splits*: a split names a node already sent that is internal
//! in the full tree, and carries its 8 children. The root and any run of splits make a complete
//! octree on their own, whose leaves are the nodes not (yet) split. An internal node of the
//! full tree stands there for its subtree with the volume-weighted mean of its valid leaves'
//! matrices, per matrix over the leaves that have it (the facing bits):
//! `Σ_k γ_k M_k / Σ_k γ_k`, `γ_k` the leaf's cell volume, which is the §7 blend of the full
//! tree over a query box equal to the node's cell; its facing bits are those some leaf under it
//! has. A valid leaf carries its own 36 bytes, so the whole stream is the full tree, value for
//! value. Values are always the paper's 36-byte leaves (`compress.rs`); a tree of full matrices
//! is compressed for the stream. Sums are f64.
//!
//! # Order
//! Splits come in the order that lowers the error fastest per byte, not depth by depth: a
//! node's split removes `δ = Σ_c w_c Σ_k |M_{c,k} − M_k|²_F / (|M_k|²_F + ε)` (its children's
//! departure from its mean, relative per matrix, as the relMSE of an image is per pixel; `ε` a
//! millionth of the valid leaves' mean) and costs its children's bytes. A child's weight
//! `w_c = γ_c / γ_root + s_c / S` is its share of the root's volume plus, with
//! [`Octree::stream_seen`], its share of the `S` surface points a first view sees (the viewer's
//! camera): what is on screen is refined first, the rest by volume. A node is split only after its
//! parent. Among such orders the one that minimises the area under the error-against-bytes
//! curve, `Σ δ_j` times the bytes sent before split `j` is done, is Horn's (1972) for jobs
//! under out-tree precedence ([`horn_order`]): a split whose subtree holds a rich run of splits
//! comes early even when its own `δ` is small. Measured against depth by depth and against a
//! rank by whole-subtree gain per byte on the viewer's curve: docs/lab/2026-12-06-viewer.md;
//! the weights by view and per matrix: docs/lab/2026-12-07-viewer-order.md.

use super::compress::{compress_leaf, decompress_matrix, CompressedLeaf, FullLeaf, MATRIX_BYTES};
use super::{LeafValues, Octree, ALL_FACING, NO_VALUE};
use glam::{DMat3, Mat3};
use std::collections::BinaryHeap;

/// What a node of the stream is in the full tree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum StreamKind {
    /// An internal node: a leaf of the prefix until a split brings its children.
    Internal = 0,
    /// A valid leaf (photons in its cell).
    Valid = 1,
    /// An atmospheric leaf (no value).
    Atmospheric = 2,
}

/// One node of the stream.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StreamNode {
    pub kind: StreamKind,
    /// The matrices that carry a value (bits `+X, −X, +Y, −Y, +Z, −Z`); 0 for atmospheric.
    pub facing: u8,
    /// The six matrices (zero for atmospheric).
    pub value: CompressedLeaf,
}

impl StreamNode {
    /// Bytes on the wire: kind and facing, and the value unless atmospheric.
    pub fn bytes(&self) -> usize {
        2 + if self.kind == StreamKind::Atmospheric { 0 } else { 36 }
    }
}

/// The 8 children of a node already sent (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct StreamSplit {
    /// The parent's index in the stream (the root is 0; split `j`'s children are
    /// `1 + 8 j .. 1 + 8 j + 8`, in child order).
    pub parent: u32,
    /// Their depth in the tree.
    pub depth: u32,
    pub children: [StreamNode; 8],
}

/// The octree as a stream (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Stream {
    pub root: StreamNode,
    pub splits: Vec<StreamSplit>,
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
    /// The tree as a stream, coarse to fine (module docs).
    pub fn stream(&self) -> Stream {
        self.stream_seen(&[])
    }

    /// The tree as a stream, the cells of the surface points `seen` (those a first view
    /// shows) refined first (module docs, "Order"); any order is still every node once, each
    /// after its parent.
    pub fn stream_seen(&self, seen: &[glam::Vec3]) -> Stream {
        let records = self.stream_nodes();
        let n = self.nodes.len();
        let depths = self.node_depths();
        let full: Vec<FullLeaf> = records
            .iter()
            .map(|r| std::array::from_fn(|k| decompress_matrix(&r.value[k * MATRIX_BYTES..(k + 1) * MATRIX_BYTES])))
            .collect();
        let m2 = |m: &Mat3| m.to_cols_array().iter().map(|v| (*v as f64).powi(2)).sum::<f64>();
        let valid: Vec<f64> = records
            .iter()
            .zip(&full)
            .filter(|(r, _)| r.kind == StreamKind::Valid)
            .map(|(_, m)| m.iter().map(m2).sum::<f64>() / 6.0)
            .collect();
        let eps = 1e-6 * valid.iter().sum::<f64>() / valid.len().max(1) as f64 + f64::MIN_POSITIVE;
        // Each split's own gain (module docs, "Order") and bytes (its 8 children and the
        // parent's index), and each node's parent.
        let (mut gain, mut bytes, mut parent) = (vec![0.0f64; n], vec![0.0f64; n], vec![u32::MAX; n]);
        let shown = self.points_per_node(seen);
        let (root_volume, seen_n) = ((self.cell_size[0] as f64).powi(3), seen.len().max(1) as f64);
        for id in 0..n {
            let node = self.nodes[id];
            if node.is_leaf() {
                continue;
            }
            let (first, mean) = (node.link as usize, &full[id]);
            bytes[id] = 4.0;
            for c in first..first + 8 {
                parent[c] = id as u32;
                bytes[id] += records[c].bytes() as f64;
                if records[c].kind == StreamKind::Atmospheric {
                    continue;
                }
                let gamma = (self.cell_size[depths[c] as usize] as f64).powi(3) / root_volume + shown[c] as f64 / seen_n;
                let d: f64 = (0..6)
                    .filter(|&k| records[c].facing & records[id].facing & (1 << k) != 0)
                    .map(|k| m2(&(full[c][k] - mean[k])) / (m2(&mean[k]) + eps))
                    .sum();
                gain[id] += gamma * d;
            }
        }
        let internal: Vec<bool> = self.nodes.iter().map(|nd| !nd.is_leaf()).collect();
        let order = if internal[0] { horn_order(&internal, &gain, &bytes, &parent) } else { Vec::new() };
        // the stream index of each node once sent: the root 0, split `j`'s children 1 + 8 j + c
        let mut at = vec![0u32; n];
        let mut splits = Vec::with_capacity(order.len());
        for id in order {
            let first = self.nodes[id as usize].link as usize;
            let base = 1 + 8 * splits.len() as u32;
            for c in 0..8 {
                at[first + c] = base + c as u32;
            }
            splits.push(StreamSplit {
                parent: at[id as usize],
                depth: depths[first],
                children: std::array::from_fn(|c| records[first + c]),
            });
        }
        Stream { root: records[0], splits }
    }

    /// Every node's record (module docs): an internal node's mean, a valid leaf's own value.
    fn stream_nodes(&self) -> Vec<StreamNode> {
        let n = self.nodes.len();
        let mut sums = vec![NO_SUMS; n];
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
        (0..n)
            .map(|id| {
                let node = self.nodes[id];
                if !node.is_leaf() {
                    let s = &sums[id];
                    let mean: FullLeaf =
                        std::array::from_fn(|k| if s.w[k] > 0.0 { (s.m[k] * (1.0 / s.w[k])).as_mat3() } else { Mat3::ZERO });
                    let facing = (0..6).filter(|&k| s.w[k] > 0.0).fold(0u8, |b, k| b | (1 << k));
                    return StreamNode { kind: StreamKind::Internal, facing, value: compress_leaf(&mean) };
                }
                let v = node.value();
                if v == NO_VALUE {
                    return StreamNode { kind: StreamKind::Atmospheric, facing: 0, value: [0; 36] };
                }
                let facing = self.facing.get(v as usize).copied().unwrap_or(ALL_FACING);
                let value = match &self.values {
                    LeafValues::Compressed(c) => c[v as usize],
                    LeafValues::Full(f) => compress_leaf(&f[v as usize]),
                };
                StreamNode { kind: StreamKind::Valid, facing, value }
            })
            .collect()
    }

    /// The six matrices of valid leaf `v`, decompressed.
    fn leaf_full(&self, v: usize) -> FullLeaf {
        match &self.values {
            LeafValues::Compressed(c) => std::array::from_fn(|k| decompress_matrix(&c[v][k * MATRIX_BYTES..(k + 1) * MATRIX_BYTES])),
            LeafValues::Full(f) => f[v],
        }
    }

    /// How many of `points` lie in each node's cell: counted at their leaves, summed upwards
    /// (children come after their parent, as in [`Octree::stream_nodes`]).
    fn points_per_node(&self, points: &[glam::Vec3]) -> Vec<u32> {
        let mut count = vec![0u32; self.nodes.len()];
        for &p in points {
            if let Some((leaf, _, _)) = self.find_leaf(p) {
                count[leaf as usize] += 1;
            }
        }
        for id in (0..self.nodes.len()).rev() {
            let node = self.nodes[id];
            if !node.is_leaf() {
                count[id] = (0..8).map(|c| count[node.link as usize + c]).sum();
            }
        }
        count
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

/// The order of the internal nodes (the root first, every node after its parent) that lowers
/// the error fastest per byte (module docs, "Order"): Horn's algorithm for an out-tree of jobs
/// of weight `gain` and time `bytes`. Repeatedly, the group of highest `Σ gain / Σ bytes` that
/// is not the root's joins its parent's group, its sequence appended to the parent group's;
/// the root's group's sequence is the order (ties: the lower node index first).
fn horn_order(internal: &[bool], gain: &[f64], bytes: &[f64], parent: &[u32]) -> Vec<u32> {
    const END: u32 = u32::MAX;
    let n = internal.len();
    // per group (named by its first node): totals, the last node of its sequence; per node:
    // the next in its group's sequence, and its group (union-find, by the first node)
    let (mut w, mut p) = (gain.to_vec(), bytes.to_vec());
    let mut tail: Vec<u32> = (0..n as u32).collect();
    let mut next = vec![END; n];
    let mut group: Vec<u32> = (0..n as u32).collect();
    let mut version = vec![0u32; n];
    fn find(group: &mut [u32], mut x: u32) -> u32 {
        while group[x as usize] != x {
            let up = group[group[x as usize] as usize];
            group[x as usize] = up;
            x = up;
        }
        x
    }
    let ratio = |w: f64, p: f64| if p > 0.0 { w / p } else { 0.0 };
    let mut heap: BinaryHeap<(u64, std::cmp::Reverse<u32>, u32)> =
        (1..n).filter(|&id| internal[id]).map(|id| (ratio(w[id], p[id]).to_bits(), std::cmp::Reverse(id as u32), 0)).collect();
    while let Some((_, std::cmp::Reverse(id), ver)) = heap.pop() {
        let g = id as usize;
        if group[g] != id || version[g] != ver {
            continue; // merged into another group, or its totals changed since
        }
        let into = find(&mut group, parent[g]);
        let to = into as usize;
        next[tail[to] as usize] = id;
        tail[to] = tail[g];
        w[to] += w[g];
        p[to] += p[g];
        group[g] = into;
        if into != 0 {
            version[to] += 1;
            heap.push((ratio(w[to], p[to]).to_bits(), std::cmp::Reverse(into), version[to]));
        }
    }
    let mut order = Vec::new();
    let mut at = 0u32;
    while at != END {
        order.push(at);
        at = next[at as usize];
    }
    order
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
    fn the_stream_sends_every_node_once_parents_first_and_ends_as_the_tree() {
        let t = tree();
        let st = t.stream();
        assert_eq!(1 + 8 * st.splits.len(), t.nodes.len());
        // a split's parent is a node sent before, internal, split once
        let mut kinds = vec![st.root.kind];
        let mut split = vec![false];
        for s in &st.splits {
            let p = s.parent as usize;
            assert!(p < kinds.len() && kinds[p] == StreamKind::Internal && !split[p], "split of {p}");
            split[p] = true;
            kinds.extend(s.children.iter().map(|c| c.kind));
            split.extend([false; 8]);
        }
        assert!(kinds.iter().zip(&split).all(|(k, s)| (*k == StreamKind::Internal) == *s), "every internal node split");
        let LeafValues::Compressed(values) = &t.values else { panic!("compressed") };
        let mut valid: Vec<CompressedLeaf> =
            st.splits.iter().flat_map(|s| &s.children).filter(|n| n.kind == StreamKind::Valid).map(|n| n.value).collect();
        let mut own = values.clone();
        valid.sort();
        own.sort();
        assert_eq!(valid, own, "every valid leaf's own 36 bytes");
        // not depth by depth: some split comes before a shallower one
        assert!(st.splits.windows(2).any(|w| w[1].depth < w[0].depth), "the order follows the gain, not the depth");
    }

    #[test]
    fn the_cells_a_view_sees_come_first() {
        // a point on the floor far from the wall: the splits down to its leaf lead the stream
        let t = tree();
        let p = Vec3::new(0.93, 0.0, 0.87);
        let (leaf, depth, _) = t.find_leaf(p).unwrap();
        assert!(depth >= 3, "a deep leaf: {depth}");
        // the split that sends `leaf`: its parent's, found by walking the stream's parents
        let sent_at = |st: &Stream| {
            let mut ids = vec![0usize]; // stream index -> node id
            for (j, s) in st.splits.iter().enumerate() {
                let first = t.nodes[ids[s.parent as usize]].link as usize;
                ids.extend(first..first + 8);
                if (first..first + 8).contains(&(leaf as usize)) {
                    return j;
                }
            }
            unreachable!("every node is sent")
        };
        let (by_volume, seen) = (sent_at(&t.stream()), sent_at(&t.stream_seen(&[p; 4])));
        assert_eq!(seen + 1, depth as usize, "the path to the seen leaf first ({by_volume} by volume)");
        assert!(by_volume > seen, "by volume alone it comes later: {by_volume}");
    }

    #[test]
    fn a_coarse_node_holds_the_blend_of_its_leaves_over_its_cell() {
        // the root's +Y matrix against the volume-weighted mean of the valid leaves' +Y
        let t = tree();
        let root = t.stream().root;
        assert_eq!(root.kind, StreamKind::Internal);
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

    /// `Σ gain_j C_j`, `C_j` the bytes sent once split `j` is done.
    fn weighted_completion(order: &[u32], gain: &[f64], bytes: &[f64]) -> f64 {
        let mut sent = 0.0;
        order
            .iter()
            .map(|&j| {
                sent += bytes[j as usize];
                gain[j as usize] * sent
            })
            .sum()
    }

    #[test]
    fn horn_order_is_the_best_order_of_small_trees() {
        // random trees of 7 nodes (node i's parent below i), all internal: against every
        // order with each node after its parent
        let mut s = Sampler::new(5, 0, 0);
        for _ in 0..40 {
            let n = 7;
            let parent: Vec<u32> = (0..n).map(|i| if i == 0 { u32::MAX } else { (s.next_1d() * i as f32) as u32 }).collect();
            let gain: Vec<f64> = (0..n).map(|_| (s.next_1d() as f64).powi(3)).collect();
            let bytes: Vec<f64> = (0..n).map(|_| 4.0 + 300.0 * s.next_1d() as f64).collect();
            let order = horn_order(&[true; 7], &gain, &bytes, &parent);
            let mut seen = [false; 7];
            for &j in &order {
                assert!(j == 0 || seen[parent[j as usize] as usize], "{order:?}: {j} before its parent");
                seen[j as usize] = true;
            }
            assert!(seen.iter().all(|&x| x), "{order:?}");
            // every order of 1..7 after the root that keeps parents first
            let mut best = f64::INFINITY;
            let mut perm: Vec<u32> = (1..n as u32).collect();
            let mut c = vec![0usize; perm.len()];
            let mut check = |p: &[u32]| {
                let full: Vec<u32> = std::iter::once(0).chain(p.iter().copied()).collect();
                let ok = full.iter().enumerate().all(|(at, &j)| j == 0 || full[..at].contains(&parent[j as usize]));
                if ok {
                    best = best.min(weighted_completion(&full, &gain, &bytes));
                }
            };
            check(&perm);
            let mut i = 0;
            while i < perm.len() {
                // Heap's algorithm
                if c[i] < i {
                    if i % 2 == 0 {
                        perm.swap(0, i)
                    } else {
                        perm.swap(c[i], i)
                    }
                    check(&perm);
                    c[i] += 1;
                    i = 0;
                } else {
                    c[i] = 0;
                    i += 1;
                }
            }
            let got = weighted_completion(&order, &gain, &bytes);
            assert!(got <= best * (1.0 + 1e-12), "Horn's order {order:?} costs {got}, the best {best}");
        }
    }
}
