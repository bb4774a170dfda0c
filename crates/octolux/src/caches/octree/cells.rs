//! Cell addressing shared by the octree's build, sort and query (paper §3): Morton keys of
//! quantised positions, the leaves under construction, and a read-only view of the node array
//! with the cells' geometry. A cell at depth `d` with integer coordinates `ijk` covers
//! `origin + ijk · size/2^d + [0, size/2^d)³` (half-open, so every point has one cell).

use super::settings::MAX_DEPTH;
use super::Node;
use glam::Vec3;

/// Spread the low 21 bits of `v` to every third bit.
#[inline]
pub(super) const fn spread_bits(v: u32) -> u64 {
    let mut x = (v as u64) & 0x1f_ffff;
    x = (x | (x << 32)) & 0x001f_0000_0000_ffff;
    x = (x | (x << 16)) & 0x001f_0000_ff00_00ff;
    x = (x | (x << 8)) & 0x100f_00f0_0f00_f00f;
    x = (x | (x << 4)) & 0x10c3_0c30_c30c_30c3;
    x = (x | (x << 2)) & 0x1249_2492_4924_9249;
    x
}

/// `spread_bits` of the 10-bit values.
static SPREAD10: [u32; 1024] = {
    let mut t = [0u32; 1024];
    let mut i = 0;
    while i < 1024 {
        t[i] = spread_bits(i as u32) as u32;
        i += 1;
    }
    t
};

/// Morton key of integer cell coordinates: bit 0 of each triple is x, bit 1 y, bit 2 z.
#[inline]
pub(super) fn morton(q: [u32; 3]) -> u64 {
    if (q[0] | q[1] | q[2]) < 1024 {
        (SPREAD10[q[0] as usize] | (SPREAD10[q[1] as usize] << 1) | (SPREAD10[q[2] as usize] << 2)) as u64
    } else {
        spread_bits(q[0]) | (spread_bits(q[1]) << 1) | (spread_bits(q[2]) << 2)
    }
}

/// Integer cell coordinates at depth `h` of a point inside the root cube (clamped to it).
#[inline]
pub(super) fn quantize(p: Vec3, origin: Vec3, inv_quant: f32, h: u32) -> [u32; 3] {
    let max = (1u32 << h) - 1;
    let q = (p - origin) * inv_quant;
    // `as` saturates (negative and NaN give 0)
    [(q.x as u32).min(max), (q.y as u32).min(max), (q.z as u32).min(max)]
}

/// A leaf during the build.
#[derive(Clone, Copy, Debug)]
pub(super) struct LeafBuild {
    pub node: u32,
    /// Photon range `[lo, hi)` in the sorted order.
    pub lo: u32,
    pub hi: u32,
    pub depth: u32,
    pub ijk: [u32; 3],
}

/// Read-only view of the node array with the cell geometry (shared by build and query).
#[derive(Clone, Copy)]
pub(super) struct TreeView<'a> {
    pub nodes: &'a [Node],
    pub origin: Vec3,
    pub cell_size: &'a [f32; MAX_DEPTH as usize + 1],
}

impl TreeView<'_> {
    #[inline]
    pub fn cell_min(&self, depth: u32, ijk: [u32; 3]) -> Vec3 {
        self.origin + Vec3::new(ijk[0] as f32, ijk[1] as f32, ijk[2] as f32) * self.cell_size[depth as usize]
    }

    /// Call `f(node, depth, ijk, overlap_volume)` for every leaf whose cell overlaps the box
    /// `[qmin, qmax]` with positive volume, in depth-first child order. Only children that
    /// overlap the box are entered (one comparison per axis against the node's centre).
    #[inline]
    pub fn visit<F: FnMut(u32, u32, [u32; 3], f32)>(&self, qmin: Vec3, qmax: Vec3, mut f: F) {
        let mut cmin = self.origin;
        let cmax = cmin + Vec3::splat(self.cell_size[0]);
        if !(qmin.cmplt(cmax).all() && qmax.cmpgt(cmin).all()) {
            return;
        }
        // descend without recursion while the box meets a single child (the common case for
        // a box much smaller than the root), then visit from there
        let (mut node, mut depth, mut ijk) = (0u32, 0u32, [0u32; 3]);
        loop {
            let n = self.nodes[node as usize];
            if n.is_leaf() {
                break;
            }
            let mid = self.cell_min(depth + 1, [2 * ijk[0] + 1, 2 * ijk[1] + 1, 2 * ijk[2] + 1]);
            let lo = qmin.cmplt(mid);
            let hi = qmax.cmpgt(mid);
            if (lo & hi).any() {
                break;
            }
            let b = [hi.x as u32, hi.y as u32, hi.z as u32];
            ijk = [2 * ijk[0] + b[0], 2 * ijk[1] + b[1], 2 * ijk[2] + b[2]];
            node = n.link + (b[0] | (b[1] << 1) | (b[2] << 2));
            depth += 1;
            cmin = self.cell_min(depth, ijk);
        }
        self.visit_rec(node, depth, ijk, cmin, qmin, qmax, &mut f);
    }

    /// Call `f(node, depth, ijk, w)` for every leaf whose tent reaches `p` (`w > 0`): the tent of
    /// a leaf of edge `s` and centre `c` is `w = Π_a max(0, 1 − |p_a − c_a| / s)`, a trilinear
    /// hat as wide as two cells, reaching half a cell past each face. Each leaf's weight is
    /// continuous in `p`, and the leaves found are all those whose tent is positive there, so
    /// any blend by these weights is continuous wherever its sum is positive (every point has
    /// its own leaf's tent, at least 1/8). A node is entered when `p` lies within half its edge
    /// of its cell: no leaf under it (no wider than it) reaches farther.
    pub fn visit_tents<F: FnMut(u32, u32, [u32; 3], f32)>(&self, p: Vec3, mut f: F) {
        let mut stack = [(0u32, 0u32, [0u32; 3]); 8 * (MAX_DEPTH as usize + 1)];
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let (node, depth, ijk) = stack[top];
            let s = self.cell_size[depth as usize];
            let c = self.cell_min(depth, ijk) + Vec3::splat(0.5 * s);
            let d = (p - c).abs() / s;
            if d.max_element() >= 1.0 {
                continue;
            }
            let n = self.nodes[node as usize];
            if n.is_leaf() {
                let w = (Vec3::ONE - d).element_product();
                if w > 0.0 {
                    f(node, depth, ijk, w);
                }
                continue;
            }
            for ch in (0..8u32).rev() {
                if top < stack.len() {
                    let b = [ch & 1, (ch >> 1) & 1, (ch >> 2) & 1];
                    stack[top] = (n.link + ch, depth + 1, [2 * ijk[0] + b[0], 2 * ijk[1] + b[1], 2 * ijk[2] + b[2]]);
                    top += 1;
                }
            }
        }
    }

    /// `cmin` = `cell_min(depth, ijk)`; the caller checked the positive overlap.
    #[allow(clippy::too_many_arguments)]
    fn visit_rec<F: FnMut(u32, u32, [u32; 3], f32)>(
        &self,
        node: u32,
        depth: u32,
        ijk: [u32; 3],
        cmin: Vec3,
        qmin: Vec3,
        qmax: Vec3,
        f: &mut F,
    ) {
        let n = self.nodes[node as usize];
        if n.is_leaf() {
            let cmax = cmin + Vec3::splat(self.cell_size[depth as usize]);
            let o = cmax.min(qmax) - cmin.max(qmin);
            f(node, depth, ijk, o.x * o.y * o.z);
            return;
        }
        // the centre, computed as the upper children's minimum corner
        let mid = self.cell_min(depth + 1, [2 * ijk[0] + 1, 2 * ijk[1] + 1, 2 * ijk[2] + 1]);
        // children overlapping the box: per axis, the lower half (bit clear) when the box
        // starts below the centre, the upper half (bit set) when it ends above it; one byte
        // mask per axis over the 8 children
        let lo = qmin.cmplt(mid).bitmask();
        let hi = qmax.cmpgt(mid).bitmask();
        const CLEAR: [u32; 3] = [0b0101_0101, 0b0011_0011, 0b0000_1111];
        let mut mask = 0xffu32;
        for (a, clear) in CLEAR.iter().enumerate() {
            let below = if (lo >> a) & 1 != 0 { *clear } else { 0 };
            let above = if (hi >> a) & 1 != 0 { !*clear & 0xff } else { 0 };
            mask &= below | above;
        }
        while mask != 0 {
            let c = mask.trailing_zeros();
            mask &= mask - 1;
            let b = [c & 1, (c >> 1) & 1, (c >> 2) & 1];
            let cijk = [2 * ijk[0] + b[0], 2 * ijk[1] + b[1], 2 * ijk[2] + b[2]];
            let ccmin = self.cell_min(depth + 1, cijk);
            self.visit_rec(n.link + c, depth + 1, cijk, ccmin, qmin, qmax, f);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_matches_a_bit_loop() {
        let naive = |q: [u32; 3]| {
            let mut k = 0u64;
            for b in 0..21 {
                for (a, qa) in q.iter().enumerate() {
                    k |= (((qa >> b) & 1) as u64) << (3 * b + a);
                }
            }
            k
        };
        let mut s = crate::sampling::Sampler::new(1, 2, 3);
        for _ in 0..10_000 {
            let q = [s.next_u32() & 0x1f_ffff, s.next_u32() & 0x1f_ffff, s.next_u32() & 0x1f_ffff];
            assert_eq!(morton(q), naive(q));
        }
        assert_eq!(morton([0x1f_ffff; 3]), (1u64 << 63) - 1);
    }
}
