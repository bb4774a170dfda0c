//! The `octree` integrator's debug views ([`OctreeView`]): the irradiance the octrees hold at
//! the first vertex with a non-delta lobe after a specular chain from the camera (the paper's
//! fig. 2), and the global octree's leaves as colours.

use super::{OctreeIntegrator, OctreeView, Tree, MAX_SPECULAR_CHAIN};
use crate::integrators::common::{facing, walk_specular, RayCounters, Vertex};
use crate::math::{Color, Ray, RayDifferential};
use crate::sampling::Sampler;
use crate::scene::{Scene, SurfaceHit};
use glam::Vec3;

impl OctreeIntegrator {
    /// The image of a debug view along a primary ray (not [`OctreeView::Render`]).
    pub(super) fn view(
        &self,
        view: OctreeView,
        scene: &Scene,
        ray: Ray,
        diff: Option<&RayDifferential>,
        sampler: &mut Sampler,
        counters: &mut RayCounters,
    ) -> Color {
        if view == OctreeView::Leaves {
            counters.rays += 1;
            return scene.intersect(&ray).map_or(Color::ZERO, |hit| self.leaf_colour(&hit, ray.d));
        }
        let max_depth = if self.settings.max_depth < 0 { MAX_SPECULAR_CHAIN } else { self.settings.max_depth as u32 };
        let walk = walk_specular(scene, ray, diff, max_depth, false, sampler, counters);
        let Some(v) = walk.vertex else { return Color::ZERO };
        let mut e = self.irradiance(scene, Tree::Global, &v, counters);
        if view == OctreeView::IrradianceAll {
            e += self.irradiance(scene, Tree::Caustic, &v, counters);
        }
        v.throughput * e.max(Color::ZERO)
    }

    /// Irradiance `M(N)ᵀ N` from `tree` at a vertex (normal on the viewer's side), W/m².
    fn irradiance(&self, scene: &Scene, tree: Tree, v: &Vertex, counters: &mut RayCounters) -> Color {
        self.incident_matrix(scene, tree, &v.hit, v.n, counters).map_or(Color::ZERO, |m| m.transpose() * v.n)
    }

    fn leaf_colour(&self, hit: &SurfaceHit, d: Vec3) -> Color {
        let Some(leaf) = self.global.leaf_at(hit.p) else { return Color::ZERO };
        if !leaf.valid {
            return Color::splat(0.02);
        }
        let h_max = self.global.h_max().max(1) as f32;
        let hue = leaf.depth as f32 / h_max;
        let base = hsv(hue * 0.8, 0.7, 0.9);
        // Darken near cell borders (in units of the cell edge).
        let e = leaf.bounds.extent().x.max(1e-12);
        let rel = ((hit.p - leaf.bounds.min) / e).clamp(Vec3::ZERO, Vec3::ONE);
        let edge = rel.min(Vec3::ONE - rel);
        // Ignore the axis the surface is flat along (the one most aligned with the normal).
        let n = facing(hit.frame.n, -d).abs();
        let dist = if n.x >= n.y && n.x >= n.z {
            edge.y.min(edge.z)
        } else if n.y >= n.z {
            edge.x.min(edge.z)
        } else {
            edge.x.min(edge.y)
        };
        if dist < 0.02 {
            base * 0.15
        } else {
            base
        }
    }
}

fn hsv(h: f32, s: f32, v: f32) -> Color {
    let h6 = (h.fract() * 6.0).max(0.0);
    let i = h6.floor() as i32;
    let f = h6 - i as f32;
    let (p, q, t) = (v * (1.0 - s), v * (1.0 - s * f), v * (1.0 - s * (1.0 - f)));
    match i % 6 {
        0 => Color::new(v, t, p),
        1 => Color::new(q, v, p),
        2 => Color::new(p, v, t),
        3 => Color::new(p, q, v),
        4 => Color::new(t, p, v),
        _ => Color::new(v, p, q),
    }
}
