//! The octree as plain data, for cache files (issue 13; the byte format is
//! `octolux_io::cache`, docs/guide/baking.md): [`Octree::to_parts`] and [`Octree::from_parts`].
//!
//! [`OctreeParts`] is the one place to extend when a leaf gains data: whatever the query reads
//! must be a field here (or derived from one, as the per-depth cell edges, the Morton scale
//! and the query box are derived from `origin`, `size`, the settings and the deepest leaf).
//!
//! `from_parts` trusts nothing: it checks every invariant the build guarantees and the query
//! relies on, so that bytes from a file cannot make a query index out of range or loop:
//! - the nodes form one tree laid out as the build lays it out: children of an internal node
//!   are 8 consecutive nodes allocated in depth-first order (so every node is reached exactly
//!   once, no cycle, no orphan), no leaf below `h_max`;
//! - a leaf is valid exactly when its cell holds photons, and the valid leaves' value indices
//!   are `0, 1, 2, ...` in depth-first order (each value used once); an internal node's photon
//!   count is the sum of its children's;
//! - the values and the facing bits have one entry per valid leaf (facing: or none), facing
//!   uses only its six bits, full matrices are finite;
//! - the settings validate, the root cube is finite and not empty.
//!
//! The structural statistics (nodes, leaves, depth histogram, smallest leaf, bytes, means over
//! the leaves' own photons and edges) are recomputed, in the build's order, so that they equal
//! the build's; the others (build time, photons dropped, gathered means, fallbacks) are kept.

use super::compress::{CompressedLeaf, FullLeaf};
use super::settings::{Depth, MAX_DEPTH};
use super::{LeafAnchors, LeafValues, Node, Octree, OctreeSettings, OctreeStats, LEAF_BIT, NO_VALUE};
use glam::Vec3;

/// The leaf values of [`OctreeParts`], one per valid leaf in depth-first order.
#[derive(Clone, Debug, PartialEq)]
pub enum LeafValueParts {
    /// The paper's 36-byte leaves (`compress.rs`).
    Compressed(Vec<CompressedLeaf>),
    /// Six f32 3x3 matrices per leaf (`Storage::Full`).
    Full(Vec<FullLeaf>),
}

impl LeafValueParts {
    pub fn len(&self) -> usize {
        match self {
            LeafValueParts::Compressed(v) => v.len(),
            LeafValueParts::Full(v) => v.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The values diffused into the leaves that lack them (`atmosphere.rs`), as plain data.
#[derive(Clone, Debug, PartialEq)]
pub struct AtmosphereParts {
    /// Per leaf (valid and atmospheric, depth-first order): which of the six matrices were
    /// diffused into it.
    pub filled: Vec<u8>,
    /// One entry per leaf with any filled bit, in order, in the tree's storage (zero matrices
    /// where not filled).
    pub values: LeafValueParts,
    /// Per entry, where its flights pass within its cell (three bytes, `0..=254` per axis;
    /// [`NO_ANCHOR`](super::atmosphere::NO_ANCHOR): a diffused value), or empty: none recorded.
    pub anchors: Vec<[u8; 3]>,
}

/// A built octree as plain data (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct OctreeParts {
    /// Minimum corner of the root cube (scene units).
    pub origin: Vec3,
    /// Edge of the root cube (scene units).
    pub size: f32,
    /// The depth limit the build used (`settings.h_max` resolved: [`Depth::Auto`] depends on
    /// the photons and the scene).
    pub h_max: u32,
    pub settings: OctreeSettings,
    /// Per node `[link, photons]`: `link` is the first child's index for an internal node,
    /// `LEAF_LINK | value index` for a leaf ([`ATMOSPHERIC`] as the value: no value);
    /// `photons` is the count in the (not enlarged) cell. Node 0 is the root.
    pub nodes: Vec<[u32; 2]>,
    pub values: LeafValueParts,
    /// Per valid leaf, the six facing bits (`+X, −X, +Y, −Y, +Z, −Z`); empty: all set.
    pub facing: Vec<u8>,
    /// Per valid leaf, where its photons lie (the leak test's anchors; any bytes are valid).
    pub anchors: Vec<LeafAnchors>,
    /// Whether `anchors` hold the sampled photons; false: each leaf's samples are its mean
    /// ([`OctreeParts::without_leak_samples`]), and the `visible_sample` leak test cannot run.
    pub leak_samples: bool,
    /// The build's statistics (the structural ones are recomputed by `from_parts`).
    pub stats: OctreeStats,
    /// Diffused values ([`Octree::fill_atmosphere`]), if filled.
    pub atmosphere: Option<AtmosphereParts>,
}

impl OctreeParts {
    /// The parts without the leak test's sampled photons: each leaf's samples become its mean
    /// (what a cache file that keeps only the means reads back, 24 bytes per valid leaf fewer).
    pub fn without_leak_samples(mut self) -> OctreeParts {
        for a in &mut self.anchors {
            a.samples = [a.mean; super::ANCHOR_SAMPLES];
        }
        self.leak_samples = false;
        self
    }
}

/// High bit of a node's `link`: the node is a leaf.
pub const LEAF_LINK: u32 = LEAF_BIT;
/// The value index of an atmospheric leaf (no photon in its cell).
pub const ATMOSPHERIC: u32 = NO_VALUE;

/// Why parts do not make an octree.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("invalid octree data: {0}")]
pub struct PartsError(pub String);

/// `2^h / size`, the Morton scale of the build (`build.rs`: same formula, same bits).
pub(super) fn morton_scale(h: u32, size: f32) -> f32 {
    ((1u64 << h) as f64 / size as f64) as f32
}

/// Edge of a cell per depth (`build.rs`: same formula).
pub(super) fn cell_sizes(size: f32) -> [f32; MAX_DEPTH as usize + 1] {
    let mut cell_size = [0.0f32; MAX_DEPTH as usize + 1];
    for (d, cs) in cell_size.iter_mut().enumerate() {
        *cs = size / (1u64 << d) as f32;
    }
    cell_size
}

/// What the depth-first check of the node array collects.
struct Walk<'a> {
    nodes: &'a [Node],
    h_max: u32,
    /// Next node index the build would allocate.
    next: usize,
    /// Next value index the build would give.
    next_value: u32,
    leaves: usize,
    max_depth: u32,
    depth_histogram: Vec<u32>,
    own_photons: f64,
    cells: f64,
    cell_size: [f32; MAX_DEPTH as usize + 1],
}

impl<'a> Walk<'a> {
    /// The check of `nodes` from the root (every invariant of the module docs on the nodes).
    fn run(nodes: &'a [Node], h_max: u32, cell_size: [f32; MAX_DEPTH as usize + 1]) -> Result<Walk<'a>, PartsError> {
        let mut walk = Walk {
            nodes,
            h_max,
            next: 1,
            next_value: 0,
            leaves: 0,
            max_depth: 0,
            depth_histogram: vec![0; h_max as usize + 1],
            own_photons: 0.0,
            cells: 0.0,
            cell_size,
        };
        walk.node(0, 0)?;
        if walk.next != nodes.len() {
            return Err(PartsError(format!("{} nodes, the tree reaches {}", nodes.len(), walk.next)));
        }
        Ok(walk)
    }

    /// `stats` with the structural statistics of the walked tree (module docs), `bytes` its
    /// size as stored.
    fn stats(&self, stats: OctreeStats, bytes: usize) -> OctreeStats {
        let nv = self.next_value as usize;
        let mean = |s: f64| if nv > 0 { s / nv as f64 } else { 0.0 };
        OctreeStats {
            bytes,
            bytes_per_valid_leaf: if nv > 0 { bytes as f64 / nv as f64 } else { 0.0 },
            leaves: self.leaves,
            valid_leaves: nv,
            mean_photons_per_leaf: mean(self.own_photons),
            mean_cell_size: mean(self.cells),
            depth_histogram: self.depth_histogram.clone(),
            nodes: self.nodes.len(),
            max_depth: self.max_depth,
            min_leaf_size: self.cell_size[self.max_depth as usize],
            h_max: self.h_max,
            ..stats
        }
    }

    fn node(&mut self, id: usize, depth: u32) -> Result<(), PartsError> {
        let bad = |m: String| Err(PartsError(m));
        let Node { link, photons } = self.nodes[id];
        if link & LEAF_BIT != 0 {
            let value = link & !LEAF_BIT;
            self.leaves += 1;
            self.max_depth = self.max_depth.max(depth);
            if value == NO_VALUE {
                if photons != 0 {
                    return bad(format!("node {id}: an atmospheric leaf holds {photons} photons"));
                }
                return Ok(());
            }
            if photons == 0 {
                return bad(format!("node {id}: a valid leaf holds no photon"));
            }
            if value != self.next_value {
                return bad(format!("node {id}: value {value}, expected {} (depth-first order)", self.next_value));
            }
            self.next_value += 1;
            self.depth_histogram[depth as usize] += 1;
            self.own_photons += photons as f64;
            self.cells += self.cell_size[depth as usize] as f64;
            return Ok(());
        }
        if depth >= self.h_max {
            return bad(format!("node {id}: an internal node at depth {depth}, h_max is {}", self.h_max));
        }
        let first = link as usize;
        if first != self.next || first + 8 > self.nodes.len() {
            return bad(format!("node {id}: children at {first}, expected {} of {} nodes", self.next, self.nodes.len()));
        }
        self.next += 8;
        for c in 0..8 {
            self.node(first + c, depth + 1)?;
        }
        let sum: u64 = self.nodes[first..first + 8].iter().map(|n| n.photons as u64).sum();
        if sum != photons as u64 {
            return bad(format!("node {id}: {photons} photons, its children hold {sum}"));
        }
        Ok(())
    }
}

impl Octree {
    /// The octree as plain data (module docs).
    pub fn to_parts(&self) -> OctreeParts {
        OctreeParts {
            origin: self.origin,
            size: self.size,
            h_max: self.h_max,
            settings: self.settings.clone(),
            nodes: self.nodes.iter().map(|n| [n.link, n.photons]).collect(),
            values: match &self.values {
                LeafValues::Compressed(v) => LeafValueParts::Compressed(v.clone()),
                LeafValues::Full(v) => LeafValueParts::Full(v.clone()),
            },
            facing: self.facing.clone(),
            anchors: self.anchors.clone(),
            leak_samples: self.leak_samples,
            stats: self.stats.clone(),
            atmosphere: self.atmosphere.as_ref().map(|a| AtmosphereParts {
                filled: a.filled.clone(),
                values: match &a.values {
                    LeafValues::Compressed(v) => LeafValueParts::Compressed(v.clone()),
                    LeafValues::Full(v) => LeafValueParts::Full(v.clone()),
                },
                anchors: a.anchors.clone(),
            }),
        }
    }

    /// An octree from plain data, every invariant checked (module docs). Queries of the
    /// result are bit-identical to those of the octree the parts came from.
    pub fn from_parts(parts: OctreeParts) -> Result<Octree, PartsError> {
        let OctreeParts { origin, size, h_max, settings, nodes, values, facing, anchors, leak_samples, stats, atmosphere } = parts;
        let bad = |m: String| Err(PartsError(m));
        settings.validate().map_err(|e| PartsError(e.to_string()))?;
        if !(origin.is_finite() && size.is_finite() && size > 0.0) {
            return bad(format!("root cube at {origin} of edge {size}"));
        }
        let h = h_max;
        if h > MAX_DEPTH || matches!(settings.h_max, Depth::Fixed(f) if f != h) {
            return bad(format!("h_max {h} (settings: {:?}, at most {MAX_DEPTH})", settings.h_max));
        }
        let inv_quant = morton_scale(h, size);
        if !(inv_quant.is_finite() && inv_quant > 0.0) {
            return bad(format!("root cube edge {size} is too small for h_max = {h}"));
        }
        if nodes.is_empty() || nodes.len() >= NO_VALUE as usize {
            return bad(format!("{} nodes", nodes.len()));
        }
        let n_values = values.len();
        if !facing.is_empty() && facing.len() != n_values {
            return bad(format!("{} facing entries for {n_values} valid leaves", facing.len()));
        }
        if let Some(f) = facing.iter().find(|&&f| f & !super::ALL_FACING != 0) {
            return bad(format!("facing bits {f:#010b} beyond the six matrices"));
        }
        if let LeafValueParts::Full(v) = &values {
            if v.iter().flatten().any(|m| !m.is_finite()) {
                return bad("a full leaf matrix is not finite".into());
            }
        }
        let cell_size = cell_sizes(size);
        let nodes: Vec<Node> = nodes.into_iter().map(|[link, photons]| Node { link, photons }).collect();
        let walk = Walk::run(&nodes, h, cell_size)?;
        if walk.next_value as usize != n_values {
            return bad(format!("{} valid leaves, {n_values} values", walk.next_value));
        }
        if anchors.len() != n_values {
            return bad(format!("{} leaf anchors for {n_values} valid leaves", anchors.len()));
        }
        if let Some(a) = &atmosphere {
            if a.filled.len() != walk.leaves {
                return bad(format!("{} atmosphere entries for {} leaves", a.filled.len(), walk.leaves));
            }
            if let Some(f) = a.filled.iter().find(|&&f| f & !super::ALL_FACING != 0) {
                return bad(format!("atmosphere bits {f:#010b} beyond the six matrices"));
            }
            let entries = a.filled.iter().filter(|&&f| f != 0).count();
            if a.values.len() != entries {
                return bad(format!("{} atmosphere values for {entries} filled leaves", a.values.len()));
            }
            if !a.anchors.is_empty() && a.anchors.len() != entries {
                return bad(format!("{} atmosphere anchors for {entries} filled leaves", a.anchors.len()));
            }
            if std::mem::discriminant(&a.values) != std::mem::discriminant(&values) {
                return bad("the atmosphere's storage is not the tree's".into());
            }
            if let LeafValueParts::Full(v) = &a.values {
                if v.iter().flatten().any(|m| !m.is_finite()) {
                    return bad("an atmosphere matrix is not finite".into());
                }
            }
        }
        let values = match values {
            LeafValueParts::Compressed(v) => LeafValues::Compressed(v),
            LeafValueParts::Full(v) => LeafValues::Full(v),
        };
        let atmosphere_values = atmosphere.map(|a| {
            let v = match a.values {
                LeafValueParts::Compressed(v) => LeafValues::Compressed(v),
                LeafValueParts::Full(v) => LeafValues::Full(v),
            };
            (a.filled, v, a.anchors)
        });
        let atmosphere_bytes = atmosphere_values.as_ref().map_or(0, |(f, v, q)| f.len() + v.bytes() + 3 * q.len());
        let stats = walk.stats(stats, stored_bytes(&nodes, &values, &facing, &anchors) + atmosphere_bytes);
        let min_leaf_size = stats.min_leaf_size;
        let mut tree = Octree {
            origin,
            size,
            cell_size,
            inv_quant,
            h_max: h,
            nodes,
            values,
            facing,
            anchors,
            leak_samples,
            query_half: 0.5 * settings.alpha * min_leaf_size,
            atmosphere: None,
            flat: Default::default(),
            settings,
            stats,
        };
        if let Some((filled, values, anchors)) = atmosphere_values {
            tree.atmosphere = Some(super::atmosphere::Atmosphere::new(&tree, filled, values, anchors));
        }
        Ok(tree)
    }
}

/// Bytes of a tree as stored: nodes, leaf values, facing bits and anchors (the atmosphere's
/// are added by the caller).
fn stored_bytes(nodes: &[Node], values: &LeafValues, facing: &[u8], anchors: &[LeafAnchors]) -> usize {
    std::mem::size_of_val(nodes) + values.bytes() + facing.len() + std::mem::size_of_val(anchors)
}

impl Octree {
    /// The structural statistics and the query box recounted from the tree as it is now, as
    /// [`Octree::from_parts`] would count them (for a tree changed after its build, such as a
    /// free-space tree refined to another depth). Fails only where the nodes break an
    /// invariant of the module docs.
    pub fn recount(&mut self) -> Result<(), PartsError> {
        let walk = Walk::run(&self.nodes, self.h_max, self.cell_size)?;
        let bytes =
            stored_bytes(&self.nodes, &self.values, &self.facing, &self.anchors) + self.atmosphere.as_ref().map_or(0, |a| a.bytes());
        let stats = walk.stats(std::mem::take(&mut self.stats), bytes);
        self.query_half = 0.5 * self.settings.alpha * stats.min_leaf_size;
        self.stats = stats;
        // the query's lists follow the query box
        self.flat = Default::default();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::caches::octree::{Estimator, Storage};
    use crate::math::Bounds3;
    use crate::photon::Photon;
    use crate::sampling::{square_to_uniform_sphere, Sampler};

    fn photons(n: usize) -> Vec<Photon> {
        super::super::test_photons::box_photons(n, 7)
    }

    fn tree(storage: Storage) -> Octree {
        let settings = OctreeSettings { storage, estimator: Estimator::Cosine, n_max: 40, n_min: 10, ..Default::default() };
        Octree::build(&photons(6000), Bounds3 { min: Vec3::ZERO, max: Vec3::ONE }, &settings, None).unwrap()
    }

    #[test]
    fn round_trip_is_exact_and_queries_are_bit_identical() {
        for storage in [Storage::Compressed, Storage::Full] {
            let t = tree(storage);
            assert!(t.stats().valid_leaves > 20 && t.stats().leaves > t.stats().valid_leaves, "{:?}", t.stats());
            let back = Octree::from_parts(t.to_parts()).unwrap();
            assert_eq!(back.stats(), t.stats());
            assert_eq!(back.to_parts(), t.to_parts());
            let mut s = Sampler::new(1, 2, 3);
            for _ in 0..2000 {
                let p = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * 1.2 - Vec3::splat(0.1);
                let n = square_to_uniform_sphere(s.next_2d());
                let (a, b) = (t.incident_matrix(p, n), back.incident_matrix(p, n));
                assert_eq!(a.map(|m| m.to_cols_array().map(f32::to_bits)), b.map(|m| m.to_cols_array().map(f32::to_bits)));
            }
        }
    }

    /// `recount` gives the statistics and the query box `from_parts` gives: on a built tree
    /// whose structural statistics were spoilt, and on a free-space tree, whose start keeps
    /// the global tree's depth until recounted.
    #[test]
    fn recount_matches_a_round_trip() {
        let t = tree(Storage::Compressed);
        let mut spoilt = t.clone();
        spoilt.stats.max_depth = 0;
        spoilt.stats.bytes = 1;
        spoilt.stats.depth_histogram.clear();
        spoilt.query_half = 0.0;
        spoilt.recount().unwrap();
        assert_eq!(spoilt.stats(), t.stats());
        assert_eq!(spoilt.query_half.to_bits(), t.query_half.to_bits());
        let mut free = t.free_space_tree();
        let back = Octree::from_parts(free.to_parts()).unwrap();
        assert_ne!(free.stats().max_depth, back.stats().max_depth, "the test needs a tree shallower than its start says");
        free.recount().unwrap();
        assert_eq!(free.stats(), back.stats());
        assert_eq!(free.query_half.to_bits(), back.query_half.to_bits());
    }

    #[test]
    fn parts_without_the_leak_samples_keep_the_means_and_say_so() {
        let t = tree(Storage::Compressed);
        assert!(t.has_leak_samples());
        let p = t.to_parts().without_leak_samples();
        assert!(!p.leak_samples);
        assert!(p.anchors.iter().zip(&t.to_parts().anchors).all(|(a, b)| a.mean == b.mean && a.samples == [b.mean; 4]));
        let back = Octree::from_parts(p.clone()).unwrap();
        assert!(!back.has_leak_samples());
        assert_eq!(back.to_parts(), p);
        // a refit copies the leaves it does not estimate: it keeps what the tree holds
        let (refit, _) = back.refit(&photons(6000), None, None).unwrap();
        assert!(!refit.has_leak_samples());
    }

    #[test]
    fn broken_invariants_are_refused() {
        let good = tree(Storage::Compressed).to_parts();
        let internal = good.nodes.iter().position(|n| n[0] & LEAF_LINK == 0).unwrap();
        let valid = good.nodes.iter().position(|n| n[0] & LEAF_LINK != 0 && n[0] != LEAF_LINK | ATMOSPHERIC).unwrap();
        let empty = good.nodes.iter().position(|n| n[0] == LEAF_LINK | ATMOSPHERIC).unwrap();
        type Mutation = Box<dyn Fn(&mut OctreeParts)>;
        let mutations: Vec<(&str, Mutation)> = vec![
            ("nodes", Box::new(|p| p.nodes.clear())),
            ("children", Box::new(move |p| p.nodes[internal][0] = 10_000_000)),
            ("children", Box::new(|p| p.nodes[0][0] = 0)),
            ("expected", Box::new(move |p| p.nodes[valid][0] = LEAF_LINK | 1_000_000)),
            ("atmospheric", Box::new(move |p| p.nodes[empty][1] = 3)),
            ("photons", Box::new(move |p| p.nodes[valid][1] += 1)),
            ("nodes, the tree", Box::new(|p| p.nodes.push([LEAF_LINK | ATMOSPHERIC, 0]))),
            (
                "values",
                Box::new(|p| {
                    if let LeafValueParts::Compressed(v) = &mut p.values {
                        v.pop();
                    }
                }),
            ),
            ("facing", Box::new(|p| p.facing = vec![1; 3])),
            ("h_max", Box::new(|p| p.h_max = 1)),
            ("h_max", Box::new(|p| p.h_max = MAX_DEPTH + 1)),
            ("h_max", Box::new(|p| p.settings.h_max = Depth::Fixed(p.h_max + 1))),
            (
                "anchors",
                Box::new(|p| {
                    p.anchors.pop();
                }),
            ),
            ("alpha", Box::new(|p| p.settings.alpha = f32::NAN)),
            ("root cube", Box::new(|p| p.size = -1.0)),
            ("root cube", Box::new(|p| p.origin.x = f32::INFINITY)),
            ("not finite", Box::new(|p| p.values = LeafValueParts::Full(vec![[glam::Mat3::from_diagonal(Vec3::NAN); 6]; p.values.len()]))),
        ];
        for (word, m) in mutations {
            let mut p = good.clone();
            m(&mut p);
            let e = Octree::from_parts(p).err().unwrap_or_else(|| panic!("accepted ({word})"));
            assert!(e.to_string().contains(word), "{e} should say {word}");
        }
        let n = good.values.len();
        let mut p = good.clone();
        p.facing = vec![0x40; n];
        assert!(Octree::from_parts(p).unwrap_err().to_string().contains("facing bits"));
    }
}
