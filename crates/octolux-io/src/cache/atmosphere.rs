//! A tree's volumetric values in a cache file (`bake --volume`; `octolux::caches::octree`
//! `atmosphere.rs`, docs/guide/baking.md, "A volumetric solution"):
//!
//! ```text
//! atmosphere u8 (0: none, 1: present), then if present:
//!   filled count u32, filled bits (one byte per leaf, depth-first),
//!   storage u8 (0 compressed, 1 full), entry count u32 (leaves with any filled bit),
//!   per entry its matrices as the leaves' values (36 bytes or 54 f32); compressed, an
//!   atmospheric leaf with all six bits as its free-space SH block (28 bytes, version 8),
//!   anchor count u32 (0 or the entry count), per entry where its flights pass in its cell
//!   (3 x u8; 255, 255, 255: none; version 9)
//! ```

use super::{count, full_leaves, nodes, put_u32, put_values, Reader, FULL_LEAF_BYTES};
use octolux::caches::octree::compress::LEAF_BYTES;
use octolux::caches::octree::{AtmosphereParts, LeafValueParts, OctreeParts, FREE_SPACE_BYTES};

/// Per atmosphere entry (a leaf with any filled bit, depth-first): whether it is an atmospheric
/// leaf with all six filled, which a compressed tree stores as free-space SH coefficients
/// (`FREE_SPACE_BYTES` of its block; `caches::octree` `atmosphere.rs`).
fn free_space_entries(nodes: &[[u32; 2]], filled: &[u8]) -> Vec<bool> {
    nodes::atmospheric_leaves(nodes).into_iter().zip(filled).filter(|(_, &f)| f != 0).map(|(atm, &f)| atm && f == 0x3f).collect()
}

/// Write `t`'s volumetric values (the flag, then the values if any).
pub(super) fn put_atmosphere(out: &mut Vec<u8>, t: &OctreeParts) {
    match &t.atmosphere {
        None => out.push(0),
        Some(a) => {
            out.push(1);
            put_u32(out, count(a.filled.len()));
            out.extend_from_slice(&a.filled);
            match &a.values {
                LeafValueParts::Compressed(v) => {
                    out.push(0);
                    put_u32(out, count(v.len()));
                    for (l, free) in v.iter().zip(free_space_entries(&t.nodes, &a.filled)) {
                        out.extend_from_slice(if free { &l[..FREE_SPACE_BYTES] } else { &l[..] });
                    }
                }
                full => put_values(out, full),
            }
            put_u32(out, count(a.anchors.len()));
            a.anchors.iter().for_each(|q| out.extend_from_slice(q));
        }
    }
}

/// Read a tree's volumetric values (`nodes`: the tree's, read before them; `what` names the
/// part in an error).
pub(super) fn get_atmosphere(r: &mut Reader, nodes: &[[u32; 2]], what: &dyn Fn(&str) -> String) -> Result<Option<AtmosphereParts>, String> {
    Ok(match r.u8(&what("atmosphere"))? {
        0 => None,
        1 => {
            let (_, filled) = r.array(1, &what("atmosphere bits"))?;
            let values = match r.u8(&what("atmosphere storage"))? {
                0 => {
                    // a free-space entry's block without its zero tail (`FREE_SPACE_BYTES`)
                    let free = free_space_entries(nodes, filled);
                    let n = r.u32(&what("atmosphere entry count"))? as usize;
                    if n != free.len() {
                        return Err(what(&format!("{n} atmosphere entries, the filled bits give {}", free.len())));
                    }
                    let size = |f: &bool| if *f { FREE_SPACE_BYTES } else { LEAF_BYTES };
                    let b = r.take(free.iter().map(size).sum(), &what("atmosphere compressed leaves"))?;
                    let mut at = 0;
                    let blocks = free
                        .iter()
                        .map(|f| {
                            let mut l = [0u8; LEAF_BYTES];
                            l[..size(f)].copy_from_slice(&b[at..at + size(f)]);
                            at += size(f);
                            l
                        })
                        .collect();
                    LeafValueParts::Compressed(blocks)
                }
                1 => {
                    let (_, b) = r.array(FULL_LEAF_BYTES, &what("atmosphere full leaves"))?;
                    full_leaves(b)
                }
                s => return Err(what(&format!("atmosphere storage: unknown storage {s} (0: compressed, 1: full)"))),
            };
            let (n, b) = r.array(3, &what("atmosphere anchors"))?;
            if n != 0 && n != values.len() {
                return Err(what(&format!("{n} atmosphere anchors for {} entries", values.len())));
            }
            let anchors = b.chunks_exact(3).map(|q| [q[0], q[1], q[2]]).collect();
            Some(AtmosphereParts { filled: filled.to_vec(), values, anchors })
        }
        a => return Err(what(&format!("atmosphere flag {a} (0: none, 1: present)"))),
    })
}
