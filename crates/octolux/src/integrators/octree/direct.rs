//! A direct-light octree beside the global one, for a rasteriser (issue 28: `octolux view`
//! draws the direct light of the scene's emitters from it; the ray tracer computes direct light
//! with shadow rays and never reads it).
//!
//! The photon pass's first hits (`photon::trace::direct_photons`: the same paths as the
//! global map's, the hits neither map stores) gathered into an octree with the global tree's
//! settings and estimator, so the viewer evaluates it with the same GPU query. Its shadows and
//! highlights are as sharp as its leaves: a preview, not the render.

use super::{estimator_surfaces, BuildError, OctreeIntegrator};
use crate::caches::octree::Surfaces;
use crate::caches::{Estimator, Octree};
use crate::photon::trace::direct_photons;
use crate::scene::Scene;

impl OctreeIntegrator {
    /// The direct-light octree of `scene` (module docs), from the photon pass of these
    /// settings.
    pub fn direct_octree(&self, scene: &Scene) -> Result<Octree, BuildError> {
        let photons = direct_photons(scene, &self.settings.traced_photons())?;
        let (tris, spheres) =
            if self.settings.global.estimator == Estimator::GeometryArea { estimator_surfaces(scene) } else { (Vec::new(), Vec::new()) };
        Octree::build_with_surfaces(&photons, scene.bounds, &self.settings.global, Some(Surfaces { triangles: &tris, spheres: &spheres }))
            .map_err(BuildError::Global)
    }
}

#[cfg(test)]
mod tests {
    use crate::integrators::octree::{OctreeIntegrator, OctreeIntegratorSettings};
    use crate::integrators::test_scenes::sky_plane_scene;
    use glam::Vec3;
    use std::f32::consts::PI;

    #[test]
    fn the_direct_octree_holds_the_skys_irradiance_on_a_plane() {
        // a plane under a constant sky of radiance 2: irradiance 2π everywhere on it, all direct
        let scene = sky_plane_scene(0.5, 2.0);
        let mut s = OctreeIntegratorSettings::default();
        s.photons.photons = 200_000;
        let o = OctreeIntegrator::build(&scene, s).unwrap();
        let d = o.direct_octree(&scene).unwrap();
        assert!(d.stats().valid_leaves > 10, "{:?}", d.stats());
        let mut ratios = Vec::new();
        for (x, z) in [(0.0, 0.0), (10.0, -5.0), (-20.0, 15.0), (25.0, 25.0)] {
            let e = d.irradiance(Vec3::new(x, 1e-3, z), Vec3::Y).expect("a leaf on the plane");
            ratios.push(e.x / (2.0 * PI));
        }
        assert!(ratios.iter().all(|r| (0.9..1.1).contains(r)), "direct octree / 2π: {ratios:?}");
        // the global octree holds none of it (no photon bounces back to the plane)
        assert_eq!(o.global.stats().valid_leaves, 0);
    }
}
