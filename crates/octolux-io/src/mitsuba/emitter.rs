//! Mitsuba `emitter` plugins that stand on their own (`point`, `spot`, `directional`,
//! `constant`; `envmap` and `sunsky` in [`super::environment`]); `area` emitters are read with
//! their shape.

use super::props::{ColorKind, Props};
use super::tree::Elem;
use super::Builder;
use crate::IoError;
use glam::{Mat4, Vec3};
use octolux::math::Frame;
use octolux::scene::Light;

impl<'t> Builder<'t> {
    /// Emitter position and direction from `position`/`direction` or `to_world`.
    pub(super) fn placement(&self, p: &Props<'t>, key: &str) -> Result<(Option<Vec3>, Option<Mat4>), IoError> {
        let v = p.vec3(key)?;
        let m = p.transform("to_world")?;
        if v.is_some() && m.is_some() {
            return Err(p.owner.loc.error(format!("{}: give either {key} or to_world, not both", p.owner.describe())));
        }
        Ok((v, m))
    }

    /// Mitsuba 3's `sampling_weight` (how often next-event estimation picks this emitter;
    /// the image it converges to does not change): octolux chooses lights with its light tree
    /// instead, so a weight other than 1 is said to be ignored.
    pub(super) fn sampling_weight(&mut self, e: &Elem, p: &Props<'t>) -> Result<(), IoError> {
        if let Some(w) = p.float("sampling_weight")? {
            if w != 1.0 {
                self.warn(
                    e,
                    format!(
                        "sampling_weight {w} is ignored: octolux picks the light of each next-event sample with its \
                         light tree (by power, distance and orientation; `--set light_selection=power`: by power)"
                    ),
                );
            }
        }
        Ok(())
    }

    pub(super) fn emitter(&mut self, e: &'t Elem) -> Result<(), IoError> {
        let ty = e.req_attr("type")?;
        let p = self.props(e)?;
        self.sampling_weight(e, &p)?;
        let light = match ty {
            "point" => {
                let intensity = self.color_param(&p, "intensity", ColorKind::Emission, 1.0)?;
                let position = match self.placement(&p, "position")? {
                    (Some(v), _) => v,
                    (None, Some(m)) => m.transform_point3(Vec3::ZERO),
                    (None, None) => Vec3::ZERO,
                };
                Light::Point { position, intensity }
            }
            "spot" => {
                let intensity = self.color_param(&p, "intensity", ColorKind::Emission, 1.0)?;
                let cutoff = p.float_or("cutoff_angle", 20.0)?;
                let mut beam = p.float_or("beam_width", cutoff * 0.75)?;
                if !(cutoff > 0.0 && cutoff < 180.0) {
                    return Err(e.loc.error(format!("{}: cutoff_angle {cutoff} must be in (0, 180) degrees", e.describe())));
                }
                if beam > cutoff || beam < 0.0 {
                    self.warn(e, format!("beam_width {beam} must lie in [0, cutoff_angle = {cutoff}]; clamped"));
                    beam = beam.clamp(0.0, cutoff);
                }
                let m = p.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
                let n = m.transform_vector3(Vec3::Z).normalize();
                let s = m.transform_vector3(Vec3::X);
                let s = (s - n * s.dot(n)).normalize();
                if !n.is_finite() || !s.is_finite() {
                    return Err(e.loc.error(format!("{}: to_world is degenerate", e.describe())));
                }
                let frame = Frame { s, t: n.cross(s), n };
                Light::Spot {
                    position: m.transform_point3(Vec3::ZERO),
                    frame,
                    intensity,
                    cos_cutoff: cutoff.to_radians().cos(),
                    cos_falloff_start: beam.to_radians().cos(),
                }
            }
            "directional" => {
                let irradiance = self.color_param(&p, "irradiance", ColorKind::Emission, 1.0)?;
                let d = match self.placement(&p, "direction")? {
                    (Some(v), _) => v,
                    (None, Some(m)) => m.transform_vector3(Vec3::Z),
                    (None, None) => Vec3::Z,
                };
                if !d.is_finite() || d.length_squared() == 0.0 {
                    return Err(e.loc.error(format!("{}: the direction is zero", e.describe())));
                }
                Light::Directional { direction: d.normalize(), irradiance }
            }
            "constant" => Light::Constant { radiance: self.color_param(&p, "radiance", ColorKind::Emission, 1.0)? },
            "envmap" => self.envmap(e, &p)?,
            "sunsky" | "sun" | "sky" if ty == "sunsky" || e.legacy => {
                let lights = self.sunsky(e, &p, e.legacy, ty)?;
                for light in &lights {
                    light.validate().map_err(|msg| e.loc.error(format!("{}: {msg}", e.describe())))?;
                }
                p.finish(&mut self.warnings);
                self.desc.lights.extend(lights);
                return Ok(());
            }
            "area" => {
                // One a shape refers to is read there (as Mitsuba 3 does).
                if !e.attr("id").is_some_and(|id| self.referenced.contains(id)) {
                    self.warn(e, "an area emitter must be nested in a shape; ignored");
                }
                return Ok(());
            }
            other => {
                self.warn(e, format!("unsupported emitter type \"{other}\"; ignored"));
                return Ok(());
            }
        };
        light.validate().map_err(|msg| e.loc.error(format!("{}: {msg}", e.describe())))?;
        p.finish(&mut self.warnings);
        self.desc.lights.push(light);
        Ok(())
    }
}
