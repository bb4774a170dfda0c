//! The textures a material reads, for the path tracer's two questions about them before it
//! evaluates anything: whether a camera hit's uv partials matter (only MIP-mapped lookups read
//! them), and which texels to prefetch (docs/lab/2026-11-30-performance.md, "Path tracer throughput on the
//! collection (session 7)").

use super::texture::{TexCoord, Texture};
use super::Material;
use crate::image::Image;

impl Material {
    /// Call `f` on every texture the material (and the materials it wraps) reads.
    pub fn for_each_texture(&self, f: &mut impl FnMut(&Texture)) {
        match self {
            Material::Diffuse { reflectance: t }
            | Material::Plastic { diffuse_reflectance: t, .. }
            | Material::RoughPlastic { diffuse_reflectance: t, .. } => f(t),
            Material::Ward { diffuse_reflectance: a, specular_reflectance: b, .. }
            | Material::Phong { diffuse_reflectance: a, specular_reflectance: b, .. } => {
                f(a);
                f(b);
            }
            Material::TwoSided { front, back } => {
                front.for_each_texture(f);
                back.for_each_texture(f);
            }
            Material::Blend { weight, first, second } => {
                f(weight);
                first.for_each_texture(f);
                second.for_each_texture(f);
            }
            Material::Mask { opacity: t, nested }
            | Material::BumpMap { height: t, nested, .. }
            | Material::NormalMap { normals: t, nested } => {
                f(t);
                nested.for_each_texture(f);
            }
            Material::Conductor { .. }
            | Material::RoughConductor { .. }
            | Material::Dielectric { .. }
            | Material::ThinDielectric { .. }
            | Material::RoughDielectric { .. } => {}
        }
    }

    /// Whether evaluating or sampling this material reads the uv partials of its [`TexCoord`]
    /// (some texture is MIP-mapped, [`Texture::reads_partials`]): without, a camera hit's ray
    /// differential changes nothing and the path tracer skips it.
    pub fn reads_uv_partials(&self) -> bool {
        let mut any = false;
        self.for_each_texture(&mut |t| any |= t.reads_partials());
        any
    }

    /// Prefetch the texels that evaluating or sampling this material at `tc` will read
    /// ([`Texture::prefetch`]; no effect on any value): the path tracer calls it as soon as it
    /// has a hit, so that the memory reads overlap the light sampling before `eval`.
    #[inline]
    pub fn prefetch(&self, images: &[Image], tc: TexCoord) {
        self.for_each_texture(&mut |t| t.prefetch(images, tc));
    }
}
