//! Photons for the tests of this module: on the floor and two walls of a unit box.

use crate::photon::Photon;
use crate::sampling::{square_to_uniform_sphere, Sampler};
use glam::Vec3;

/// `n` photons on the floor and walls of the unit box, lit from above, from the random
/// numbers of `seed`.
pub(super) fn box_photons(n: usize, seed: u64) -> Vec<Photon> {
    let mut s = Sampler::new(seed, 0, 0);
    (0..n)
        .map(|i| {
            let (u, v) = (s.next_1d(), s.next_1d());
            let (p, ng) = match i % 3 {
                0 => (Vec3::new(u, 0.0, v), Vec3::Y),
                1 => (Vec3::new(0.0, u, v), Vec3::X),
                _ => (Vec3::new(u, v, 1.0), -Vec3::Z),
            };
            let mut wi = square_to_uniform_sphere(s.next_2d());
            if wi.dot(ng) < 0.0 {
                wi = -wi;
            }
            Photon { p, wi, power: Vec3::new(1.0, 0.5, 0.25) * 1e-3, ng }
        })
        .collect()
}
