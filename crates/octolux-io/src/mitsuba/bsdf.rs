//! Mitsuba `bsdf` plugins mapped onto octolux materials (see the module documentation of
//! [`super`] for the departures from Mitsuba).

use super::props::{self, ColorKind, Props};
use super::tree::Elem;
use super::{spectra, Builder, SMOOTH_PLASTIC_ALPHA};
use crate::IoError;
use octolux::material::{Material, Texture};
use octolux::math::Color;

impl<'t> Builder<'t> {
    pub(super) fn default_material(&mut self) -> u32 {
        if let Some(i) = self.default_material {
            return i;
        }
        self.desc.materials.push(Material::Diffuse { reflectance: Texture::Const(Color::splat(0.5)) });
        let i = (self.desc.materials.len() - 1) as u32;
        self.default_material = Some(i);
        i
    }

    /// Index of the material for bsdf element `e`, instantiating it once.
    pub(super) fn material_index(&mut self, e: &'t Elem) -> Result<u32, IoError> {
        let key = e as *const Elem;
        if let Some(&i) = self.materials.get(&key) {
            return Ok(i);
        }
        let m = self.material(e)?;
        m.validate(self.desc.images.len()).map_err(|msg| e.loc.error(format!("{}: {msg}", e.describe())))?;
        self.desc.materials.push(m);
        let i = (self.desc.materials.len() - 1) as u32;
        self.materials.insert(key, i);
        Ok(i)
    }

    /// An IOR given as a number or a name from Mitsuba's table.
    pub(super) fn ior(&mut self, p: &Props<'t>, name: &str, default: &str) -> Result<f32, IoError> {
        let v = match p.get(name) {
            None => spectra::lookup_ior(default).unwrap_or(1.0),
            Some(entry) => {
                let e = entry.target;
                match e.tag.as_str() {
                    "float" | "integer" => props::parse_f32(e, e.req_attr("value")?)?,
                    "string" => {
                        let n = e.req_attr("value")?;
                        spectra::lookup_ior(n)
                            .ok_or_else(|| e.loc.error(format!("unknown IOR name \"{n}\"; valid names are: {}", spectra::ior_names())))?
                    }
                    "rgb" | "spectrum" => {
                        let c = props::parse_color(e, ColorKind::Unbounded, &mut self.warnings)?;
                        if c.max_element() - c.min_element() > 1e-6 {
                            self.warn(e, "a spectrally varying IOR is not supported; using its luminance");
                        }
                        octolux::math::luminance(c)
                    }
                    t => return Err(entry.elem.loc.error(format!("{name} must be a <float> or <string>, not <{t}>"))),
                }
            }
        };
        if v <= 0.0 {
            return Err(p.owner.loc.error(format!("{}: {name} = {v} must be positive", p.owner.describe())));
        }
        Ok(v)
    }

    /// `int_ior / ext_ior` with Mitsuba's checks.
    pub(super) fn eta(&mut self, p: &Props<'t>, int_default: &str) -> Result<f32, IoError> {
        let int = self.ior(p, "int_ior", int_default)?;
        let ext = self.ior(p, "ext_ior", "air")?;
        if int == ext {
            return Err(p
                .owner
                .loc
                .error(format!("{}: the interior and exterior indices of refraction must differ (both {int})", p.owner.describe())));
        }
        Ok(int / ext)
    }

    /// GGX alpha of a microfacet bsdf (warns about Beckmann and anisotropy).
    pub(super) fn alpha(&mut self, p: &Props<'t>) -> Result<f32, IoError> {
        let e = p.owner;
        let dist = p.string("distribution")?.unwrap_or("beckmann").to_ascii_lowercase();
        if dist != "ggx" {
            self.warn(
                e,
                format!("microfacet distribution \"{dist}\" (Mitsuba's default is beckmann) is replaced by GGX with the same alpha"),
            );
        }
        p.accept(&["sample_visible"]);
        let (au, av) = (p.float("alpha_u")?, p.float("alpha_v")?);
        let alpha = match (p.float("alpha")?, au, av) {
            (Some(a), None, None) => a,
            (None, Some(u), Some(v)) => {
                if u != v {
                    self.warn(e, format!("anisotropic roughness is not supported; using alpha = sqrt({u} * {v})"));
                }
                (u * v).sqrt()
            }
            (None, None, None) => 0.1,
            _ => return Err(e.loc.error(format!("{}: give either alpha or both alpha_u and alpha_v", e.describe()))),
        };
        if alpha.is_nan() || alpha <= 0.0 {
            return Err(e.loc.error(format!("{}: alpha {alpha} must be positive", e.describe())));
        }
        Ok(alpha)
    }

    /// The nested bsdfs of a wrapper (nested elements or refs), in order.
    pub(super) fn nested_bsdfs(&self, p: &Props<'t>) -> Vec<&'t Elem> {
        let mut v = Vec::new();
        for (i, o) in p.objects() {
            if o.target.tag == "bsdf" {
                p.mark(i);
                v.push(o.target);
            }
        }
        v
    }

    pub(super) fn material(&mut self, e: &'t Elem) -> Result<Material, IoError> {
        let ty = e.req_attr("type")?;
        let p = self.props(e)?;
        let m = match ty {
            "diffuse" => Material::Diffuse { reflectance: self.texture_param(&p, "reflectance", ColorKind::Bounded, 0.5)? },
            "dielectric" | "roughdielectric" | "thindielectric" => {
                if ty == "roughdielectric" {
                    self.warn(e, "rough dielectrics are not supported; using a smooth dielectric with the same IORs");
                    p.accept(&["alpha", "alpha_u", "alpha_v", "distribution", "sample_visible"]);
                }
                let eta = self.eta(&p, "bk7")?;
                let specular_reflectance = self.color_param(&p, "specular_reflectance", ColorKind::Bounded, 1.0)?;
                let specular_transmittance = self.color_param(&p, "specular_transmittance", ColorKind::Bounded, 1.0)?;
                if ty == "thindielectric" {
                    Material::ThinDielectric { eta, specular_reflectance, specular_transmittance }
                } else {
                    Material::Dielectric { eta, specular_reflectance, specular_transmittance }
                }
            }
            "conductor" | "roughconductor" => {
                let preset = p.string("material")?;
                let (eta, k) = if p.has("eta") || p.has("k") {
                    if preset.is_some_and(|m| m != "none") {
                        return Err(e.loc.error(format!("{}: give either (eta, k) or material, not both", e.describe())));
                    }
                    (self.color_param(&p, "eta", ColorKind::Unbounded, 0.0)?, self.color_param(&p, "k", ColorKind::Unbounded, 1.0)?)
                } else {
                    let name = preset.unwrap_or("none");
                    match spectra::lookup_conductor(name).or_else(|| {
                        let lower = name.to_ascii_lowercase();
                        spectra::conductor_names().split(", ").find(|n| n.to_ascii_lowercase() == lower).and_then(spectra::lookup_conductor)
                    }) {
                        Some(v) => v,
                        None => {
                            self.warn(
                                e,
                                format!(
                                    "conductor material \"{name}\" is not in octolux's table ({}); using a perfect mirror",
                                    spectra::conductor_names()
                                ),
                            );
                            (Color::ZERO, Color::ZERO)
                        }
                    }
                };
                let specular_reflectance = self.color_param(&p, "specular_reflectance", ColorKind::Bounded, 1.0)?;
                if ty == "roughconductor" {
                    let alpha = self.alpha(&p)?;
                    Material::RoughConductor { alpha, eta, k, specular_reflectance }
                } else {
                    Material::Conductor { eta, k, specular_reflectance }
                }
            }
            "plastic" | "roughplastic" => {
                let alpha = if ty == "plastic" {
                    self.warn(e, format!("smooth plastic is approximated by a GGX roughplastic with alpha = {SMOOTH_PLASTIC_ALPHA}"));
                    SMOOTH_PLASTIC_ALPHA
                } else {
                    self.alpha(&p)?
                };
                let eta = self.eta(&p, "polypropylene")?;
                let diffuse_reflectance = self.texture_param(&p, "diffuse_reflectance", ColorKind::Bounded, 0.5)?;
                let specular_reflectance = self.color_param(&p, "specular_reflectance", ColorKind::Bounded, 1.0)?;
                if p.bool_or("nonlinear", false)? {
                    self.warn(e, "nonlinear = true is not supported; using the linear (default) model");
                }
                Material::RoughPlastic { diffuse_reflectance, specular_reflectance, alpha, eta }
            }
            "twosided" => {
                let nested = self.nested_bsdfs(&p);
                match nested.as_slice() {
                    [one] => {
                        let m = self.material(one)?;
                        Material::TwoSided { front: Box::new(m.clone()), back: Box::new(m) }
                    }
                    [front, back] => Material::TwoSided { front: Box::new(self.material(front)?), back: Box::new(self.material(back)?) },
                    _ => return Err(e.loc.error(format!("{} needs one or two nested bsdfs, found {}", e.describe(), nested.len()))),
                }
            }
            "mask" | "bumpmap" | "normalmap" => {
                let nested = self.nested_bsdfs(&p);
                let [inner] = nested.as_slice() else {
                    return Err(e.loc.error(format!("{} needs exactly one nested bsdf, found {}", e.describe(), nested.len())));
                };
                self.warn(e, format!("\"{ty}\" is not supported; using its nested bsdf alone"));
                p.accept_all();
                self.material(inner)?
            }
            "null" => {
                self.warn(e, "the null bsdf (invisible surface) is not supported; the surface is black diffuse");
                Material::Diffuse { reflectance: Texture::Const(Color::ZERO) }
            }
            other => {
                self.warn(e, format!("unsupported bsdf type \"{other}\"; using Mitsuba's default diffuse (reflectance 0.5)"));
                p.accept_all();
                Material::Diffuse { reflectance: Texture::Const(Color::splat(0.5)) }
            }
        };
        p.finish(&mut self.warnings);
        Ok(m)
    }
}
