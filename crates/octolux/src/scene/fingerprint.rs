//! What a baked lighting solution depends on (issue 13, docs/guide/baking.md): three 64-bit
//! fingerprints of a prepared scene, kept apart so that a refused cache can say what changed.
//!
//! - `geometry`: every vertex position, normal and uv, every triangle and the shape it belongs
//!   to, the analytic spheres, the shapes' normal flips and the scene bounds (the octree's root);
//! - `materials`: the materials, which material each shape uses, and the bitmaps no emitter
//!   uses (textures);
//! - `emitters`: the lights (area lights included) and the bitmaps environment maps use.
//!
//! The camera, the film and the render hints are left out: any camera renders from one bake.
//!
//! The hash is 64-bit FNV-1a (Fowler–Noll–Vo), written here: a dozen lines, published test
//! vectors, stable across Rust versions and platforms (std's `DefaultHasher` promises neither).
//! Numbers go in one 64-bit word per step (two floats per word), text byte by byte. Floats are hashed by their bits; materials and
//! lights by their `Debug` text, which prints every `f32` in its shortest exactly round-tripping
//! form, so a variant added to `Material` or `Light` is covered without code here.

use super::Scene;
use crate::image::Image;
use crate::scene::desc::Light;

/// The three fingerprints of a scene's lighting (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct LightingFingerprint {
    pub geometry: u64,
    pub materials: u64,
    pub emitters: u64,
}

impl LightingFingerprint {
    /// The parts that differ between `self` and `other`: `"geometry"`, `"materials"`,
    /// `"emitters"`, in that order (empty when they agree).
    pub fn changes(&self, other: &LightingFingerprint) -> Vec<&'static str> {
        let mut out = Vec::new();
        for (name, a, b) in [
            ("geometry", self.geometry, other.geometry),
            ("materials", self.materials, other.materials),
            ("emitters", self.emitters, other.emitters),
        ] {
            if a != b {
                out.push(name);
            }
        }
        out
    }
}

/// 64-bit FNV-1a.
pub struct Fnv1a(u64);

impl Default for Fnv1a {
    fn default() -> Self {
        Fnv1a(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv1a {
    pub fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 = (self.0 ^ x as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    /// One FNV-1a step on a whole 64-bit word (8x fewer multiplies than byte by byte; each
    /// step is a bijection of the state for a fixed word and of the word for a fixed state,
    /// so a change of any single word always changes the hash).
    pub fn u64(&mut self, v: u64) {
        self.0 = (self.0 ^ v).wrapping_mul(0x0000_0100_0000_01b3);
    }
    /// Floats by their bits, two per word.
    pub fn f32s(&mut self, v: &[f32]) {
        let mut pairs = v.chunks_exact(2);
        for p in &mut pairs {
            self.u64(p[0].to_bits() as u64 | (p[1].to_bits() as u64) << 32);
        }
        for x in pairs.remainder() {
            self.u64(x.to_bits() as u64);
        }
    }
    pub fn finish(&self) -> u64 {
        self.0
    }
}

fn image(h: &mut Fnv1a, index: usize, im: &Image) {
    h.u64(index as u64);
    h.u64(im.width as u64);
    h.u64(im.height as u64);
    h.u64(im.data.len() as u64);
    for c in &im.data {
        h.f32s(&c.to_array());
    }
}

impl Scene {
    /// The fingerprints of what the lighting depends on (module docs).
    pub fn lighting_fingerprint(&self) -> LightingFingerprint {
        let mut g = Fnv1a::default();
        g.u64(self.flat.positions.len() as u64);
        for p in &self.flat.positions {
            g.f32s(&p.to_array());
        }
        // all normals, then all uvs: the order of the fingerprints written into cache files
        for a in &self.flat.shading {
            g.f32s(&a.n.to_array());
        }
        for a in &self.flat.shading {
            g.f32s(&a.uv.to_array());
        }
        g.u64(self.flat.triangles.len() as u64);
        for (t, s) in self.flat.triangles.iter().zip(&self.flat.tri_shape) {
            t.iter().chain([s]).for_each(|&i| g.u64(i as u64));
        }
        g.u64(self.flat.spheres.len() as u64);
        for s in &self.flat.spheres {
            g.f32s(&[s.center.x, s.center.y, s.center.z, s.radius]);
            g.u64(s.shape as u64);
        }
        g.u64(self.flat.shapes.len() as u64);
        for s in &self.flat.shapes {
            g.bytes(&[s.flip as u8, s.has_normals as u8, s.has_uvs as u8]);
        }
        g.f32s(&self.bounds.min.to_array());
        g.f32s(&self.bounds.max.to_array());

        let env_images: Vec<usize> = self
            .lights
            .lights
            .iter()
            .filter_map(|l| match l {
                Light::Envmap { image, .. } => Some(*image as usize),
                _ => None,
            })
            .collect();
        let mut m = Fnv1a::default();
        m.bytes(format!("{:?}", self.materials).as_bytes());
        for s in &self.flat.shapes {
            m.u64(s.material as u64);
        }
        let mut e = Fnv1a::default();
        e.bytes(format!("{:?}", self.lights.lights).as_bytes());
        for (i, im) in self.images.iter().enumerate() {
            image(if env_images.contains(&i) { &mut e } else { &mut m }, i, im);
        }
        LightingFingerprint { geometry: g.finish(), materials: m.finish(), emitters: e.finish() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::BackendKind;
    use crate::scene::material::Material;
    use crate::scene::Scene;

    #[test]
    fn fnv1a_matches_the_published_vectors() {
        let h = |s: &str| {
            let mut f = Fnv1a::default();
            f.bytes(s.as_bytes());
            f.finish()
        };
        assert_eq!(h(""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(h("a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(h("foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn each_change_shows_in_its_own_fingerprint_and_the_camera_in_none() {
        let base = crate::integrators::test_scenes::box_desc();
        let fp = |d: &crate::scene::SceneDesc| Scene::prepare(d.clone(), BackendKind::Bvh).unwrap().lighting_fingerprint();
        let f0 = fp(&base);
        assert_eq!(f0, fp(&base), "deterministic");
        let mut d = base.clone();
        d.camera.fov_deg *= 0.5;
        d.film.width += 16;
        assert_eq!(f0.changes(&fp(&d)), Vec::<&str>::new(), "camera and film");
        let mut d = base.clone();
        if let crate::scene::Geometry::Mesh(m) = &mut d.shapes[0].geometry {
            m.positions[0].x += 1e-3;
        }
        assert_eq!(f0.changes(&fp(&d)), vec!["geometry"]);
        let mut d = base.clone();
        d.materials[0] = Material::Diffuse { reflectance: crate::scene::material::Texture::Const(glam::Vec3::splat(0.123)) };
        assert_eq!(f0.changes(&fp(&d)), vec!["materials"]);
        let mut d = base.clone();
        let s = d.shapes.iter_mut().find(|s| s.emission.is_some()).expect("an area light");
        s.emission = s.emission.map(|e| e * 2.0);
        assert_eq!(f0.changes(&fp(&d)), vec!["emitters"]);
    }
}
