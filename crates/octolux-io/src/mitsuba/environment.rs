//! Mitsuba environment emitters: `envmap` (both syntaxes) and `sunsky` (Mitsuba 3's model,
//! reachable from Mitsuba 0.6 files with their parameters mapped onto it; 0.6's `sun` and `sky`
//! as a `sunsky` without its sky or its sun).
//!
//! `envmap`: `filename` (EXR, HDR linear; PNG/JPEG decoded from sRGB unless `raw`), `scale`,
//! `to_world`; 0.5/0.6 and Mitsuba 3 share the latitude-longitude convention. 0.6's `gamma`
//! (an override of the file's transfer curve: 1 linear, -1 sRGB, another value a power law)
//! is honoured as for bitmaps (`texture::Decode`).
//!
//! `sunsky` (Mitsuba 3.9 names): `turbidity`, `albedo`, `sun_direction` or
//! `latitude/longitude/timezone/year/month/day/hour/minute/second`, `sun_scale`, `sky_scale`,
//! `sun_aperture`, `to_world` (local `+z` is the zenith). Mitsuba 0.6 names (camelCase in the
//! file): `sunDirection`, `sunScale`, `skyScale` (both default to `scale`), `albedo` (default
//! 0.2 in 0.6's code, whose documentation says 0.15), `sunRadiusScale` (the sun's radius factor with its power kept: Mitsuba 3's
//! `sun_aperture = 0.5358° × sunRadiusScale`; 0 makes the sun a directional light, as in 0.6).
//! A 0.6 sky has `+y` as its zenith and measures azimuth from `-z` towards `+x`: its `toWorld` is
//! composed with the fixed map `(x, y, z) -> (-y, z, x)` from Mitsuba 3's local frame, which
//! puts both the zenith and a sun placed by date and place where 0.6 puts them. `stretch`
//! (≠ 1), `extend` (true) and `resolution` have no equivalent (the sky is evaluated, not rasterised; nothing
//! is emitted below the horizon): each gets a warning saying so.

use super::props::{ColorKind, Props};
use super::tree::{resolve_file, Elem};
use super::Builder;
use crate::IoError;
use glam::{Mat3, Mat4, Vec3};
use octolux::scene::sunsky::{SolarTime, SunSky, SunSkyDesc, SUN_APERTURE_DEG};
use octolux::scene::Light;

/// The rotation part of a transform's linear part (columns orthonormalised, handedness kept),
/// and whether the linear part was a rotation times a uniform scale.
fn rotation_of(m: &Mat4) -> (Mat3, bool) {
    let l = Mat3::from_mat4(*m);
    let s = l.x_axis.length();
    let c0 = l.x_axis.normalize_or_zero();
    let c1 = (l.y_axis - c0 * c0.dot(l.y_axis)).normalize_or_zero();
    let sign = if l.determinant() < 0.0 { -1.0 } else { 1.0 };
    let r = Mat3::from_cols(c0, c1, c0.cross(c1) * sign);
    let exact = s > 0.0 && ((l / s).transpose() * (l / s) - Mat3::IDENTITY).to_cols_array().iter().all(|v| v.abs() < 1e-4);
    (r, exact)
}

/// Mitsuba 3's sky frame in Mitsuba 0.6's: 0.6 has `+y` up and azimuth from `-z` towards `+x`.
fn legacy_sky_frame() -> Mat3 {
    // (x, y, z) -> (-y, z, x)
    Mat3::from_cols(Vec3::Z, -Vec3::X, Vec3::Y)
}

impl<'t> Builder<'t> {
    /// The `to_world` of an environment emitter as a rotation (a warning when it was not one).
    fn environment_frame(&mut self, e: &'t Elem, p: &Props<'t>) -> Result<Mat3, IoError> {
        let Some(m) = p.transform("to_world")? else { return Ok(Mat3::IDENTITY) };
        let (r, exact) = rotation_of(&m);
        if !r.is_finite() || r.determinant().abs() < 0.5 {
            return Err(e.loc.error(format!("{}: to_world is degenerate", e.describe())));
        }
        if !exact {
            self.warn(e, "to_world is not a rotation (it scales or shears); only its rotation part is used");
        }
        Ok(r)
    }

    pub(super) fn envmap(&mut self, e: &'t Elem, p: &Props<'t>) -> Result<Light, IoError> {
        let name = p.string("filename")?.ok_or_else(|| e.loc.error(format!("{} needs a \"filename\"", e.describe())))?;
        let path = resolve_file(&e.loc, name, &self.main_dir, self.search_dirs)
            .ok_or_else(|| e.loc.error(format!("{}: image file \"{name}\" not found", e.describe())))?;
        let (mut img, negative) = crate::image_io::read_texture(&path)?;
        self.warnings.extend(negative);
        let eight_bit = !path.extension().is_some_and(|x| {
            let x = x.to_ascii_lowercase();
            x == "exr" || x == "hdr" || x == "rgbe" || x == "pic"
        });
        // Mitsuba 3's `raw`, Mitsuba 0.6's `gamma`: as for bitmaps.
        super::texture::Decode::from_props(p, e)?.apply(&mut img, eight_bit);
        let scale = p.float_or("scale", 1.0)?;
        let to_world = self.environment_frame(e, p)?;
        p.accept(&["cache", "filter_type"]);
        let image = self.push_image(e, img)?;
        Ok(Light::Envmap { image, scale, to_world })
    }

    /// `sunsky` (and 0.6's `sun`, `sky`): the description, plus a directional light for a 0.6
    /// sun of radius scale 0.
    pub(super) fn sunsky(&mut self, e: &'t Elem, p: &Props<'t>, legacy: bool, kind: &str) -> Result<Vec<Light>, IoError> {
        let err = |msg: String| e.loc.error(format!("{}: {msg}", e.describe()));
        let mut to_world = self.environment_frame(e, p)?;
        if legacy {
            to_world *= legacy_sky_frame();
        }
        let turbidity = p.float_or("turbidity", 3.0)?;
        let albedo = self.color_param(p, "albedo", ColorKind::Bounded, if legacy { 0.2 } else { 0.3 })?;
        let scale = p.float_or("scale", 1.0)?;
        let mut sun_scale = p.float_or("sun_scale", scale)?;
        let mut sky_scale = p.float_or("sky_scale", scale)?;
        match kind {
            "sun" => sky_scale = 0.0,
            "sky" => sun_scale = 0.0,
            _ => {}
        }
        let mut aperture = p.float("sun_aperture")?;
        let radius_scale = p.float("sun_radius_scale")?;
        let mut directional_sun = false;
        if let Some(r) = radius_scale {
            if aperture.is_some() {
                self.warn(e, "both sun_aperture and sunRadiusScale are given; sun_aperture is used");
            } else if r == 0.0 {
                directional_sun = true;
            } else if r > 0.0 {
                aperture = Some(SUN_APERTURE_DEG * r);
            } else {
                return Err(err(format!("sunRadiusScale {r} must not be negative")));
            }
        }
        if p.bool_or("complex_sun", false)? {
            self.warn(e, "complex_sun (limb darkening) is not supported; the sun disk has uniform radiance of the same power");
        }
        if let Some(s) = p.float("stretch")? {
            if s != 1.0 {
                self.warn(
                    e,
                    format!("stretch = {s} has no equivalent in Mitsuba 3's sunsky; ignored (nothing is emitted below the horizon)"),
                );
            }
        }
        if p.bool_or("extend", false)? {
            self.warn(e, "extend = true has no equivalent in Mitsuba 3's sunsky; ignored (nothing is emitted below the horizon)");
        }
        if let Some(r) = p.int("resolution")? {
            self.warn(
                e,
                format!("resolution = {r} has no equivalent: the sky is evaluated per direction (Mitsuba 3's model), not rasterised"),
            );
        }

        // Sun direction: given in world space, or from date, time and place.
        const TIME_KEYS: [&str; 9] = ["latitude", "longitude", "timezone", "year", "month", "day", "hour", "minute", "second"];
        let sun_direction = match p.vec3("sun_direction")? {
            Some(v) => {
                if TIME_KEYS.iter().any(|k| p.has(k)) {
                    return Err(err("give either sun_direction or a date, time and place, not both".into()));
                }
                if !(v.is_finite() && v.length_squared() > 0.0) {
                    return Err(err(format!("sun_direction {v} is not a direction")));
                }
                v.normalize()
            }
            None => {
                let d = SolarTime::default();
                let int = |k: &str, def: i32| -> Result<i32, IoError> {
                    match p.int(k)? {
                        None => Ok(def),
                        Some(v) if (-100_000..=100_000).contains(&v) => Ok(v as i32),
                        Some(v) => Err(err(format!("{k} = {v} is out of range"))),
                    }
                };
                let t = SolarTime {
                    year: int("year", d.year)?,
                    month: int("month", d.month)?,
                    day: int("day", d.day)?,
                    hour: p.float_or("hour", d.hour)?,
                    minute: p.float_or("minute", d.minute)?,
                    second: p.float_or("second", d.second)?,
                    latitude: p.float_or("latitude", d.latitude)?,
                    longitude: p.float_or("longitude", d.longitude)?,
                    timezone: p.float_or("timezone", d.timezone)?,
                };
                let local = t.sun_direction();
                if !local.is_finite() {
                    return Err(err("the date, time and place give no sun position".into()));
                }
                (to_world * local).normalize()
            }
        };
        let desc = SunSkyDesc {
            sun_direction,
            turbidity,
            albedo,
            sun_scale: if directional_sun { 0.0 } else { sun_scale },
            sky_scale,
            sun_aperture_deg: aperture.unwrap_or(SUN_APERTURE_DEG),
            to_world,
        };
        desc.validate().map_err(err)?;
        if (to_world.transpose() * sun_direction).z < 0.0 {
            self.warn(e, "the sun is below the horizon: the sun and sky emit nothing (as in Mitsuba 3)");
        }
        let mut lights = vec![Light::Sunsky(desc.clone())];
        if directional_sun && sun_scale > 0.0 {
            // 0.6: a sun of radius 0 is a directional light of the sun's irradiance.
            let full = SunSky::new(&SunSkyDesc { sun_scale, sky_scale: 0.0, sun_aperture_deg: SUN_APERTURE_DEG, ..desc }).map_err(err)?;
            let half = 0.5 * SUN_APERTURE_DEG.to_radians();
            let omega = 2.0 * std::f32::consts::PI * (1.0 - half.cos());
            lights.push(Light::Directional { direction: -sun_direction, irradiance: full.sun_radiance() * omega });
        }
        Ok(lights)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn legacy_frame_maps_mitsuba3_sun_positions_onto_0_6_ones() {
        // 0.6: toSphere(θ, φ) = (sin φ sin θ, cos θ, -cos φ sin θ);
        // Mitsuba 3: (sin θ cos(φ - π), sin θ sin(φ - π), cos θ) for the same (θ, φ).
        let r = legacy_sky_frame();
        assert!((r.determinant() + 1.0).abs() < 1e-6, "a mirror: the two azimuths turn opposite ways");
        for (t, ph) in [(0.3f32, 0.2f32), (1.2, 2.5), (0.7, 4.0)] {
            let m3 = Vec3::new(t.sin() * (ph - std::f32::consts::PI).cos(), t.sin() * (ph - std::f32::consts::PI).sin(), t.cos());
            let v06 = Vec3::new(ph.sin() * t.sin(), t.cos(), -ph.cos() * t.sin());
            assert!((r * m3 - v06).length() < 1e-5);
        }
    }

    #[test]
    fn rotation_part_of_transforms() {
        let rot = Mat4::from_rotation_y(0.4) * Mat4::from_rotation_x(-1.0);
        let (r, exact) = rotation_of(&(rot * Mat4::from_scale(Vec3::splat(3.0))));
        assert!(exact && (r - Mat3::from_mat4(rot)).to_cols_array().iter().all(|v| v.abs() < 1e-5));
        let (r, exact) = rotation_of(&Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)));
        assert!(exact && r.determinant() < 0.0);
        let (_, exact) = rotation_of(&Mat4::from_scale(Vec3::new(1.0, 2.0, 1.0)));
        assert!(!exact);
    }
}
