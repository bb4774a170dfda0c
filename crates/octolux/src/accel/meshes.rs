//! Procedural triangle meshes for the intersection tests and the `rays` benchmark (this crate
//! parses no mesh files). Not used by the renderer.
//!
//! All meshes are indexed; closed meshes share vertices along edges (so they are watertight for
//! a watertight ray/triangle test) and are wound counter-clockwise seen from outside, i.e. the
//! geometric normal `(p1-p0)×(p2-p0)` points out.

use crate::sampling::Sampler;
use glam::Vec3;
use std::collections::HashMap;

/// An indexed triangle mesh.
#[derive(Clone, Debug, Default)]
pub struct MeshData {
    pub vertices: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
}

impl MeshData {
    /// Append another mesh (indices are rebased).
    pub fn append(&mut self, o: &MeshData) {
        let base = self.vertices.len() as u32;
        self.vertices.extend_from_slice(&o.vertices);
        self.triangles.extend(o.triangles.iter().map(|t| t.map(|i| i + base)));
    }

    /// Corners of triangle `i`.
    pub fn corners(&self, i: usize) -> [Vec3; 3] {
        self.triangles[i].map(|k| self.vertices[k as usize])
    }

    /// Add a quad `a b c d` (counter-clockwise seen from the side the normal points to).
    pub fn quad(&mut self, a: Vec3, b: Vec3, c: Vec3, d: Vec3) {
        let base = self.vertices.len() as u32;
        self.vertices.extend([a, b, c, d]);
        self.triangles.push([base, base + 1, base + 2]);
        self.triangles.push([base, base + 2, base + 3]);
    }
}

/// Unit icosphere with `20 * 4^level` triangles, closed and outward-wound.
pub fn icosphere(level: u32) -> MeshData {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut vertices: Vec<Vec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::with_capacity(triangles.len() * 2);
        let mut next = Vec::with_capacity(triangles.len() * 4);
        let mut midpoint = |a: u32, b: u32, vertices: &mut Vec<Vec3>| -> u32 {
            let key = (a.min(b), a.max(b));
            *mid.entry(key).or_insert_with(|| {
                vertices.push(((vertices[a as usize] + vertices[b as usize]) * 0.5).normalize());
                vertices.len() as u32 - 1
            })
        };
        for &[a, b, c] in &triangles {
            let ab = midpoint(a, b, &mut vertices);
            let bc = midpoint(b, c, &mut vertices);
            let ca = midpoint(c, a, &mut vertices);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    MeshData { vertices, triangles }
}

/// Icosphere with a bumpy radial displacement `radius * (1 + amp * bumps(dir))`, moved to
/// `center`. Still closed (vertices are displaced, never duplicated).
pub fn displaced_icosphere(level: u32, center: Vec3, radius: f32, amp: f32, seed: u64) -> MeshData {
    let mut m = icosphere(level);
    let mut s = Sampler::new(seed, 0, 0);
    // A sum of a few random "waves" along random directions.
    let waves: Vec<(Vec3, f32, f32)> = (0..6)
        .map(|_| {
            let d = crate::sampling::square_to_uniform_sphere(s.next_2d());
            (d, 3.0 + 20.0 * s.next_1d(), std::f32::consts::TAU * s.next_1d())
        })
        .collect();
    for p in &mut m.vertices {
        let bump: f32 = waves.iter().map(|(d, f, ph)| (d.dot(*p) * f + ph).sin()).sum::<f32>() / waves.len() as f32;
        *p = center + *p * radius * (1.0 + amp * bump);
    }
    m
}

/// Axis-aligned box, closed, 12 triangles. `inward` flips the winding (normals point in).
pub fn box_mesh(lo: Vec3, hi: Vec3, inward: bool) -> MeshData {
    let c = |i: u32| {
        Vec3::new(if i & 1 != 0 { hi.x } else { lo.x }, if i & 2 != 0 { hi.y } else { lo.y }, if i & 4 != 0 { hi.z } else { lo.z })
    };
    let vertices = (0..8).map(c).collect();
    // Outward-wound faces as quads of corner indices.
    let faces = [[0u32, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let mut triangles = Vec::with_capacity(12);
    for [a, b, cc, d] in faces {
        if inward {
            triangles.push([a, cc, b]);
            triangles.push([a, d, cc]);
        } else {
            triangles.push([a, b, cc]);
            triangles.push([a, cc, d]);
        }
    }
    MeshData { vertices, triangles }
}

/// A Cornell-box-like scene (≈ 34 triangles): open-front room of size 2 (y up, camera looking
/// down -z from z = +3.9 at y = 1), a small light quad below the ceiling, two rotated boxes.
pub fn cornell_box() -> MeshData {
    let mut m = MeshData::default();
    let v = Vec3::new;
    // Floor, ceiling, back, left, right walls (normals pointing into the room).
    m.quad(v(-1.0, 0.0, -1.0), v(-1.0, 0.0, 1.0), v(1.0, 0.0, 1.0), v(1.0, 0.0, -1.0));
    m.quad(v(-1.0, 2.0, -1.0), v(1.0, 2.0, -1.0), v(1.0, 2.0, 1.0), v(-1.0, 2.0, 1.0));
    m.quad(v(-1.0, 0.0, -1.0), v(1.0, 0.0, -1.0), v(1.0, 2.0, -1.0), v(-1.0, 2.0, -1.0));
    m.quad(v(-1.0, 0.0, -1.0), v(-1.0, 2.0, -1.0), v(-1.0, 2.0, 1.0), v(-1.0, 0.0, 1.0));
    m.quad(v(1.0, 0.0, -1.0), v(1.0, 0.0, 1.0), v(1.0, 2.0, 1.0), v(1.0, 2.0, -1.0));
    // Light, facing down.
    m.quad(v(-0.25, 1.98, -0.25), v(0.25, 1.98, -0.25), v(0.25, 1.98, 0.25), v(-0.25, 1.98, 0.25));
    for (center, half, angle) in [(v(0.35, 0.3, 0.35), v(0.3, 0.3, 0.3), -0.3f32), (v(-0.35, 0.6, -0.3), v(0.3, 0.6, 0.3), 0.3)] {
        let mut b = box_mesh(-half, half, false);
        let (s, c) = angle.sin_cos();
        for p in &mut b.vertices {
            *p = center + v(c * p.x + s * p.z, p.y, -s * p.x + c * p.z);
        }
        m.append(&b);
    }
    m
}

/// `n` random triangles with edges up to `size` inside the unit cube.
pub fn triangle_soup(n: usize, size: f32, seed: u64) -> MeshData {
    let mut s = Sampler::new(seed, 1, 0);
    let mut m = MeshData::default();
    for i in 0..n {
        let c = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d());
        for _ in 0..3 {
            let d = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) - 0.5;
            m.vertices.push(c + d * size);
        }
        let b = 3 * i as u32;
        m.triangles.push([b, b + 1, b + 2]);
    }
    m
}

/// The benchmark scene: three displaced icospheres of `20 * 4^level` triangles each inside an
/// inward-facing box room (level 7: 983 052 triangles).
pub fn spheres_in_room(level: u32) -> MeshData {
    let mut m = box_mesh(Vec3::new(-4.0, -1.5, -4.0), Vec3::new(4.0, 4.0, 4.0), true);
    let spheres = [(Vec3::new(-1.6, 0.0, 0.0), 1.0, 11u64), (Vec3::new(1.3, 0.3, -0.5), 1.3, 12), (Vec3::new(0.0, 0.2, 1.8), 0.8, 13)];
    for (c, r, seed) in spheres {
        m.append(&displaced_icosphere(level, c, r, 0.08, seed));
    }
    m
}
