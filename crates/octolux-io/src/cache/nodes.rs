//! The node array of a cache file since format version 7 (issue 26, item 3: compact leaves).
//! The build lays the nodes out so that each node's kind fixes the whole array
//! (`octolux::caches::octree` `parts.rs`: an internal node's 8 children are allocated together,
//! depth-first; the valid leaves take the value indices 0, 1, 2, ... in depth-first order; an
//! internal node holds the sum of its children's photons). The file stores only:
//!
//! ```text
//! node count u32, kinds (2 bits per node in array order, 4 per byte, low bits first:
//!   0 internal, 1 valid leaf, 2 atmospheric leaf),
//! u32 length + the valid leaves' photon counts as LEB128 varints, in value order
//! ```
//!
//! and [`get_nodes`] replays the build's allocation to give back `[link, photons]` per node.
//! On the cornell-box at 1M photons: 11 697 nodes in 3.0 KB of kinds and 9.9 KB of counts,
//! against 93.6 KB as two u32 per node (format 6).

use super::Reader;
use octolux::caches::octree::{ATMOSPHERIC, LEAF_LINK};

const INTERNAL: u8 = 0;
const VALID: u8 = 1;
const EMPTY: u8 = 2;

fn kind(link: u32) -> u8 {
    match link {
        l if l & LEAF_LINK == 0 => INTERNAL,
        l if l == LEAF_LINK | ATMOSPHERIC => EMPTY,
        _ => VALID,
    }
}

fn put_varint(out: &mut Vec<u8>, mut v: u32) {
    while v >= 0x80 {
        out.push((v as u8 & 0x7f) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

/// Append the nodes (module docs). The photon counts are those of the valid leaves met
/// depth-first from the root, the order of their value indices in a built tree.
pub(super) fn put_nodes(out: &mut Vec<u8>, nodes: &[[u32; 2]]) {
    super::put_u32(out, super::count(nodes.len()));
    let mut packed = vec![0u8; nodes.len().div_ceil(4)];
    for (i, n) in nodes.iter().enumerate() {
        packed[i / 4] |= kind(n[0]) << (2 * (i % 4));
    }
    out.extend_from_slice(&packed);
    let mut counts = Vec::new();
    for_each_leaf(nodes, |k, photons| {
        if k == VALID {
            put_varint(&mut counts, photons);
        }
    });
    super::put_u32(out, super::count(counts.len()));
    out.extend_from_slice(&counts);
}

/// Read the nodes (module docs) back as `[link, photons]`. Everything the layout implies is
/// checked here (the count against the bytes left and the memory budget, every kind, children
/// inside the array, every node reached, every count read, no sum past `u32`); the tree's other
/// invariants are `Octree::from_parts`'s to check.
pub(super) fn get_nodes(r: &mut Reader, what: &dyn Fn(&str) -> String) -> Result<Vec<[u32; 2]>, String> {
    let n = r.u32(&what("node count"))? as usize;
    if n == 0 || n.div_ceil(4) > r.left() {
        return Err(what(&format!("{n} nodes announced, {} bytes left", r.left())));
    }
    octolux::budget::check_items(|| what(&format!("{n} nodes")), n as u64, 8).map_err(|e| e.to_string())?;
    let packed = r.take(n.div_ceil(4), &what("node kinds"))?;
    let kind_of = |i: usize| (packed[i / 4] >> (2 * (i % 4))) & 3;
    let (_, counts) = r.array(1, &what("photon counts"))?;
    let mut at = 0usize;
    let mut varint = || -> Result<u32, String> {
        let mut v = 0u64;
        for shift in (0..35).step_by(7) {
            let b = *counts.get(at).ok_or_else(|| what("photon counts: fewer than the valid leaves"))?;
            at += 1;
            v |= ((b & 0x7f) as u64) << shift;
            if b & 0x80 == 0 {
                return u32::try_from(v).map_err(|_| what(&format!("photon count {v} past u32")));
            }
        }
        Err(what("photon counts: a varint longer than 5 bytes"))
    };
    let mut nodes = vec![[0u32; 2]; n];
    let (mut next, mut value) = (1usize, 0u32);
    let mut stack = vec![0usize];
    while let Some(id) = stack.pop() {
        nodes[id] = match kind_of(id) {
            INTERNAL => {
                if next + 8 > n {
                    return Err(what(&format!("node {id}: its children would lie past the {n} nodes")));
                }
                stack.extend((0..8).rev().map(|c| next + c));
                next += 8;
                [(next - 8) as u32, 0]
            }
            VALID => {
                let v = value;
                value += 1;
                [LEAF_LINK | v, varint()?]
            }
            EMPTY => [LEAF_LINK | ATMOSPHERIC, 0],
            k => return Err(what(&format!("node {id}: kind {k} (0 internal, 1 valid leaf, 2 atmospheric leaf)"))),
        };
    }
    if next != n {
        return Err(what(&format!("{n} nodes, the tree reaches {next}")));
    }
    if at != counts.len() {
        return Err(what(&format!("{} bytes of photon counts left over", counts.len() - at)));
    }
    // children lie after their parent: sums from the last node back
    for id in (0..n).rev() {
        let [link, _] = nodes[id];
        if link & LEAF_LINK == 0 {
            let first = link as usize;
            let sum: u64 = nodes[first..first + 8].iter().map(|c| c[1] as u64).sum();
            nodes[id][1] = u32::try_from(sum).map_err(|_| what(&format!("node {id}: {sum} photons, past u32")))?;
        }
    }
    Ok(nodes)
}

/// Per leaf, in depth-first order (the order of the atmosphere's filled bits): whether it is
/// atmospheric. `nodes` as [`get_nodes`] returns them (or a tree's own, laid out the same way).
pub(super) fn atmospheric_leaves(nodes: &[[u32; 2]]) -> Vec<bool> {
    let mut out = Vec::new();
    for_each_leaf(nodes, |k, _| out.push(k == EMPTY));
    out
}

/// Call `f(kind, photons)` for every leaf, depth-first from the root, children in order.
fn for_each_leaf(nodes: &[[u32; 2]], mut f: impl FnMut(u8, u32)) {
    let mut stack = vec![0usize];
    while let Some(id) = stack.pop() {
        let Some(&[link, photons]) = nodes.get(id) else { continue };
        match kind(link) {
            INTERNAL => stack.extend((0..8).rev().map(|c| link as usize + c)),
            k => f(k, photons),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn round_trip(nodes: &[[u32; 2]]) -> Result<Vec<[u32; 2]>, String> {
        let mut out = Vec::new();
        put_nodes(&mut out, nodes);
        let mut r = Reader { data: &out, at: 0 };
        let back = get_nodes(&mut r, &|w: &str| w.to_string())?;
        assert_eq!(r.left(), 0);
        Ok(back)
    }

    #[test]
    fn a_tree_comes_back_node_for_node() {
        // root with 8 children; child 2 split again (children at 9..17)
        let mut nodes = vec![[1, 0]];
        let leaf = |v: u32, p: u32| [LEAF_LINK | v, p];
        let empty = [LEAF_LINK | ATMOSPHERIC, 0];
        let first: Vec<[u32; 2]> = vec![leaf(0, 5), empty, [9, 0], leaf(3, 200), empty, empty, leaf(4, 1 << 20), leaf(5, 1)];
        nodes.extend(first);
        nodes.extend([leaf(1, 127), leaf(2, 128), empty, empty, empty, empty, empty, empty]);
        nodes[3][1] = 255;
        nodes[0][1] = 5 + 255 + 200 + (1 << 20) + 1;
        assert_eq!(round_trip(&nodes).unwrap(), nodes);
    }

    /// `n` nodes of the packed `kinds` and no photon count: the reader's error.
    fn refused(n: u32, kinds: &[u8]) -> String {
        let mut out = Vec::new();
        super::super::put_u32(&mut out, n);
        out.extend_from_slice(kinds);
        super::super::put_u32(&mut out, 0);
        let mut r = Reader { data: &out, at: 0 };
        get_nodes(&mut r, &|w: &str| w.to_string()).unwrap_err()
    }

    #[test]
    fn a_layout_the_build_cannot_make_is_refused() {
        // root and all its children internal: children past the end
        assert!(refused(9, &[0, 0, 0]).contains("past"));
        assert!(refused(1, &[3]).contains("kind 3"));
        assert!(refused(1, &[1]).contains("fewer"));
    }
}
