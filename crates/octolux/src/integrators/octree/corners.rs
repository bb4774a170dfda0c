//! The `octree` integrator's corner-table query ([`QueryMode::Corners`]): the §7 blend
//! precomputed at the corners of each valid leaf, per query class, with the leak test's
//! verdicts decided from the leaf's own photons (`caches/octree/corners.rs`;
//! `docs/performance.md`, "The octree's query").
//!
//! Verdicts ([`LeakTest::VisibleSample`]): for leaf `L` and class `c` (the dominant half-axis of
//! the geometric normal on the query's side), the *origins* are `L`'s sampled photons whose
//! incident direction points to `c`'s side (`w · axis_c > 0`), lifted as the exact test lifts
//! its targets. A leaf `j` of `L`'s list is kept when an origin sees one of `j`'s lifted
//! photons (the exact test's rule, from the origin instead of the query point). When the
//! origins disagree about any `j`, or `L` has none on that side, there is no table and those
//! queries take the exact path. A query point uses the table only when it sees one of the
//! table's origins (from `L`'s planes when they tell, else one ray): a point on the other side of a
//! thin wall inside `L`, or hidden from the photons, takes the exact path.
//! With [`LeakTest::None`] every leaf is kept and every query uses the tables; with the other
//! leak tests the exact query is always used.

use super::leak::keep_sample_seen;
use super::reach::LeakData;
use super::{LeakTest, OctreeIntegrator, QueryMode, ANCHOR_LIFT};
use crate::caches::octree::{class_axis, query_class, CornerTable, CornerTables, Segment, Verdicts, QUERY_CLASSES};
use crate::caches::Octree;
use crate::scene::{Scene, SurfaceHit};
use glam::Vec3;

impl OctreeIntegrator {
    /// Whether this integrator's queries may use corner tables.
    #[inline]
    pub(super) fn uses_corners(&self) -> bool {
        self.settings.query == QueryMode::Corners
            && matches!(self.settings.leak, LeakTest::None | LeakTest::VisibleSample)
            && self.inserted.shapes.is_empty()
    }

    /// The corner tables of `tree` (one of this integrator's octrees), built at the first call.
    pub fn corners_of(&self, scene: &Scene, tree: &Octree) -> &CornerTables {
        let i = if std::ptr::eq(tree, &self.global) { 0 } else { 1 };
        self.corners[i].get_or_init(|| {
            let leak = self.settings.leak;
            let planes = (leak == LeakTest::VisibleSample).then(|| self.planes_of(scene, tree));
            let leaves = tree.valid_leaves();
            tree.corner_tables(leak != LeakTest::None, |v, class, list| verdicts(scene, planes, leaves, v, class, list, leak))
        })
    }

    /// The table a query at `hit` (normal `n` on the viewer's side) may use, with the point's
    /// position in the leaf's cell; `None`: the exact query. `rays` counts the rays cast.
    #[inline]
    pub fn corner_table<'a>(
        &'a self,
        scene: &Scene,
        tree: &'a Octree,
        hit: &SurfaceHit,
        n: Vec3,
        rays: &mut u64,
    ) -> Option<(&'a CornerTable, Vec3)> {
        if !n.is_finite() {
            return None; // the exact query answers it (with `None`)
        }
        let tables = self.corners_of(scene, tree);
        let (v, t) = tree.valid_leaf_at(hit.p)?;
        let ngf = crate::math::facing(hit.ng, n);
        let table = tables.get(v, query_class(ngf))?;
        if self.settings.leak == LeakTest::None {
            return Some((table, t));
        }
        let o = crate::math::offset_origin(hit.p, ngf, ngf);
        let planes = &self.planes_of(scene, tree).planes;
        let origins = &table.origins[..table.origins_len as usize];
        // an origin the leaf's planes show free from `o`; else a ray to the first one not
        // shown blocked
        let mut unknown = None;
        for &a in origins {
            match planes.segment(v, o, a) {
                Segment::Free => return Some((table, t)),
                Segment::Blocked => {}
                Segment::Unknown => {
                    unknown.get_or_insert(a);
                }
            }
        }
        let a = unknown?;
        *rays += 1;
        let seen = scene.sees(o, a, 0.0);
        seen.then_some((table, t))
    }
}

/// The verdicts of valid leaf `v` for query class `class` (see the module docs).
fn verdicts(
    scene: &Scene,
    planes: Option<&LeakData>,
    leaves: &[crate::caches::octree::QueryLeaf],
    v: u32,
    class: usize,
    list: &[u32],
    leak: LeakTest,
) -> Option<Verdicts> {
    if leak == LeakTest::None {
        // the same sums for every class: one table
        return Some(Verdicts { keep: vec![true; list.len()], origins: Vec::new() });
    }
    let q = &leaves[v as usize];
    let axis = class_axis(class);
    let lift = ANCHOR_LIFT * q.cell_size;
    let mut origins = [Vec3::ZERO; crate::caches::octree::ANCHOR_SAMPLES];
    let mut n_o = 0;
    for &(p, w) in &q.samples {
        if w.dot(axis) > 0.0 {
            origins[n_o] = p + w * lift;
            n_o += 1;
        }
    }
    if n_o == 0 {
        return None;
    }
    let mut rays = 0u64;
    let mut keep = Vec::with_capacity(list.len());
    for &j in list {
        let target = &leaves[j as usize];
        let first = keep_sample_seen(scene, planes, origins[0], target, &mut rays);
        for &o in &origins[1..n_o] {
            if keep_sample_seen(scene, planes, o, target, &mut rays) != first {
                return None;
            }
        }
        keep.push(first);
    }
    Some(Verdicts { keep, origins: origins[..n_o].to_vec() })
}

/// Classes are the six half-axes.
const _: () = assert!(QUERY_CLASSES == 6);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrators::octree::leak_tests::two_rooms;
    use crate::integrators::octree::{OctreeIntegratorSettings, OctreeView};
    use crate::integrators::test_scenes::{box_scene, check_furnace, furnace_box_scene, image_mean};
    use crate::integrators::{Integrator, RayCounters};
    use crate::math::Ray;
    use crate::render::{render, RenderSettings};
    use crate::sampling::Sampler;

    /// The first hits of `n` rays from `from` in random directions: (hit, normal on the ray's side).
    fn hits(scene: &Scene, from: Vec3, n: u64) -> Vec<(SurfaceHit, Vec3)> {
        (0..n)
            .filter_map(|i| {
                let mut s = Sampler::new(7, i, 0);
                let d = crate::sampling::square_to_uniform_sphere(s.next_2d());
                let hit = scene.intersect(&Ray::new(from, d))?;
                let n = crate::math::facing(hit.frame.n, -d);
                Some((hit, n))
            })
            .collect()
    }

    fn with(o: &OctreeIntegrator, query: QueryMode, leak: LeakTest) -> OctreeIntegrator {
        let mut p = o.to_parts();
        p.settings.query = query;
        p.settings.leak = leak;
        OctreeIntegrator::from_parts(p).unwrap()
    }

    /// In the furnace (a uniform field: every leaf holds the same light) the interpolated sums
    /// divide to the exact blend's value, so the render and the irradiance keep the octree's
    /// furnace bound (3%, `octree.rs`'s `furnace_is_analytic`), and the tables answer most
    /// queries (else this would test the exact path).
    #[test]
    fn corner_tables_keep_the_furnace() {
        let scene = furnace_box_scene(0.5, 1.0);
        let mut s = OctreeIntegratorSettings { query: QueryMode::Corners, ..Default::default() };
        s.photons.photons = 400_000;
        let o = OctreeIntegrator::build(&scene, s.clone()).unwrap();
        let pts = hits(&scene, Vec3::ZERO, 2000);
        let mut rays = 0;
        let tabled = pts.iter().filter(|(h, n)| o.corner_table(&scene, &o.global, h, *n, &mut rays).is_some()).count();
        assert!(tabled as f64 > 0.8 * pts.len() as f64, "{tabled} of {} queries with a table", pts.len());
        let mut means = Vec::new();
        for view in [OctreeView::Render, OctreeView::Irradiance] {
            let mut p = o.to_parts();
            p.settings.view = view;
            let oi = OctreeIntegrator::from_parts(p).unwrap();
            let (img, _) = render(&scene, &Integrator::Octree(Box::new(oi)), &RenderSettings { spp: 16, ..Default::default() }, &|_, _| {});
            means.push(image_mean(&img.data));
        }
        check_furnace(means[0], means[1], 0.03, "octree, corner tables");
    }

    /// In the test box the interpolated query stays close to the paper's blend at the same
    /// points, with and without the leak test: the mean of the irradiance over 3000 random
    /// surface points within 1%, and 90% of the points within 10%.
    #[test]
    fn corner_tables_follow_the_blend_in_a_box() {
        let scene = box_scene(8);
        let mut s = OctreeIntegratorSettings::default();
        s.photons.photons = 300_000;
        let o = OctreeIntegrator::build(&scene, s).unwrap();
        let pts = hits(&scene, Vec3::new(0.1, 1.1, 0.2), 3000);
        for leak in [LeakTest::None, LeakTest::VisibleSample] {
            let (exact, corners) = (with(&o, QueryMode::Blend, leak), with(&o, QueryMode::Corners, leak));
            let mut c = RayCounters::default();
            let (mut se, mut sc, mut close, mut n) = (0.0f64, 0.0f64, 0usize, 0usize);
            for (h, nn) in &pts {
                let e = exact.irradiance_at(&scene, &exact.global, h, *nn, &mut c).map_or(0.0, |e| e.element_sum() as f64);
                let k = corners.irradiance_at(&scene, &corners.global, h, *nn, &mut c).map_or(0.0, |e| e.element_sum() as f64);
                se += e;
                sc += k;
                n += 1;
                close += ((k - e).abs() <= 0.1 * e.abs().max(1e-6)) as usize;
            }
            eprintln!("{leak:?}: mean blend {:.4}, corners {:.4}, within 10%: {close} of {n}", se / n as f64, sc / n as f64);
            assert!((sc - se).abs() < 0.01 * se, "{leak:?}: mean {sc} against {se}");
            assert!(close as f64 >= 0.9 * n as f64, "{leak:?}: {close} of {n} within 10%");
        }
    }

    /// The thin-wall test of `octree_leak.rs` with the corner tables and the default leak
    /// test: at most 1% of the lit floor's irradiance on the dark side at every thickness. The
    /// leaf holding the wall has a table for the floor's class from its lit-side photons; the
    /// dark-side points in it must not use it (they do not see its photons) and take the
    /// exact path.
    #[test]
    fn corner_tables_do_not_leak_through_a_thin_wall() {
        use crate::caches::octree::Depth;
        let root = 2.0 * (1.0 + 2e-5);
        let s = root / 32.0;
        let x_lit = -1.0 - 1e-5 * 2.0 + (16.0 + 0.3) * s;
        let mut checked = 0;
        for t_leaves in [0.05f32, 0.25, 1.0] {
            let scene = two_rooms(x_lit, t_leaves * s);
            let mut st = OctreeIntegratorSettings { query: QueryMode::Corners, ..Default::default() };
            st.photons.photons = 200_000;
            st.global.h_max = Depth::Fixed(5);
            st.global.n_max = 100;
            st.global.n_min = 10;
            let o = OctreeIntegrator::build(&scene, st).unwrap();
            let mut c = RayCounters::default();
            let e = |p: Vec3, d: Vec3, c: &mut RayCounters| {
                let hit = scene.intersect(&Ray::new(p, d)).expect("closed rooms");
                let n = crate::math::facing(hit.frame.n, -d);
                o.irradiance_at(&scene, &o.global, &hit, n, c).map_or(0.0, |e| e.element_sum() as f64 / 3.0)
            };
            let lit: f64 = (0..8).map(|i| e(Vec3::new(-0.9 + 0.1 * i as f32, 0.5, 0.5), -Vec3::Y, &mut c)).sum::<f64>() / 8.0;
            let x_dark = x_lit + t_leaves * s;
            let (mut worst, mut tabled, mut exists, mut r) = (0.0f64, 0, 0, 0u64);
            for d in [0.1f32, 0.3, 0.6, 1.0, 1.5] {
                for z in [0.3f32, 0.5, 0.7] {
                    for dir in [-Vec3::Y, Vec3::Y] {
                        let p = Vec3::new(x_dark + d * s, 0.5, z);
                        worst = worst.max(e(p, dir, &mut c));
                        let hit = scene.intersect(&Ray::new(p, dir)).expect("closed rooms");
                        let n = crate::math::facing(hit.frame.n, -dir);
                        tabled += o.corner_table(&scene, &o.global, &hit, n, &mut r).is_some() as u32;
                        let class = query_class(crate::math::facing(hit.ng, n));
                        exists +=
                            o.global.valid_leaf_at(hit.p).is_some_and(|(v, _)| o.corners_of(&scene, &o.global).get(v, class).is_some())
                                as u32;
                    }
                }
            }
            eprintln!("thickness {t_leaves}: of 30 dark-side floor and ceiling queries, {exists} in a leaf with a table of their class, {tabled} used it");
            checked += exists - tabled;
            for y in [0.1f32, 0.5, 0.9] {
                worst = worst.max(e(Vec3::new(x_dark + 0.5, y, 0.5), -Vec3::X, &mut c));
            }
            eprintln!("thickness {t_leaves}: dark side {:.3}% of the lit floor ({lit:.3})", 100.0 * worst / lit);
            assert!(lit > 0.0 && worst <= 0.01 * lit, "thickness {t_leaves}: {:.2}% of the lit floor", 100.0 * worst / lit);
        }
        // the per-query check is what kept them out: dark-side points in leaves whose table
        // holds the lit side's light
        assert!(checked > 0, "no dark-side query met a table: the test does not exercise the check");
    }
}
