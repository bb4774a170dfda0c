//! Vertex normals, and the placement of an object-space mesh in a scene with the orientation
//! Mitsuba 3 gives it.
//!
//! Orientation. octolux decides the front of a triangle (the side an area light emits to, the
//! outside of a one-sided BSDF) from its winding normal, Mitsuba 3 from its shading normal
//! (`Frame3f::cos_theta(si.wi) > 0` in its `area` emitter and BSDFs). The two agree unless a
//! `to_world` with a negative determinant (a mirror) is applied to a mesh whose normals are
//! transformed rather than recomputed: a mirror reverses the winding normal
//! (`cof(M) n = det(M) M^-T n`) but not the transformed normal (`M^-T n`, Mitsuba's
//! `Transform * Normal3f`). Mitsuba 3 transforms
//! - the analytic normal of `rectangle` and `disk` (`m_frame.n = normalize(to_world * Normal3f(0, 0, 1))`
//!   in `rectangle.cpp`, `disk.cpp`) and the vertex normals of `cube`;
//! - the normals stored in `obj`, `ply` and `serialized` files;
//!
//! and recomputes (from the transformed winding, so a mirror flips them) the normals of meshes
//! stored without any. [`place_mesh`] follows these rules and, where the normals are
//! transformed and the determinant is negative, reverses the winding so that octolux's winding
//! normal is Mitsuba's shading normal. Spheres are not meshes: Mitsuba 3 turns a mirrored
//! sphere inside out (its normals point inward), which the loader expresses with the shape's
//! `flip_normals` (`mitsuba::shape`).

use glam::{Mat4, Vec2, Vec3};
use octolux::scene::TriMesh;

/// Angle-weighted smooth vertex normals (Thürmer & Wüthrich 1998, the scheme of Mitsuba's
/// `Mesh::recompute_vertex_normals`). Degenerate triangles contribute nothing; a vertex whose
/// weighted sum vanishes gets the normal of one of its triangles (or +z when it has none).
pub fn compute_vertex_normals(positions: &[Vec3], indices: &[[u32; 3]]) -> Vec<Vec3> {
    let mut acc = vec![Vec3::ZERO; positions.len()];
    let mut fallback = vec![Vec3::ZERO; positions.len()];
    for t in indices {
        let p = [positions[t[0] as usize], positions[t[1] as usize], positions[t[2] as usize]];
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        let len = n.length();
        if !len.is_finite() || len <= 0.0 {
            continue;
        }
        let n = n / len;
        for j in 0..3 {
            let e0 = (p[(j + 1) % 3] - p[j]).normalize_or_zero();
            let e1 = (p[(j + 2) % 3] - p[j]).normalize_or_zero();
            let angle = e0.dot(e1).clamp(-1.0, 1.0).acos();
            let v = t[j] as usize;
            acc[v] += n * angle;
            if fallback[v] == Vec3::ZERO {
                fallback[v] = n;
            }
        }
    }
    acc.iter()
        .zip(fallback)
        .map(|(a, f)| {
            let l = a.length();
            if l.is_finite() && l > 1e-30 {
                *a / l
            } else if f != Vec3::ZERO {
                f
            } else {
                Vec3::Z
            }
        })
        .collect()
}

/// Computed normals where `given` has none (or an unusable one); returns how many given normals
/// were unusable (zero length).
pub(super) fn merge_normals(positions: &[Vec3], indices: &[[u32; 3]], given: &[Option<Vec3>]) -> (Vec<Vec3>, usize) {
    let computed = compute_vertex_normals(positions, indices);
    let mut bad = 0;
    let normals = computed
        .into_iter()
        .zip(given)
        .map(|(c, g)| match g {
            Some(n) => {
                let m = n.normalize_or_zero();
                if m == Vec3::ZERO {
                    bad += 1;
                    c
                } else {
                    m
                }
            }
            None => c,
        })
        .collect();
    (normals, bad)
}

/// Where the shading normals of a mesh placed in a scene come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormalSource {
    /// Given in object space (stored in the file, or a shape's analytic normals) and
    /// transformed by the inverse transpose of `to_world`: a mirror does not flip them.
    Given,
    /// Computed in world space from the winding after the transform (Mitsuba 3's
    /// `recompute_vertex_normals` for a file without normals): a mirror flips them.
    Computed,
    /// None: the winding normal shades (`face_normals = true`).
    Face,
}

/// Transform an object-space mesh to world space and give it normals as Mitsuba 3 does (see
/// the module documentation); with [`NormalSource::Given`], `mesh.normals` must hold them.
pub fn place_mesh(mesh: &mut TriMesh, to_world: &Mat4, normals: NormalSource) {
    if normals != NormalSource::Given {
        mesh.normals = None;
    }
    mesh.transform(to_world);
    match normals {
        NormalSource::Given => orient_to_given_normals(mesh, to_world),
        NormalSource::Computed => mesh.normals = Some(compute_vertex_normals(&mesh.positions, &mesh.indices)),
        NormalSource::Face => {}
    }
}

/// For a mesh already transformed by `to_world` whose normals were transformed with it:
/// reverse the winding when `to_world` mirrors (negative determinant of its linear part), so
/// that the winding normal points to the side of the transformed normals.
pub fn orient_to_given_normals(mesh: &mut TriMesh, to_world: &Mat4) {
    if mirrors(to_world) {
        for t in &mut mesh.indices {
            t.swap(1, 2);
        }
    }
}

/// True when the linear part of `m` has a negative determinant (the transform mirrors).
pub fn mirrors(m: &Mat4) -> bool {
    glam::Mat3::from_mat4(*m).determinant() < 0.0
}

/// Mitsuba 0.6's `maxSmoothAngle` (`TriMesh::rebuildTopology`): vertices are merged by position
/// and texture coordinate, then split again so that the triangles sharing a vertex have face
/// normals within `max_angle_deg` of the first triangle of their group (a greedy clustering, in
/// triangle order); smooth normals are then computed on the new topology, so that creases
/// sharper than the angle stay sharp. Degenerate triangles have a zero face normal (they join a
/// group only when the angle exceeds 90°, or with other degenerate triangles).
pub fn rebuild_topology(mesh: &TriMesh, max_angle_deg: f32) -> TriMesh {
    let threshold = max_angle_deg.to_radians().cos();
    let key = |v: u32| {
        let p = mesh.positions[v as usize];
        let uv = mesh.uvs.as_ref().map_or(Vec2::ZERO, |t| t[v as usize]);
        [p.x.to_bits(), p.y.to_bits(), p.z.to_bits(), uv.x.to_bits(), uv.y.to_bits()]
    };
    let face_normals: Vec<Vec3> = mesh
        .indices
        .iter()
        .map(|t| {
            let p = |i: usize| mesh.positions[t[i] as usize];
            let n = (p(1) - p(0)).cross(p(2) - p(0));
            let l = n.length();
            if l.is_finite() && l > 1e-30 {
                n / l
            } else {
                Vec3::ZERO
            }
        })
        .collect();
    // Corners (triangle, corner) grouped by vertex key, groups in order of first appearance.
    let mut group_of: super::VertexMap<[u32; 5], usize> = super::VertexMap::default();
    let mut groups: Vec<Vec<(usize, usize)>> = Vec::new();
    for (t, tri) in mesh.indices.iter().enumerate() {
        for (c, &v) in tri.iter().enumerate() {
            let g = *group_of.entry(key(v)).or_insert_with(|| {
                groups.push(Vec::new());
                groups.len() - 1
            });
            groups[g].push((t, c));
        }
    }
    let mut out = TriMesh {
        positions: Vec::with_capacity(mesh.positions.len()),
        normals: None,
        uvs: mesh.uvs.as_ref().map(|_| Vec::with_capacity(mesh.positions.len())),
        indices: mesh.indices.clone(),
    };
    for corners in &groups {
        let mut clustered = vec![false; corners.len()];
        for i in 0..corners.len() {
            if clustered[i] {
                continue;
            }
            let (t1, c1) = corners[i];
            let v = mesh.indices[t1][c1];
            let id = out.positions.len() as u32;
            out.positions.push(mesh.positions[v as usize]);
            if let (Some(o), Some(s)) = (out.uvs.as_mut(), mesh.uvs.as_ref()) {
                o.push(s[v as usize]);
            }
            let n1 = face_normals[t1];
            for j in i..corners.len() {
                let (t2, c2) = corners[j];
                let n2 = face_normals[t2];
                if !clustered[j] && (n1 == n2 || n1.dot(n2) > threshold) {
                    out.indices[t2][c2] = id;
                    clustered[j] = true;
                }
            }
        }
    }
    out.normals = Some(compute_vertex_normals(&out.positions, &out.indices));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two triangles folded along the x axis by `angle` degrees, sharing the edge (0,0,0)-(1,0,0).
    fn fold(angle: f32) -> TriMesh {
        let (s, c) = angle.to_radians().sin_cos();
        TriMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(0.5, 1.0, 0.0), Vec3::new(0.5, -c, s)],
            normals: None,
            uvs: None,
            indices: vec![[0, 1, 2], [1, 0, 3]],
        }
    }

    #[test]
    fn a_crease_sharper_than_the_angle_is_split_and_a_softer_one_is_smoothed() {
        // The fold's dihedral angle between face normals is `angle`.
        let sharp = rebuild_topology(&fold(60.0), 30.0);
        assert_eq!(sharp.positions.len(), 6, "both shared vertices split");
        let n = sharp.normals.as_ref().unwrap();
        for (t, tri) in sharp.indices.iter().enumerate() {
            let p = |i: usize| sharp.positions[tri[i] as usize];
            let ng = (p(1) - p(0)).cross(p(2) - p(0)).normalize();
            for &v in tri {
                assert!(n[v as usize].dot(ng) > 0.9999, "triangle {t}: faceted normal expected");
            }
        }
        let soft = rebuild_topology(&fold(20.0), 30.0);
        assert_eq!(soft.positions.len(), 4, "shared vertices kept");
        let n = soft.normals.as_ref().unwrap();
        assert!(n[0].dot(n[1]) > 0.9999 && n[0].z > 0.05, "the shared edge gets the averaged normal");
    }

    #[test]
    fn mirrored_given_normals_keep_their_side_and_the_winding_follows() {
        let quad = || TriMesh {
            positions: vec![Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(-1.0, 1.0, 0.0)],
            normals: Some(vec![Vec3::Z; 4]),
            uvs: None,
            indices: vec![[0, 1, 2], [2, 3, 0]],
        };
        let winding = |m: &TriMesh| {
            let t = m.indices[0];
            let p = |i: usize| m.positions[t[i] as usize];
            (p(1) - p(0)).cross(p(2) - p(0)).normalize()
        };
        // A mirror through the xz plane (y -> -y): Mitsuba's normal M^-T z stays +z.
        let mirror = Mat4::from_scale(Vec3::new(1.0, -1.0, 1.0));
        for source in [NormalSource::Given, NormalSource::Computed, NormalSource::Face] {
            let mut m = quad();
            place_mesh(&mut m, &mirror, source);
            let w = winding(&m);
            match source {
                NormalSource::Given => {
                    assert!((w - Vec3::Z).length() < 1e-6, "{w}");
                    assert!(m.normals.as_ref().unwrap().iter().all(|n| (*n - Vec3::Z).length() < 1e-6));
                }
                // Recomputed from the mirrored winding, as Mitsuba 3 does: both flip together.
                NormalSource::Computed => {
                    assert!((w + Vec3::Z).length() < 1e-6, "{w}");
                    assert!(m.normals.as_ref().unwrap().iter().all(|n| (*n + Vec3::Z).length() < 1e-6));
                }
                NormalSource::Face => {
                    assert!((w + Vec3::Z).length() < 1e-6, "{w}");
                    assert!(m.normals.is_none());
                }
            }
        }
        // Without a mirror nothing is reversed.
        let mut m = quad();
        place_mesh(&mut m, &Mat4::from_scale(Vec3::new(2.0, 3.0, 1.0)), NormalSource::Given);
        assert!((winding(&m) - Vec3::Z).length() < 1e-6);
    }
}
