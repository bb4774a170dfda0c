//! Mitsuba `bsdf` plugins mapped onto octolux materials (see the module documentation of
//! [`super`] for the departures from Mitsuba).

use super::props::{self, ColorKind, Props};
use super::tree::Elem;
use super::{spectra, Builder};
use crate::IoError;
use octolux::math::Color;
use octolux::scene::material::{Material, Microfacet, MicrofacetKind, Roughness, Texture, WardVariant};

/// Whether `m` holds a bump or normal map below a `twosided` or `blendbsdf` (the prepared scene
/// perturbs shading frames only for a chain of mask, bumpmap and normalmap at the top of a
/// shape's material; deeper, the nested bsdf is evaluated unperturbed).
fn holds_frame_wrapper(m: &Material) -> bool {
    match m {
        Material::BumpMap { .. } | Material::NormalMap { .. } => true,
        Material::Mask { nested, .. } => holds_frame_wrapper(nested),
        Material::TwoSided { front: a, back: b } | Material::Blend { first: a, second: b, .. } => {
            holds_frame_wrapper(a) || holds_frame_wrapper(b)
        }
        _ => false,
    }
}

/// The bsdf types octolux reads.
pub(super) const BSDF_TYPES: &[&str] = &[
    "diffuse",
    "dielectric",
    "thindielectric",
    "roughdielectric",
    "conductor",
    "roughconductor",
    "plastic",
    "roughplastic",
    "ward",
    "phong",
    "twosided",
    "blendbsdf",
    "mask",
    "bumpmap",
    "normalmap",
    "null",
];

/// Bsdf plugins of Mitsuba 3 and of 0.5/0.6 that octolux does not read: a warning, and
/// Mitsuba's default diffuse in their place. Any other type is no Mitsuba plugin (Mitsuba
/// refuses the file too): an error.
const MITSUBA_ONLY_BSDF_TYPES: &[&str] = &[
    // Mitsuba 3
    "hair",
    "measured",
    "measured_polarized",
    "polarizer",
    "retarder",
    "circular",
    "pplastic",
    "principled",
    "principledthin",
    // Mitsuba 0.5/0.6
    "roughdiffuse",
    "coating",
    "roughcoating",
    "difftrans",
    "hk",
    "irawan",
    "mixturebsdf",
    "dipolebrdf",
    "sssbrdf",
];

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

    /// The material of an emitting shape without a bsdf: Mitsuba 3's `Shape` (and 0.6's)
    /// gives it a `diffuse` of reflectance 0, so that a light source reflects nothing.
    pub(super) fn default_emitter_material(&mut self) -> u32 {
        if let Some(i) = self.default_emitter_material {
            return i;
        }
        self.desc.materials.push(Material::Diffuse { reflectance: Texture::Const(Color::ZERO) });
        let i = (self.desc.materials.len() - 1) as u32;
        self.default_emitter_material = Some(i);
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

    /// The `distribution` of a rough bsdf (`beckmann`, Mitsuba's default, or `ggx`) and its
    /// `sample_visible`.
    fn microfacet_kind(&mut self, p: &Props<'t>) -> Result<MicrofacetKind, IoError> {
        let e = p.owner;
        let dist = p.string("distribution")?.unwrap_or("beckmann").to_ascii_lowercase();
        let kind = match dist.as_str() {
            "beckmann" => MicrofacetKind::Beckmann,
            "ggx" => MicrofacetKind::Ggx,
            "phong" | "as" => {
                self.warn(e, format!("microfacet distribution \"{dist}\" (Mitsuba 0.6 only) is replaced by beckmann with the same alpha"));
                MicrofacetKind::Beckmann
            }
            other => {
                return Err(e.loc.error(format!("{}: invalid distribution \"{other}\", must be \"beckmann\" or \"ggx\"", e.describe())))
            }
        };
        if !p.bool_or("sample_visible", true)? {
            self.warn(e, "sample_visible = false: octolux always samples visible normals (the same image in expectation, less noise)");
        }
        Ok(kind)
    }

    /// The microfacet distribution of a rough bsdf, as Mitsuba 3 reads it: `distribution`
    /// (`beckmann`, the default, or `ggx`), `alpha` or both `alpha_u` and `alpha_v` (default
    /// 0.1). `isotropic_only`: anisotropy is an error (Mitsuba's `roughplastic` throws too).
    pub(super) fn microfacet(&mut self, p: &Props<'t>, isotropic_only: bool) -> Result<Microfacet, IoError> {
        let e = p.owner;
        let kind = self.microfacet_kind(p)?;
        let (alpha_u, alpha_v) = match (p.float("alpha")?, p.float("alpha_u")?, p.float("alpha_v")?) {
            (Some(a), None, None) => (a, a),
            (None, Some(u), Some(v)) => (u, v),
            (None, None, None) => (0.1, 0.1),
            _ => return Err(e.loc.error(format!("{}: give either alpha or both alpha_u and alpha_v", e.describe()))),
        };
        for a in [alpha_u, alpha_v] {
            if !(a >= 0.0 && a.is_finite()) {
                return Err(e.loc.error(format!("{}: roughness {a} must be finite and non-negative", e.describe())));
            }
            if a == 0.0 {
                self.warn(e, "a roughness of 0 is clamped to 1e-4 (as Mitsuba does); use the smooth model for a smooth surface");
            }
        }
        if isotropic_only && alpha_u != alpha_v {
            return Err(e.loc.error(format!("{}: anisotropic roughness is not supported by this bsdf (nor by Mitsuba)", e.describe())));
        }
        Ok(Microfacet { kind, alpha_u, alpha_v })
    }

    /// The roughness of `roughconductor` and `roughdielectric`, whose alphas Mitsuba 3 accepts as
    /// textures: as [`Builder::microfacet`] reads it when the alphas are numbers, else the
    /// textures (a bitmap decoded as for colours, read through its luminance).
    pub(super) fn roughness(&mut self, p: &Props<'t>) -> Result<Roughness, IoError> {
        let e = p.owner;
        let is_texture = |n: &str| p.get(n).is_some_and(|x| x.target.tag == "texture");
        if !["alpha", "alpha_u", "alpha_v"].into_iter().any(is_texture) {
            return Ok(self.microfacet(p, false)?.into());
        }
        let kind = self.microfacet_kind(p)?;
        let (alpha_u, alpha_v) = match (p.has("alpha"), p.has("alpha_u"), p.has("alpha_v")) {
            (true, false, false) => {
                let a = self.texture_param(p, "alpha", ColorKind::Unbounded, 0.1)?;
                (a.clone(), a)
            }
            (false, true, true) => {
                (self.texture_param(p, "alpha_u", ColorKind::Unbounded, 0.1)?, self.texture_param(p, "alpha_v", ColorKind::Unbounded, 0.1)?)
            }
            _ => return Err(e.loc.error(format!("{}: give either alpha or both alpha_u and alpha_v", e.describe()))),
        };
        Ok(Roughness { kind, alpha_u, alpha_v })
    }

    /// Mitsuba 0.6's `ensureEnergyConservation` (default on) for `ward` and `phong`.
    fn energy_conservation(&mut self, p: &Props<'t>, mut m: Material) -> Result<Material, IoError> {
        if p.bool_or("ensure_energy_conservation", true)? {
            for msg in m.ensure_energy_conservation(&mut self.desc.images) {
                self.warn(p.owner, msg);
            }
        }
        Ok(m)
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

    fn warn_nested_frame_wrapper(&mut self, e: &'t Elem, m: &Material) {
        if holds_frame_wrapper(m) {
            self.warn(
                e,
                "a bumpmap or normalmap inside this bsdf is not supported: its nested bsdf is used unperturbed \
                 (put the bumpmap or normalmap outside, around it)",
            );
        }
    }

    pub(super) fn material(&mut self, e: &'t Elem) -> Result<Material, IoError> {
        let ty = e.req_attr("type")?;
        let p = self.props(e)?;
        if matches!(ty, "conductor" | "dielectric" | "thindielectric" | "plastic") {
            // A roughness on a smooth model: Mitsuba 0.6's smooth plugins never read it.
            self.not_mitsuba_params(&p, &["alpha", "alpha_u", "alpha_v", "distribution"], &format!("smooth {ty}"));
        }
        let m = match ty {
            "diffuse" => Material::Diffuse { reflectance: self.texture_param(&p, "reflectance", ColorKind::Bounded, 0.5)? },
            "dielectric" | "thindielectric" => {
                let eta = self.eta(&p, "bk7")?;
                let specular_reflectance = self.color_param(&p, "specular_reflectance", ColorKind::Bounded, 1.0)?;
                let specular_transmittance = self.color_param(&p, "specular_transmittance", ColorKind::Bounded, 1.0)?;
                if ty == "thindielectric" {
                    Material::ThinDielectric { eta, specular_reflectance, specular_transmittance }
                } else {
                    Material::Dielectric { eta, specular_reflectance, specular_transmittance }
                }
            }
            "roughdielectric" => {
                let distribution = self.roughness(&p)?;
                let eta = self.eta(&p, "bk7")?;
                let specular_reflectance = self.color_param(&p, "specular_reflectance", ColorKind::Bounded, 1.0)?;
                let specular_transmittance = self.color_param(&p, "specular_transmittance", ColorKind::Bounded, 1.0)?;
                Material::RoughDielectric { distribution, eta, specular_reflectance, specular_transmittance }
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
                // Mitsuba 0.6's `extEta`: the complex IOR is relative to the exterior medium.
                let (eta, k) = if p.has("ext_eta") {
                    let ext = self.ior(&p, "ext_eta", "air")?;
                    (eta / ext, k / ext)
                } else {
                    (eta, k)
                };
                let specular_reflectance = self.color_param(&p, "specular_reflectance", ColorKind::Bounded, 1.0)?;
                if ty == "roughconductor" {
                    let distribution = self.roughness(&p)?;
                    Material::RoughConductor { distribution, eta, k, specular_reflectance }
                } else {
                    Material::Conductor { eta, k, specular_reflectance }
                }
            }
            "plastic" | "roughplastic" => {
                let distribution = if ty == "roughplastic" { Some(self.microfacet(&p, true)?) } else { None };
                let eta = self.eta(&p, "polypropylene")?;
                let diffuse_reflectance = self.texture_param(&p, "diffuse_reflectance", ColorKind::Bounded, 0.5)?;
                let specular_reflectance = self.color_param(&p, "specular_reflectance", ColorKind::Bounded, 1.0)?;
                let nonlinear = p.bool_or("nonlinear", false)?;
                match distribution {
                    Some(distribution) => {
                        Material::RoughPlastic { diffuse_reflectance, specular_reflectance, distribution, eta, nonlinear }
                    }
                    None => Material::Plastic { diffuse_reflectance, specular_reflectance, eta, nonlinear },
                }
            }
            "ward" => {
                let variant = match p.string("variant")?.unwrap_or("balanced").to_ascii_lowercase().as_str() {
                    "ward" => WardVariant::Ward,
                    "ward-duer" => WardVariant::WardDuer,
                    "balanced" => WardVariant::Balanced,
                    other => {
                        return Err(e.loc.error(format!(
                            "{}: invalid variant \"{other}\", must be \"ward\", \"ward-duer\" or \"balanced\"",
                            e.describe()
                        )))
                    }
                };
                let alpha = p.float_or("alpha", 0.1)?;
                let (alpha_u, alpha_v) = (p.float_or("alpha_u", alpha)?, p.float_or("alpha_v", alpha)?);
                let diffuse_reflectance = self.texture_param(&p, "diffuse_reflectance", ColorKind::Bounded, 0.5)?;
                let specular_reflectance = self.texture_param(&p, "specular_reflectance", ColorKind::Bounded, 0.2)?;
                let m = Material::Ward { variant, alpha_u, alpha_v, diffuse_reflectance, specular_reflectance };
                self.energy_conservation(&p, m)?
            }
            "phong" => {
                let exponent = p.float_or("exponent", 30.0)?;
                let diffuse_reflectance = self.texture_param(&p, "diffuse_reflectance", ColorKind::Bounded, 0.5)?;
                let specular_reflectance = self.texture_param(&p, "specular_reflectance", ColorKind::Bounded, 0.2)?;
                self.energy_conservation(&p, Material::Phong { exponent, diffuse_reflectance, specular_reflectance })?
            }
            "twosided" => {
                let nested = self.nested_bsdfs(&p);
                let m = match nested.as_slice() {
                    [one] => {
                        let m = self.material(one)?;
                        Material::TwoSided { front: Box::new(m.clone()), back: Box::new(m) }
                    }
                    [front, back] => Material::TwoSided { front: Box::new(self.material(front)?), back: Box::new(self.material(back)?) },
                    _ => return Err(e.loc.error(format!("{} needs one or two nested bsdfs, found {}", e.describe(), nested.len()))),
                };
                self.warn_nested_frame_wrapper(e, &m);
                m
            }
            "blendbsdf" => {
                if !p.has("weight") {
                    return Err(e.loc.error(format!("{} needs a \"weight\"", e.describe())));
                }
                let weight = self.texture_param(&p, "weight", ColorKind::Bounded, 0.5)?;
                let nested = self.nested_bsdfs(&p);
                let [first, second] = nested.as_slice() else {
                    return Err(e.loc.error(format!("{} needs exactly two nested bsdfs, found {}", e.describe(), nested.len())));
                };
                let m = Material::Blend { weight, first: Box::new(self.material(first)?), second: Box::new(self.material(second)?) };
                self.warn_nested_frame_wrapper(e, &m);
                m
            }
            "mask" | "bumpmap" | "normalmap" => {
                let nested = self.nested_bsdfs(&p);
                let [inner] = nested.as_slice() else {
                    return Err(e.loc.error(format!("{} needs exactly one nested bsdf, found {}", e.describe(), nested.len())));
                };
                let inner = Box::new(self.material(inner)?);
                match ty {
                    // Mitsuba 3 (and 0.6): `opacity`, a float or a texture, default 0.5.
                    "mask" => Material::Mask { opacity: self.texture_param(&p, "opacity", ColorKind::Bounded, 0.5)?, nested: inner },
                    // Mitsuba 3 and 0.6: one nested texture of any name, `scale` (default 1).
                    "bumpmap" => {
                        let textures: Vec<(usize, &'t Elem)> =
                            p.objects().filter(|(_, o)| o.target.tag == "texture").map(|(i, o)| (i, o.target)).collect();
                        let [(i, tex)] = textures.as_slice() else {
                            return Err(e.loc.error(format!(
                                "{} needs exactly one nested texture, found {}",
                                e.describe(),
                                textures.len()
                            )));
                        };
                        p.mark(*i);
                        let height = self.texture(tex)?;
                        Material::BumpMap { height, scale: p.float_or("scale", 1.0)?, nested: inner }
                    }
                    // Mitsuba 3 only: the texture `normalmap` (0.6 has no such plugin).
                    _ => {
                        if !p.has("normalmap") {
                            return Err(e.loc.error(format!("{} needs a \"normalmap\" texture", e.describe())));
                        }
                        Material::NormalMap { normals: self.texture_param(&p, "normalmap", ColorKind::Bounded, 0.5)?, nested: inner }
                    }
                }
            }
            "null" => {
                self.warn(e, "the null bsdf (invisible surface) is not supported; the surface is black diffuse");
                Material::Diffuse { reflectance: Texture::Const(Color::ZERO) }
            }
            other if !MITSUBA_ONLY_BSDF_TYPES.contains(&other) => {
                let known = BSDF_TYPES.iter().chain(MITSUBA_ONLY_BSDF_TYPES);
                let msg = match super::did_you_mean(other, known.clone().copied()) {
                    Some(close) => format!("unknown bsdf type \"{other}\" (did you mean \"{close}\"?)"),
                    None => format!(
                        "unknown bsdf type \"{other}\": no bsdf of Mitsuba 3 or 0.6 has that name (octolux reads {})",
                        BSDF_TYPES.join(", ")
                    ),
                };
                return Err(e.loc.error(format!("{}: {msg}", e.describe())));
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
