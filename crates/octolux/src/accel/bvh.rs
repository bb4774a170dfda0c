//! Pure-Rust backend: a wide BVH (8 children per node for `Accel`; 4 also available) with
//! 4-triangle leaf blocks, built with binned SAH, and a watertight triangle test.
//!
//! Layout (struct-of-arrays so that one SIMD op handles four boxes or four triangles; `glam::Vec4`
//! maps to SSE on x86-64 and to scalar code elsewhere):
//! - `Node<H>`: bounds of up to `4H` children as `[min_x, max_x, min_y, max_y, min_z, max_z]`
//!   lanes, plus a child word each. Empty slots have inverted (+inf/-inf) bounds, so they are never
//!   entered. A child word is either an inner-node index (`< LEAF_BIT`) or a leaf
//!   `LEAF_BIT | first_block << 3 | (block_count - 1)`.
//! - `Tri4`: four triangles (vertices and original index). A block with fewer than four
//!   triangles repeats its first triangle in the unused lanes (duplicate hits are harmless: same
//!   triangle, same `t`).
//!
//! Build: top-down binned SAH (32 bins on all three axes; cost counted in 4-triangle blocks, as
//! in Embree's builders). A node is formed by repeatedly splitting the child candidate with the
//! largest surface area until it has `4H` children (the usual "collapse a BVH2" rule, done during
//! the build). Leaves hold at most [`MAX_LEAF_TRIS`] triangles. Below depth [`MAX_SAH_DEPTH`] the
//! builder switches to object-median splits of the most populated candidate, which bounds the
//! tree depth (and so the fixed traversal stack) for any input. Identical triangles are dropped
//! before any backend sees them ([`super::dedup`]); without that, a million coincident copies
//! make a tree of overlapping boxes that every ray through them visits to the bottom. Subtrees
//! with many triangles are built in parallel (rayon). Measured on 983k triangles: BVH8 slightly faster than BVH4, and
//! both faster than the `obvhs` 0.4 CWBVH (which is therefore not used).
//!
//! Traversal: closest hit is ordered (nearest child first, the others pushed farthest-first with
//! their entry distance and culled on pop once a closer hit is known); occlusion pushes hit
//! children unsorted and stops at the first hit (as Embree's any-hit traversal). Pushed children
//! are prefetched. Box tests are conservative like Embree's robust mode (entry distance scaled by
//! `1 - 3 ulp`, exit by `1 + 3 ulp`). The stack is a fixed, uninitialised array. At the `avx2`
//! kernel level (`crate::cpu`) the BVH8's traversal is a second copy compiled for AVX2 whose
//! box test takes a node's eight boxes in one register, with the same per-lane operations:
//! its hits are the baseline's, bit for bit (`bvh/tests.rs`).
//!
//! Triangle test: the watertight algorithm of Woop, Benthin & Wald (JCGT 2013): vertices are
//! translated to the ray origin and sheared so that the ray becomes the +z axis of a permuted
//! frame (`kz` = largest |direction| component); the 2D edge functions
//! `U = Cx*By - Cy*Bx`, `V = Ax*Cy - Ay*Cx`, `W = Bx*Ay - By*Ax` are exactly antisymmetric per
//! edge and are recomputed in f64 when one is exactly zero, so no ray passes between triangles
//! sharing an edge or a vertex. `(U, V, W) / (U + V + W)` are the weights of `(p0, p1, p2)`,
//! hence octolux's `u = V / det`, `v = W / det`; `t = (U Az + V Bz + W Cz) / det`.

use super::TriHit;
use crate::math::Ray;
use glam::{Vec3, Vec3A, Vec4};
use rayon::prelude::*;
use std::mem::MaybeUninit;

mod build;
use build::{build_inner, range_bounds, Aabb, BuildNode, PrimRef};

/// Most triangles in one leaf (4 blocks of 4; the leaf word has 3 bits for the block count).
pub const MAX_LEAF_TRIS: usize = 16;
/// Below this depth (in tree levels) the builder uses SAH; deeper it splits at object medians,
/// always splitting the most populated candidate, so every level at least halves the count.
pub const MAX_SAH_DEPTH: usize = 16;
/// Tree levels: at most `MAX_SAH_DEPTH` SAH levels, then median levels, each of which divides
/// the triangle count by at least 4 (the most populated candidate is halved until there are
/// four or eight), so at most 16 more for < 2^32 triangles.
const MAX_DEPTH: usize = MAX_SAH_DEPTH + 17;
/// Ordered traversal pushes at most `4H - 1 <= 7` entries per level.
const STACK_SIZE: usize = 7 * MAX_DEPTH + 1;
const LEAF_BIT: u32 = 1 << 31;
const EMPTY: u32 = u32::MAX;
/// Conservative box-test factors (3 ulp), as Embree's robust traversal.
const NEAR_SCALE: f32 = 1.0 - 3.0 * f32::EPSILON * 0.5;
const FAR_SCALE: f32 = 1.0 + 3.0 * f32::EPSILON * 0.5;

/// `4 * H` child boxes (SoA, `H` groups of four lanes) and their child words.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug)]
struct Node<const H: usize> {
    /// `[min_x, max_x, min_y, max_y, min_z, max_z]`, one lane per child.
    b: [[Vec4; H]; 6],
    child: [[u32; 4]; H],
}

impl<const H: usize> Node<H> {
    const EMPTY: Self = Node {
        b: [
            [Vec4::splat(f32::INFINITY); H],
            [Vec4::splat(f32::NEG_INFINITY); H],
            [Vec4::splat(f32::INFINITY); H],
            [Vec4::splat(f32::NEG_INFINITY); H],
            [Vec4::splat(f32::INFINITY); H],
            [Vec4::splat(f32::NEG_INFINITY); H],
        ],
        child: [[EMPTY; 4]; H],
    };

    fn set_child(&mut self, k: usize, b: &Aabb, word: u32) {
        let (lo, hi) = (b.lo.to_array(), b.hi.to_array());
        for axis in 0..3 {
            self.b[2 * axis][k / 4][k % 4] = lo[axis];
            self.b[2 * axis + 1][k / 4][k % 4] = hi[axis];
        }
        self.child[k / 4][k % 4] = word;
    }

    #[inline(always)]
    fn child(&self, k: usize) -> u32 {
        self.child[k / 4][k % 4]
    }
}

/// Four triangles (SoA): vertices `p[vertex][axis]` and original triangle indices.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug)]
struct Tri4 {
    p: [[Vec4; 3]; 3],
    prim: [u32; 4],
}

/// A BVH with `4 * H` children per node (`H = 1`: BVH4, `H = 2`: BVH8).
#[derive(Debug)]
pub struct Bvh<const H: usize> {
    nodes: Vec<Node<H>>,
    tris: Vec<Tri4>,
}

/// 4-wide BVH.
pub type Bvh4 = Bvh<1>;
/// 8-wide BVH (two 4-lane halves per node).
pub type Bvh8 = Bvh<2>;

/// Per-ray constants for the traversal.
struct RayData {
    o: [Vec4; 3],
    inv: [Vec4; 3],
    /// Index into `Node::b` of the near plane per axis (`2*axis` or `2*axis + 1`).
    near: [usize; 3],
    /// Permuted axes of the watertight triangle test (`kz`: largest |direction| component).
    k: [usize; 3],
    /// Shear constants `(Sx, Sy, Sz)`, splatted.
    shear: [Vec4; 3],
    tmin: f32,
}

impl RayData {
    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        let d = ray.d.to_array();
        let o = ray.o.to_array();
        // Tiny components become ±1e-18 (as Embree's rcp_safe) so that no NaN arises from 0*inf.
        let inv = d.map(|x| 1.0 / if x.abs() < 1e-18 { 1e-18f32.copysign(x) } else { x });
        let a = ray.d.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let shear = [d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]].map(Vec4::splat);
        RayData {
            o: o.map(Vec4::splat),
            inv: inv.map(Vec4::splat),
            near: [usize::from(inv[0] < 0.0), 2 + usize::from(inv[1] < 0.0), 4 + usize::from(inv[2] < 0.0)],
            k: [kx, ky, kz],
            shear,
            tmin: ray.tmin,
        }
    }

    /// Slab test against the child boxes; returns the hit mask (bit `k` for child `k`) and
    /// the entry distances.
    #[inline(always)]
    fn hit_node<const H: usize>(&self, n: &Node<H>, tmax: f32) -> (u32, [Vec4; H]) {
        let [nx, ny, nz] = self.near;
        let mut mask = 0;
        let mut tns = [Vec4::ZERO; H];
        for (h, tns_h) in tns.iter_mut().enumerate() {
            let tnx = (n.b[nx][h] - self.o[0]) * self.inv[0];
            let tny = (n.b[ny][h] - self.o[1]) * self.inv[1];
            let tnz = (n.b[nz][h] - self.o[2]) * self.inv[2];
            let tfx = (n.b[nx ^ 1][h] - self.o[0]) * self.inv[0];
            let tfy = (n.b[ny ^ 1][h] - self.o[1]) * self.inv[1];
            let tfz = (n.b[nz ^ 1][h] - self.o[2]) * self.inv[2];
            let tn = tnx.max(tny).max(tnz.max(Vec4::splat(self.tmin))) * NEAR_SCALE;
            let tf = tfx.min(tfy).min(tfz.min(Vec4::splat(tmax))) * FAR_SCALE;
            mask |= tn.cmple(tf).bitmask() << (4 * h);
            *tns_h = tn;
        }
        (mask, tns)
    }

    /// The box test of a node at the kernel level `AVX` (`crate::cpu`): with `AVX` a BVH8
    /// node's eight boxes in one AVX register ([`RayData::hit_node8_avx`]), else
    /// [`RayData::hit_node`]. `AVX` is set only in code compiled for AVX2 and run where the CPU
    /// has it ([`Bvh::intersect`]).
    #[inline(always)]
    fn node_test<const H: usize, const AVX: bool>(&self, n: &Node<H>, tmax: f32) -> (u32, [Vec4; H]) {
        #[cfg(target_arch = "x86_64")]
        if AVX && H == 2 {
            // SAFETY: `H == 2`, so `n` is a `Node<2>`; the CPU has AVX2 and FMA (above).
            let (mask, t) = unsafe { self.hit_node8_avx(&*(n as *const Node<H>).cast::<Node<2>>(), tmax) };
            let mut tns = [Vec4::ZERO; H];
            for (out, t) in tns.iter_mut().zip(t) {
                *out = t;
            }
            return (mask, tns);
        }
        self.hit_node(n, tmax)
    }

    /// [`RayData::hit_node`] of a BVH8 node, its eight lanes in AVX registers: the same IEEE
    /// operations in the same order on each lane (`maxps`/`minps` operand order included), so
    /// the mask and the entry distances are bit-identical to the SSE version's.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn hit_node8_avx(&self, n: &Node<2>, tmax: f32) -> (u32, [Vec4; 2]) {
        use std::arch::x86_64::*;
        let [nx, ny, nz] = self.near;
        // a plane's eight lanes are the two `Vec4`s of `b[k]`, contiguous
        let plane = |k: usize| _mm256_loadu_ps(n.b[k].as_ptr().cast::<f32>());
        let (ox, oy, oz) = (_mm256_set1_ps(self.o[0].x), _mm256_set1_ps(self.o[1].x), _mm256_set1_ps(self.o[2].x));
        let (ix, iy, iz) = (_mm256_set1_ps(self.inv[0].x), _mm256_set1_ps(self.inv[1].x), _mm256_set1_ps(self.inv[2].x));
        let tnx = _mm256_mul_ps(_mm256_sub_ps(plane(nx), ox), ix);
        let tny = _mm256_mul_ps(_mm256_sub_ps(plane(ny), oy), iy);
        let tnz = _mm256_mul_ps(_mm256_sub_ps(plane(nz), oz), iz);
        let tfx = _mm256_mul_ps(_mm256_sub_ps(plane(nx ^ 1), ox), ix);
        let tfy = _mm256_mul_ps(_mm256_sub_ps(plane(ny ^ 1), oy), iy);
        let tfz = _mm256_mul_ps(_mm256_sub_ps(plane(nz ^ 1), oz), iz);
        let near = _mm256_max_ps(_mm256_max_ps(tnx, tny), _mm256_max_ps(tnz, _mm256_set1_ps(self.tmin)));
        let far = _mm256_min_ps(_mm256_min_ps(tfx, tfy), _mm256_min_ps(tfz, _mm256_set1_ps(tmax)));
        let tn = _mm256_mul_ps(near, _mm256_set1_ps(NEAR_SCALE));
        let tf = _mm256_mul_ps(far, _mm256_set1_ps(FAR_SCALE));
        let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OS>(tn, tf)) as u32;
        let mut out = [Vec4::ZERO; 2];
        _mm256_storeu_ps(out.as_mut_ptr().cast::<f32>(), tn);
        (mask, out)
    }

    /// Intersect four triangles: returns the lane mask of hits with `t` in `[tmin, tmax]`,
    /// `t`, and the unnormalised weights `V`, `W` of `p1`, `p2` with their sum `det`.
    #[inline(always)]
    fn hit_tri4(&self, tri: &Tri4, tmax: f32) -> (u32, Vec4, Vec4, Vec4, Vec4) {
        let [kx, ky, kz] = self.k;
        let [sx, sy, sz] = self.shear;
        // Vertex i relative to the origin, sheared: (x, y) in the ray's 2D frame, z along it.
        let project = |p: &[Vec4; 3]| {
            let z = p[kz] - self.o[kz];
            (p[kx] - self.o[kx] - sx * z, p[ky] - self.o[ky] - sy * z, z)
        };
        let (ax, ay, az) = project(&tri.p[0]);
        let (bx, by, bz) = project(&tri.p[1]);
        let (cx, cy, cz) = project(&tri.p[2]);
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        let zero = Vec4::ZERO;
        let mut exact_zero = (u.cmpeq(zero) | v.cmpeq(zero) | w.cmpeq(zero)).bitmask();
        if exact_zero != 0 {
            // Recompute those lanes in f64, where the products are exact (Woop et al. §4).
            let (ax, ay, bx, by, cx, cy) = (ax.to_array(), ay.to_array(), bx.to_array(), by.to_array(), cx.to_array(), cy.to_array());
            let (mut ua, mut va, mut wa) = (u.to_array(), v.to_array(), w.to_array());
            while exact_zero != 0 {
                let l = exact_zero.trailing_zeros() as usize;
                exact_zero &= exact_zero - 1;
                let f = |p: f32, q: f32, r: f32, s: f32| (p as f64 * q as f64 - r as f64 * s as f64) as f32;
                ua[l] = f(cx[l], by[l], cy[l], bx[l]);
                va[l] = f(ax[l], cy[l], ay[l], cx[l]);
                wa[l] = f(bx[l], ay[l], by[l], ax[l]);
            }
            (u, v, w) = (Vec4::from_array(ua), Vec4::from_array(va), Vec4::from_array(wa));
        }
        let neg = u.cmplt(zero) | v.cmplt(zero) | w.cmplt(zero);
        let pos = u.cmpgt(zero) | v.cmpgt(zero) | w.cmpgt(zero);
        let inside = !(neg & pos).bitmask() & 0xf;
        if inside == 0 {
            return (0, zero, zero, zero, zero);
        }
        let det = u + v + w;
        let t = (u * (sz * az) + v * (sz * bz) + w * (sz * cz)) / det;
        // NaN `t` (det == 0) fails both comparisons.
        let valid = t.cmpge(Vec4::splat(self.tmin)) & t.cmple(Vec4::splat(tmax)) & det.cmpne(zero);
        (inside & valid.bitmask(), t, v, w, det)
    }
}

/// Fixed-size traversal stack entry.
#[derive(Clone, Copy)]
struct StackItem {
    node: u32,
    t: f32,
}

/// Traversal stack (uninitialised storage; `sp` entries are valid).
struct Stack<const H: usize> {
    items: [MaybeUninit<StackItem>; STACK_SIZE],
    sp: usize,
}

impl<const H: usize> Stack<H> {
    #[inline(always)]
    fn new() -> Self {
        const { assert!(H == 1 || H == 2) };
        // SAFETY: an array of `MaybeUninit` needs no initialisation. (`[MaybeUninit::uninit(); N]`
        // makes rustc emit a memset of the whole array on every call.)
        Stack { items: unsafe { MaybeUninit::<[MaybeUninit<StackItem>; STACK_SIZE]>::uninit().assume_init() }, sp: 0 }
    }
    #[inline(always)]
    fn push(&mut self, it: StackItem) {
        self.items[self.sp].write(it);
        self.sp += 1;
    }
    #[inline(always)]
    fn pop(&mut self) -> Option<StackItem> {
        if self.sp == 0 {
            return None;
        }
        self.sp -= 1;
        // SAFETY: every entry below `sp` was written by `push`.
        Some(unsafe { self.items[self.sp].assume_init() })
    }

    /// Any-hit order (as Embree's occlusion traversal): push all hit children but the first
    /// (two or more), unsorted, and return the first.
    #[inline(always)]
    fn push_any(&mut self, node: &Node<H>, mask: u32, prefetch: impl Fn(u32)) -> u32 {
        let first = node.child(mask.trailing_zeros() as usize);
        let mut m = mask & (mask - 1);
        while m != 0 {
            let w = node.child(m.trailing_zeros() as usize);
            m &= m - 1;
            prefetch(w);
            self.push(StackItem { node: w, t: 0.0 });
        }
        first
    }

    /// Order the hit children (two or more) by entry distance, push all but the nearest
    /// (farthest first) and return the nearest.
    #[inline(always)]
    fn push_sorted(&mut self, node: &Node<H>, mask: u32, tn: &[Vec4; H], prefetch: impl Fn(u32)) -> u32 {
        let mut ta = [0.0f32; 8];
        for h in 0..H {
            ta[4 * h..4 * h + 4].copy_from_slice(&tn[h].to_array());
        }
        let mut items = [StackItem { node: 0, t: 0.0 }; 8];
        let mut n = 0;
        let mut m = mask;
        while m != 0 {
            let k = m.trailing_zeros() as usize;
            m &= m - 1;
            // Insertion sort, descending by t.
            let it = StackItem { node: node.child(k), t: ta[k] };
            let mut j = n;
            while j > 0 && items[j - 1].t < it.t {
                items[j] = items[j - 1];
                j -= 1;
            }
            items[j] = it;
            n += 1;
        }
        for it in &items[..n - 1] {
            prefetch(it.node);
            self.push(*it);
        }
        items[n - 1].node
    }
}

impl<const H: usize> Bvh<H> {
    /// Build from validated input (every index `< vertices.len()`, finite vertices).
    pub fn build(vertices: &[Vec3], triangles: &[[u32; 3]]) -> Self {
        let mut bvh = Bvh { nodes: Vec::new(), tris: Vec::new() };
        if triangles.is_empty() {
            return bvh;
        }
        let mut prims: Vec<PrimRef> = triangles
            .par_iter()
            .enumerate()
            .map(|(i, t)| {
                let [a, b, c] = t.map(|k| Vec3A::from(vertices[k as usize]));
                PrimRef { lo: a.min(b).min(c), hi: a.max(b).max(c), idx: i as u32 }
            })
            .collect();
        let (bounds, cbounds) = range_bounds(&prims);
        let root = build_inner(&mut prims, 0, bounds, cbounds, 0, 4 * H);
        bvh.tris.reserve(triangles.len() / 3);
        bvh.flatten(&root, &prims, vertices, triangles);
        bvh.nodes.shrink_to_fit();
        bvh.tris.shrink_to_fit();
        bvh
    }

    /// Number of nodes and of 4-triangle blocks (for stats and tests).
    pub fn counts(&self) -> (usize, usize) {
        (self.nodes.len(), self.tris.len())
    }

    fn flatten(&mut self, node: &BuildNode, prims: &[PrimRef], vertices: &[Vec3], triangles: &[[u32; 3]]) -> u32 {
        let BuildNode::Inner(children) = node else {
            unreachable!("flatten is called on inner nodes only");
        };
        let idx = self.nodes.len();
        self.nodes.push(Node::EMPTY);
        for (k, (bounds, child)) in children.iter().enumerate() {
            let word = match child {
                BuildNode::Leaf { start, count } => {
                    let first = self.tris.len() as u32;
                    for chunk in prims[*start..start + count].chunks(4) {
                        self.tris.push(make_tri4(chunk, vertices, triangles));
                    }
                    let nblocks = count.div_ceil(4) as u32;
                    LEAF_BIT | (first << 3) | (nblocks - 1)
                }
                BuildNode::Inner(_) => self.flatten(child, prims, vertices, triangles),
            };
            self.nodes[idx].set_child(k, bounds, word);
        }
        idx as u32
    }

    /// Hint the cache to load a child that was pushed on the stack (it is likely visited soon).
    #[inline(always)]
    fn prefetch(&self, word: u32) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            let (p, bytes) = if word & LEAF_BIT == 0 {
                (self.nodes.as_ptr().wrapping_add(word as usize) as *const i8, std::mem::size_of::<Node<H>>())
            } else {
                (self.tris.as_ptr().wrapping_add(((word & !LEAF_BIT) >> 3) as usize) as *const i8, std::mem::size_of::<Tri4>())
            };
            let mut off = 0;
            while off < bytes {
                // SAFETY: prefetching has no architectural effect, whatever the address.
                unsafe { _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(off)) };
                off += 64;
            }
        }
    }

    #[inline(always)]
    fn leaf_blocks(&self, word: u32) -> &[Tri4] {
        let first = ((word & !LEAF_BIT) >> 3) as usize;
        let count = (word & 7) as usize + 1;
        &self.tris[first..first + count]
    }

    /// Closest hit with `t` in `[ray.tmin, ray.tmax]`, at the kernel level of `crate::cpu`.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<TriHit> {
        #[cfg(target_arch = "x86_64")]
        if H == 2 && crate::cpu::level() == crate::cpu::KernelLevel::Avx2 {
            // SAFETY: the CPU has AVX2 and FMA (`cpu::level` never exceeds what it detects).
            return unsafe { self.intersect_avx2(ray) };
        }
        self.intersect_with::<false>(ray)
    }

    /// Whether any triangle is hit with `t` in `[ray.tmin, ray.tmax]`, at the kernel level of
    /// `crate::cpu`.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        #[cfg(target_arch = "x86_64")]
        if H == 2 && crate::cpu::level() == crate::cpu::KernelLevel::Avx2 {
            // SAFETY: as in `intersect`.
            return unsafe { self.occluded_avx2(ray) };
        }
        self.occluded_with::<false>(ray)
    }

    /// The traversals compiled for AVX2 (the whole loop, so that the box test inlines).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn intersect_avx2(&self, ray: &Ray) -> Option<TriHit> {
        self.intersect_with::<true>(ray)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn occluded_avx2(&self, ray: &Ray) -> bool {
        self.occluded_with::<true>(ray)
    }

    /// Closest hit (module docs, "Traversal"), the box test at level `AVX`.
    #[inline(always)]
    fn intersect_with<const AVX: bool>(&self, ray: &Ray) -> Option<TriHit> {
        if self.nodes.is_empty() || !(ray.tmin <= ray.tmax) {
            return None;
        }
        let r = RayData::new(ray);
        let mut tmax = ray.tmax;
        let mut hit: Option<TriHit> = None;
        let mut stack = Stack::<H>::new();
        let mut cur = 0u32;
        loop {
            if cur & LEAF_BIT == 0 {
                let node = &self.nodes[cur as usize];
                let (mask, tn) = r.node_test::<H, AVX>(node, tmax);
                if mask != 0 {
                    cur = if mask & (mask - 1) == 0 {
                        node.child(mask.trailing_zeros() as usize)
                    } else {
                        stack.push_sorted(node, mask, &tn, |w| self.prefetch(w))
                    };
                    continue;
                }
            } else {
                for tri in self.leaf_blocks(cur) {
                    let (mask, t, v, w, det) = r.hit_tri4(tri, tmax);
                    if mask != 0 {
                        let ta = t.to_array();
                        let mut lane = mask.trailing_zeros() as usize;
                        let mut m = mask & (mask - 1);
                        while m != 0 {
                            let l = m.trailing_zeros() as usize;
                            if ta[l] < ta[lane] {
                                lane = l;
                            }
                            m &= m - 1;
                        }
                        tmax = ta[lane];
                        let det = det.to_array()[lane];
                        hit = Some(TriHit { t: tmax, prim: tri.prim[lane], u: v.to_array()[lane] / det, v: w.to_array()[lane] / det });
                    }
                }
            }
            // Pop the next subtree that may still hold a closer hit.
            loop {
                match stack.pop() {
                    None => return hit,
                    Some(it) if it.t <= tmax => {
                        cur = it.node;
                        break;
                    }
                    Some(_) => {}
                }
            }
        }
    }

    /// Any hit (module docs, "Traversal"), the box test at level `AVX`.
    #[inline(always)]
    fn occluded_with<const AVX: bool>(&self, ray: &Ray) -> bool {
        if self.nodes.is_empty() || !(ray.tmin <= ray.tmax) {
            return false;
        }
        let r = RayData::new(ray);
        let tmax = ray.tmax;
        let mut stack = Stack::<H>::new();
        let mut cur = 0u32;
        loop {
            if cur & LEAF_BIT == 0 {
                let node = &self.nodes[cur as usize];
                let (mask, _) = r.node_test::<H, AVX>(node, tmax);
                if mask != 0 {
                    cur = if mask & (mask - 1) == 0 {
                        node.child(mask.trailing_zeros() as usize)
                    } else {
                        stack.push_any(node, mask, |w| self.prefetch(w))
                    };
                    continue;
                }
            } else {
                for tri in self.leaf_blocks(cur) {
                    if r.hit_tri4(tri, tmax).0 != 0 {
                        return true;
                    }
                }
            }
            match stack.pop() {
                None => return false,
                Some(it) => cur = it.node,
            }
        }
    }
}

#[cfg(test)]
mod tests;

fn make_tri4(chunk: &[PrimRef], vertices: &[Vec3], triangles: &[[u32; 3]]) -> Tri4 {
    let mut t = Tri4 { p: [[Vec4::ZERO; 3]; 3], prim: [0; 4] };
    for lane in 0..4 {
        let pr = &chunk[if lane < chunk.len() { lane } else { 0 }];
        let tri = triangles[pr.idx as usize];
        for (k, &vi) in tri.iter().enumerate() {
            let pk = vertices[vi as usize];
            t.p[k][0][lane] = pk.x;
            t.p[k][1][lane] = pk.y;
            t.p[k][2][lane] = pk.z;
        }
        t.prim[lane] = pr.idx;
    }
    t
}
