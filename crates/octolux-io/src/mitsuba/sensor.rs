//! Mitsuba `sensor`, `film`, `rfilter` and `sampler` plugins: the camera, the image size, the
//! pixel filter and the sample count (a hint for the CLI).

use super::props;
use super::tree::Elem;
use super::{Builder, DEFAULT_FILM};
use crate::IoError;
use glam::Mat4;
use octolux::scene::camera::FovAxis;
use octolux::scene::{FilmDesc, PixelFilter};

impl<'t> Builder<'t> {
    /// Returns false when the sensor type is unsupported (and was skipped).
    pub(super) fn sensor(&mut self, e: &'t Elem) -> Result<bool, IoError> {
        let ty = e.req_attr("type")?;
        match ty {
            "perspective" => {}
            "thinlens" => self.warn(e, "depth of field is not supported; rendered as a pinhole (perspective) camera"),
            _ => {
                self.warn(e, format!("unsupported sensor type \"{ty}\"; skipped"));
                return Ok(false);
            }
        }
        let p = self.props(e)?;
        // Film first: the fov conversions need the aspect ratio only at render time, but the
        // film also carries the sampler-independent settings.
        let mut film = DEFAULT_FILM;
        let mut spp = None;
        for (i, o) in p.objects() {
            match o.target.tag.as_str() {
                "film" => {
                    p.mark(i);
                    film = self.film(o.target)?;
                }
                "sampler" => {
                    p.mark(i);
                    spp = Some(self.sampler(o.target)?);
                }
                _ => {}
            }
        }
        let cam = &mut self.desc.camera;
        cam.to_world = p.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
        let fov = p.float("fov")?;
        let focal = p.get("focal_length").map(|f| (f.target.attr("value").unwrap_or("").to_string(), f.target));
        match (fov, focal) {
            (Some(_), Some(_)) => return Err(e.loc.error(format!("{}: give either fov or focal_length, not both", e.describe()))),
            (Some(f), None) => {
                cam.fov_deg = f;
                cam.fov_axis = match p.string("fov_axis")?.unwrap_or("x").to_ascii_lowercase().as_str() {
                    "x" => FovAxis::X,
                    "y" => FovAxis::Y,
                    "diagonal" => FovAxis::Diagonal,
                    "smaller" => FovAxis::Smaller,
                    "larger" => FovAxis::Larger,
                    other => {
                        return Err(e
                            .loc
                            .error(format!("{}: fov_axis \"{other}\" must be x, y, diagonal, smaller or larger", e.describe())))
                    }
                };
            }
            (None, focal) => {
                let (text, fe) = focal.unwrap_or_else(|| ("50mm".to_string(), e));
                let mm = props::parse_f32(fe, text.trim().trim_end_matches("mm"))?;
                if mm <= 0.0 {
                    return Err(fe.loc.error(format!("focal length {mm} mm must be positive")));
                }
                // 35 mm-equivalent focal length -> diagonal field of view (Mitsuba's parse_fov).
                cam.fov_deg = 2.0 * (36.0f32.hypot(24.0) / (2.0 * mm)).atan().to_degrees();
                cam.fov_axis = FovAxis::Diagonal;
                if p.has("fov_axis") {
                    p.string("fov_axis")?;
                }
            }
        }
        if !(cam.fov_deg > 0.0 && cam.fov_deg < 180.0) {
            return Err(e.loc.error(format!("{}: field of view {} degrees is outside (0, 180)", e.describe(), cam.fov_deg)));
        }
        cam.near_clip = p.float_or("near_clip", 1e-2)?;
        if cam.near_clip < 0.0 {
            return Err(e.loc.error(format!("{}: near_clip {} must not be negative", e.describe(), cam.near_clip)));
        }
        cam.validate().map_err(|msg| e.loc.error(format!("{}: {msg}", e.describe())))?;
        // Accepted without effect: the far plane lies beyond every scene we render, and the
        // focus settings only matter for thin lenses, which are not supported.
        p.accept(&["far_clip", "focus_distance", "aperture_radius", "shutter_open", "shutter_close"]);
        for axis in ["principal_point_offset_x", "principal_point_offset_y"] {
            if p.float(axis)?.is_some_and(|v| v != 0.0) {
                self.warn(e, format!("{axis} is not supported; the principal point stays at the image centre"));
            }
        }
        p.finish(&mut self.warnings);
        self.desc.film = film;
        if spp.is_some() {
            self.desc.hints.spp = spp;
        }
        Ok(true)
    }

    pub(super) fn film(&mut self, e: &'t Elem) -> Result<FilmDesc, IoError> {
        let ty = e.req_attr("type")?;
        if !matches!(ty, "hdrfilm" | "ldrfilm") {
            self.warn(e, format!("film type \"{ty}\" is read as an hdrfilm"));
        }
        let p = self.props(e)?;
        let mut size = [DEFAULT_FILM.width, DEFAULT_FILM.height];
        for (k, name) in ["width", "height"].iter().enumerate() {
            if let Some(v) = p.int(name)? {
                if !(1..=1 << 15).contains(&v) {
                    return Err(e.loc.error(format!("{}: {name} {v} is outside 1..32768", e.describe())));
                }
                size[k] = v as u32;
            }
        }
        octolux::budget::check_film(size[0] as u64, size[1] as u64).map_err(|b| e.loc.error(format!("{}: {b}", e.describe())))?;
        let mut filter = DEFAULT_FILM.filter;
        let mut seen = false;
        for (i, o) in p.objects() {
            if o.target.tag != "rfilter" {
                continue;
            }
            p.mark(i);
            if seen {
                return Err(o.elem.loc.error("a film can only have one reconstruction filter"));
            }
            seen = true;
            filter = self.rfilter(o.target)?;
        }
        // Mitsuba 0.6's `highQualityEdges` (Mitsuba 3's `sample_border`): also sample the band
        // outside the film that the filter reaches from the edge pixels (`octolux::render`).
        let mut sample_border = false;
        for name in ["high_quality_edges", "sample_border"] {
            sample_border |= p.bool_or(name, false)?;
        }
        // 0.6's hdrfilm has no `gamma` (its ldrfilm does): 0.6 ignores it.
        if ty == "hdrfilm" {
            self.not_mitsuba_params(&p, &["gamma"], "hdrfilm");
        }
        // Output format only (Mitsuba 0.6's `banner` and `attach_log` change the file's metadata).
        p.accept(&["pixel_format", "component_format", "file_format", "banner", "attach_log"]);
        p.finish(&mut self.warnings);
        Ok(FilmDesc { width: size[0], height: size[1], filter, sample_border })
    }

    pub(super) fn rfilter(&mut self, e: &'t Elem) -> Result<PixelFilter, IoError> {
        let ty = e.req_attr("type")?;
        let p = self.props(e)?;
        let f = match ty {
            "box" => {
                if p.float("radius")?.is_some_and(|r| r != 0.5) {
                    self.warn(e, "only the default box radius 0.5 is supported");
                }
                PixelFilter::Box
            }
            "tent" => {
                if p.float("radius")?.is_some_and(|r| r != 1.0) {
                    self.warn(e, "only the default tent radius 1 is supported");
                }
                PixelFilter::Tent
            }
            "gaussian" => {
                let stddev = p.float_or("stddev", 0.5)?;
                if stddev <= 0.0 {
                    return Err(e.loc.error(format!("{}: stddev {stddev} must be positive", e.describe())));
                }
                PixelFilter::Gaussian { stddev }
            }
            other => {
                self.warn(e, format!("reconstruction filter \"{other}\" is not supported; using Mitsuba's default gaussian (stddev 0.5)"));
                p.accept_all();
                PixelFilter::Gaussian { stddev: 0.5 }
            }
        };
        p.finish(&mut self.warnings);
        Ok(f)
    }

    pub(super) fn sampler(&mut self, e: &'t Elem) -> Result<u32, IoError> {
        let p = self.props(e)?;
        let n = p.int("sample_count")?.unwrap_or(4);
        if n < 1 {
            return Err(e.loc.error(format!("{}: sample_count {n} must be positive", e.describe())));
        }
        if n > u32::MAX as i64 {
            return Err(e.loc.error(format!("{}: sample_count {n} is too large (at most {})", e.describe(), u32::MAX)));
        }
        // The sampler type and its settings only change the noise pattern.
        p.accept_all();
        Ok(n as u32)
    }
}
