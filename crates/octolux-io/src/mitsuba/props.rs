//! Typed access to the properties of one Mitsuba plugin element (`<float name="fov" .../>`,
//! `<rgb>`, `<transform>`, nested objects, `<ref>`), with the value syntax of Mitsuba 3:
//! lists separated by commas and/or spaces, `value="x"` expanding to x = y = z, transform
//! operations composed in document order (each new operation left-multiplies).
//!
//! Every lookup marks the property as used; [`Props::finish`] then reports each property
//! nobody asked for as one warning (file, line, element), which is how unsupported
//! parameters such as `banner` or `strict_normals` are reported. Numbers must be finite.

use super::spectra;
use super::tree::Elem;
use crate::IoError;
use glam::{Mat4, Vec3};
use octolux::math::{Color, Frame};
use std::cell::Cell;
use std::collections::HashMap;

/// Property tags (anything else is a nested object or a `<ref>`).
const VALUE_TAGS: &[&str] =
    &["boolean", "integer", "float", "string", "point", "vector", "rgb", "srgb", "transform", "animation", "blackbody"];

/// `true` when the element is a property rather than a nested object.
pub(crate) fn is_value(e: &Elem) -> bool {
    VALUE_TAGS.contains(&e.tag.as_str()) || (e.tag == "spectrum" && e.attr("type").is_none())
}

/// What a colour property describes; decides clamping like Mitsuba's RGB variants.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ColorKind {
    /// Reflectance-like: spectra are clamped to [0, 1].
    Bounded,
    /// Complex IOR and other unbounded values: spectra are only clamped to >= 0.
    Unbounded,
    /// Emitted radiance, intensity or irradiance: unbounded, and a single-valued `<spectrum>`
    /// is an equal-energy spectrum of that value, converted to linear sRGB as Mitsuba 3 does in
    /// its RGB variants (about (1.205, 0.948, 0.909) times the value: E is reddish next to
    /// sRGB's D65 white). Measured with Mitsuba 3.9.1 (`scalar_rgb`, `llvm_ad_rgb`): an area
    /// or constant emitter of `<spectrum value="1"/>` renders (1.2048, 0.9483, 0.9089), one of
    /// `<rgb value="1"/>` renders (1, 1, 1); a reflectance `<spectrum value="0.5"/>` stays grey.
    Emission,
}

/// A colour-valued parameter: a constant or a texture object (to be built by the caller).
pub(crate) enum Spec<'t> {
    Const(Color),
    Texture(&'t Elem),
}

/// One child of a plugin element: `elem` as written, `target` the element it stands for
/// (the referenced object for a `<ref>`).
pub(crate) struct Entry<'t> {
    pub name: Option<&'t str>,
    pub elem: &'t Elem,
    pub target: &'t Elem,
}

/// The properties and nested objects of one plugin element.
pub(crate) struct Props<'t> {
    pub owner: &'t Elem,
    entries: Vec<Entry<'t>>,
    used: Vec<Cell<bool>>,
}

/// Split a list of numbers written with commas and/or white space.
pub(crate) fn tokens(s: &str) -> Vec<&str> {
    s.split(|c: char| c == ',' || c.is_whitespace()).filter(|t| !t.is_empty()).collect()
}

/// Parse a finite float written in `e`.
pub(crate) fn parse_f32(e: &Elem, s: &str) -> Result<f32, IoError> {
    let v: f32 = s.trim().parse().map_err(|_| e.loc.error(format!("{}: could not parse the number \"{s}\"", e.describe())))?;
    if !v.is_finite() {
        return Err(e.loc.error(format!("{}: \"{s}\" is not a finite number", e.describe())));
    }
    Ok(v)
}

fn parse_list(e: &Elem, s: &str) -> Result<Vec<f32>, IoError> {
    tokens(s).into_iter().map(|t| parse_f32(e, t)).collect()
}

/// A three-component attribute such as `origin="0, 1, 2"`.
fn parse_vec3_attr(e: &Elem, attr: &str) -> Result<Vec3, IoError> {
    let s = e.req_attr(attr)?;
    let v = parse_list(e, s)?;
    if v.len() != 3 {
        return Err(e.loc.error(format!("{}: \"{attr}\" must have exactly 3 values, not \"{s}\"", e.describe())));
    }
    Ok(Vec3::new(v[0], v[1], v[2]))
}

/// `x`/`y`/`z` attributes, or `value` holding 1 (all three) or 3 numbers; missing ones are `default`.
fn parse_xyz(e: &Elem, default: f32) -> Result<Vec3, IoError> {
    if let Some(v) = e.attr("value") {
        if e.attr("x").is_some() || e.attr("y").is_some() || e.attr("z").is_some() {
            return Err(e.loc.error(format!("{}: can't mix \"value\" and \"x\"/\"y\"/\"z\" attributes", e.describe())));
        }
        let l = parse_list(e, v)?;
        return match l.len() {
            1 => Ok(Vec3::splat(l[0])),
            3 => Ok(Vec3::new(l[0], l[1], l[2])),
            _ => Err(e.loc.error(format!("{}: \"value\" must have 1 or 3 numbers, not \"{v}\"", e.describe()))),
        };
    }
    let c = |a: &str| e.attr(a).map(|s| parse_f32(e, s)).transpose().map(|v| v.unwrap_or(default));
    Ok(Vec3::new(c("x")?, c("y")?, c("z")?))
}

/// Compose the operations of a `<transform>` element (each new one left-multiplies).
pub(crate) fn parse_transform(t: &Elem) -> Result<Mat4, IoError> {
    let mut m = Mat4::IDENTITY;
    for op in &t.children {
        let om = match op.tag.as_str() {
            "translate" => Mat4::from_translation(parse_xyz(op, 0.0)?),
            "scale" => Mat4::from_scale(parse_xyz(op, 1.0)?),
            "rotate" => {
                let axis = parse_xyz(op, 0.0)?;
                let angle = parse_f32(op, op.req_attr("angle")?)?;
                if axis.length_squared() == 0.0 {
                    return Err(op.loc.error(format!("{}: the rotation axis is zero", op.describe())));
                }
                Mat4::from_axis_angle(axis.normalize(), angle.to_radians())
            }
            "lookat" => {
                let origin = parse_vec3_attr(op, "origin")?;
                let target = parse_vec3_attr(op, "target")?;
                let mut up = if op.attr("up").is_some() { parse_vec3_attr(op, "up")? } else { Vec3::ZERO };
                if up.length_squared() == 0.0 {
                    up = Frame::from_normal((target - origin).normalize()).s;
                }
                let r = octolux::scene::camera::look_at(origin, target, up);
                if !r.is_finite() {
                    return Err(op.loc.error(format!(
                        "{}: invalid lookat transformation (origin equals target, or up is parallel to the view direction)",
                        op.describe()
                    )));
                }
                r
            }
            "matrix" => {
                let s = op.req_attr("value")?;
                let v = parse_list(op, s)?;
                match v.len() {
                    16 => Mat4::from_cols_slice(&v).transpose(),
                    9 => {
                        let r = |i: usize, j: usize| v[i * 3 + j];
                        Mat4::from_cols_array(&[
                            r(0, 0),
                            r(1, 0),
                            r(2, 0),
                            0.0,
                            r(0, 1),
                            r(1, 1),
                            r(2, 1),
                            0.0,
                            r(0, 2),
                            r(1, 2),
                            r(2, 2),
                            0.0,
                            0.0,
                            0.0,
                            0.0,
                            1.0,
                        ])
                    }
                    n => return Err(op.loc.error(format!("{}: a matrix needs 16 (or 9) values, got {n}", op.describe()))),
                }
            }
            other => {
                return Err(op
                    .loc
                    .error(format!("<{other}> cannot appear inside {} (only translate, scale, rotate, lookat, matrix)", t.describe())))
            }
        };
        m = om * m;
    }
    Ok(m)
}

/// Parse `#rrggbb` (sRGB-encoded) into linear RGB.
fn parse_hex(e: &Elem, s: &str) -> Result<Color, IoError> {
    let h = s.trim().trim_start_matches('#');
    let bad = || e.loc.error(format!("{}: could not parse the colour \"{s}\"", e.describe()));
    if h.len() != 6 || !h.is_ascii() {
        return Err(bad());
    }
    let mut c = [0.0f32; 3];
    for (k, v) in c.iter_mut().enumerate() {
        let byte = u8::from_str_radix(&h[2 * k..2 * k + 2], 16).map_err(|_| bad())?;
        *v = spectra::srgb_to_linear(byte as f32 / 255.0);
    }
    Ok(Color::from_array(c))
}

/// Parse a colour value element (`rgb`, `srgb`, `spectrum` without type, `float`, `integer`);
/// `warnings` receives a note when a spectrum had to be clamped, and when a reflectance-like
/// value (a [`ColorKind::Bounded`] one: reflectance, opacity, blend weight) is above 1. Negative
/// values are errors.
pub(crate) fn parse_color(e: &Elem, kind: ColorKind, warnings: &mut Vec<String>) -> Result<Color, IoError> {
    let c = parse_color_unchecked(e, kind, warnings)?;
    if c.min_element() < 0.0 {
        return Err(e.loc.error(format!("{}: colour {c} has a negative component", e.describe())));
    }
    if kind == ColorKind::Bounded && c.max_element() > 1.0 {
        let v = if c.x == c.y && c.y == c.z { c.x.to_string() } else { c.to_string() };
        warnings.push(e.warning(format!(
            "{v} is above 1: a reflectance over 1 creates light (an opacity or a blend weight is read as 1); kept as given"
        )));
    }
    Ok(c)
}

fn parse_color_unchecked(e: &Elem, kind: ColorKind, warnings: &mut Vec<String>) -> Result<Color, IoError> {
    match e.tag.as_str() {
        "rgb" | "srgb" => {
            let s = e.req_attr("value")?;
            if s.trim_start().starts_with('#') {
                return parse_hex(e, s);
            }
            let v = parse_list(e, s)?;
            let c = match v.len() {
                1 => Color::splat(v[0]),
                3 => Color::new(v[0], v[1], v[2]),
                _ => return Err(e.loc.error(format!("{}: needs one or three values, not \"{s}\"", e.describe()))),
            };
            Ok(if e.tag == "srgb" { c.map(spectra::srgb_to_linear) } else { c })
        }
        "float" | "integer" => Ok(Color::splat(parse_f32(e, e.req_attr("value")?)?)),
        "spectrum" => {
            let (wl, vals) = match (e.attr("value"), e.attr("filename")) {
                (Some(v), None) => {
                    let toks = tokens(v);
                    if toks.len() == 1 && !toks[0].contains(':') {
                        let v = parse_f32(e, toks[0])?;
                        return Ok(match kind {
                            ColorKind::Emission => spectra::equal_energy_rgb() * v,
                            ColorKind::Bounded | ColorKind::Unbounded => Color::splat(v),
                        });
                    }
                    let mut wl = Vec::new();
                    let mut vals = Vec::new();
                    for t in toks {
                        let (a, b) = t
                            .split_once(':')
                            .ok_or_else(|| e.loc.error(format!("{}: expected wavelength:value pairs, found \"{t}\"", e.describe())))?;
                        wl.push(parse_f32(e, a)? as f64);
                        vals.push(parse_f32(e, b)? as f64);
                    }
                    (wl, vals)
                }
                (None, Some(f)) => {
                    let path = super::tree::resolve_file(&e.loc, f, e.loc.dir(), &[])
                        .ok_or_else(|| e.loc.error(format!("{}: spectrum file \"{f}\" not found", e.describe())))?;
                    read_spd(e, &path)?
                }
                _ => return Err(e.loc.error(format!("{}: needs exactly one of \"value\" or \"filename\"", e.describe()))),
            };
            if wl.len() < 2 {
                return Err(e.loc.error(format!("{}: a sampled spectrum needs at least two wavelengths", e.describe())));
            }
            if wl.windows(2).any(|w| w[1] <= w[0]) {
                return Err(e.loc.error(format!("{}: wavelengths must be given in increasing order", e.describe())));
            }
            let (c, clamped) = spectra::spectrum_to_rgb(&wl, &vals, kind == ColorKind::Bounded);
            if clamped {
                warnings.push(e.warning(format!("spectrum is out of the RGB gamut; clamped to {c}")));
            }
            Ok(c)
        }
        other => Err(e.loc.error(format!("<{other}> is not a colour value"))),
    }
}

/// Read a Mitsuba `.spd` file (lines of `wavelength value`, `#` comments).
fn read_spd(e: &Elem, path: &std::path::Path) -> Result<(Vec<f64>, Vec<f64>), IoError> {
    let text = crate::files::read_to_string(path)?;
    let (mut wl, mut vals) = (Vec::new(), Vec::new());
    for (i, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let t: Vec<&str> = line.split_whitespace().collect();
        let parse = |s: &str| s.parse::<f64>().ok().filter(|v| v.is_finite());
        match (t.len(), t.first().and_then(|s| parse(s)), t.get(1).and_then(|s| parse(s))) {
            (2, Some(a), Some(b)) => {
                wl.push(a);
                vals.push(b);
            }
            _ => return Err(IoError::parse(path, i as u32 + 1, format!("expected \"wavelength value\" (referenced from {})", e.loc))),
        }
    }
    Ok((wl, vals))
}

impl<'t> Props<'t> {
    /// Gather the children of `owner`, resolving `<ref id>` through `ids`.
    pub fn new(owner: &'t Elem, ids: &HashMap<String, &'t Elem>) -> Result<Props<'t>, IoError> {
        let mut entries: Vec<Entry<'t>> = Vec::new();
        for c in &owner.children {
            let target = if c.tag == "ref" {
                let id = c.req_attr("id")?;
                ids.get(id).copied().ok_or_else(|| c.loc.error(format!("reference to unknown id \"{id}\"")))?
            } else {
                c
            };
            let name = c.attr("name");
            if let Some(n) = name {
                if let Some(prev) = entries.iter().find(|p| p.name == Some(n)) {
                    return Err(c.loc.error(format!(
                        "parameter \"{n}\" of {} is given twice (first at {})",
                        owner.describe(),
                        prev.elem.loc
                    )));
                }
            }
            entries.push(Entry { name, elem: c, target });
        }
        let used = entries.iter().map(|_| Cell::new(false)).collect();
        Ok(Props { owner, entries, used })
    }

    /// The entry called `name` (marked as used).
    pub fn get(&self, name: &str) -> Option<&Entry<'t>> {
        let i = self.entries.iter().position(|p| p.name == Some(name))?;
        self.used[i].set(true);
        Some(&self.entries[i])
    }

    pub fn has(&self, name: &str) -> bool {
        self.entries.iter().any(|p| p.name == Some(name))
    }

    /// Mark a parameter as used without reading it (accepted and deliberately ignored).
    pub fn accept(&self, names: &[&str]) {
        for n in names {
            self.get(n);
        }
    }

    fn expect(&self, p: &Entry<'t>, tags: &[&str], what: &str) -> Result<&'t Elem, IoError> {
        if tags.contains(&p.target.tag.as_str()) {
            Ok(p.target)
        } else {
            Err(p.elem.loc.error(format!(
                "parameter \"{}\" of {} must be {what}, not <{}>",
                p.name.unwrap_or(""),
                self.owner.describe(),
                p.target.tag
            )))
        }
    }

    pub fn float(&self, name: &str) -> Result<Option<f32>, IoError> {
        let Some(p) = self.get(name) else { return Ok(None) };
        let e = self.expect(p, &["float", "integer"], "a <float>")?;
        parse_f32(e, e.req_attr("value")?).map(Some)
    }

    pub fn float_or(&self, name: &str, default: f32) -> Result<f32, IoError> {
        Ok(self.float(name)?.unwrap_or(default))
    }

    pub fn int(&self, name: &str) -> Result<Option<i64>, IoError> {
        let Some(p) = self.get(name) else { return Ok(None) };
        let e = self.expect(p, &["integer", "float"], "an <integer>")?;
        let s = e.req_attr("value")?.trim();
        match s.parse::<i64>() {
            Ok(v) => Ok(Some(v)),
            Err(_) => {
                let f = parse_f32(e, s)?;
                if f.fract() == 0.0 && f.abs() < 9.0e15 {
                    Ok(Some(f as i64))
                } else {
                    Err(e.loc.error(format!("{}: could not parse the integer \"{s}\"", e.describe())))
                }
            }
        }
    }

    pub fn boolean(&self, name: &str) -> Result<Option<bool>, IoError> {
        let Some(p) = self.get(name) else { return Ok(None) };
        let e = self.expect(p, &["boolean"], "a <boolean>")?;
        match e.req_attr("value")?.trim().to_ascii_lowercase().as_str() {
            "true" => Ok(Some(true)),
            "false" => Ok(Some(false)),
            v => Err(e.loc.error(format!("{}: \"{v}\" is not a boolean (true or false)", e.describe()))),
        }
    }

    pub fn bool_or(&self, name: &str, default: bool) -> Result<bool, IoError> {
        Ok(self.boolean(name)?.unwrap_or(default))
    }

    pub fn string(&self, name: &str) -> Result<Option<&'t str>, IoError> {
        let Some(p) = self.get(name) else { return Ok(None) };
        let e = self.expect(p, &["string"], "a <string>")?;
        e.req_attr("value").map(Some)
    }

    /// A `<point>` or `<vector>`.
    pub fn vec3(&self, name: &str) -> Result<Option<Vec3>, IoError> {
        let Some(p) = self.get(name) else { return Ok(None) };
        let e = self.expect(p, &["point", "vector"], "a <point> or <vector>")?;
        parse_xyz(e, 0.0).map(Some)
    }

    pub fn transform(&self, name: &str) -> Result<Option<Mat4>, IoError> {
        let Some(p) = self.get(name) else { return Ok(None) };
        let e = self.expect(p, &["transform"], "a <transform>")?;
        parse_transform(e).map(Some)
    }

    /// A colour or texture parameter.
    pub fn spec(&self, name: &str, kind: ColorKind, warnings: &mut Vec<String>) -> Result<Option<Spec<'t>>, IoError> {
        let Some(p) = self.get(name) else { return Ok(None) };
        let e = p.target;
        if is_value(e) {
            if e.tag == "blackbody" {
                warnings.push(e.warning("blackbody spectra are not supported in RGB; the parameter keeps its default"));
                return Ok(None);
            }
            if e.tag == "string" || e.tag == "boolean" {
                return Err(p.elem.loc.error(format!(
                    "parameter \"{name}\" of {} must be a colour, not <{}>",
                    self.owner.describe(),
                    e.tag
                )));
            }
            return parse_color(e, kind, warnings).map(|c| Some(Spec::Const(c)));
        }
        Ok(Some(Spec::Texture(e)))
    }

    /// Mark every parameter as used (for plugins replaced as a whole by a fallback).
    pub fn accept_all(&self) {
        for u in &self.used {
            u.set(true);
        }
    }

    /// Nested objects (and resolved refs) in document order, whether or not they carry a name.
    pub fn objects(&self) -> impl Iterator<Item = (usize, &Entry<'t>)> {
        self.entries.iter().enumerate().filter(|(_, p)| !is_value(p.target))
    }

    /// Mark entry `i` (from [`Props::objects`]) as used.
    pub fn mark(&self, i: usize) {
        self.used[i].set(true);
    }

    /// Names of the parameters (values, not nested objects) nobody used, in document order;
    /// they are marked as used, so that [`Props::finish`] does not report them again.
    pub fn take_unused_values(&self) -> Vec<&'t str> {
        let mut names = Vec::new();
        for (p, used) in self.entries.iter().zip(&self.used) {
            if !used.get() && is_value(p.target) {
                names.push(p.name.unwrap_or("?"));
                used.set(true);
            }
        }
        names
    }

    /// One warning for every property or nested object nobody used.
    pub fn finish(&self, warnings: &mut Vec<String>) {
        for (p, used) in self.entries.iter().zip(&self.used) {
            if used.get() {
                continue;
            }
            let what = if is_value(p.target) {
                format!("parameter \"{}\" of {} is not supported and was ignored", p.name.unwrap_or("?"), self.owner.describe())
            } else {
                format!("{} inside {} is not supported here and was ignored", p.target.describe(), self.owner.describe())
            };
            warnings.push(format!("{}: <{}>: {what}", p.elem.loc, p.elem.tag));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mitsuba::tree::Loc;
    use std::path::PathBuf;
    use std::rc::Rc;

    fn op(tag: &str, attrs: &[(&str, &str)]) -> Elem {
        Elem {
            tag: tag.into(),
            attrs: attrs.iter().map(|(a, b)| (a.to_string(), b.to_string())).collect(),
            children: Vec::new(),
            loc: Loc { file: Rc::new(PathBuf::from("t.xml")), line: 7 },
            legacy: false,
        }
    }

    #[test]
    fn number_lists_accept_commas_and_spaces_and_reject_nan() {
        assert_eq!(tokens("1, 2,3  4"), vec!["1", "2", "3", "4"]);
        let e = op("float", &[]);
        assert!(parse_f32(&e, "nan").is_err());
        assert!(parse_f32(&e, "inf").is_err());
        let err = parse_f32(&e, "1.2.3").unwrap_err().to_string();
        assert!(err.contains("t.xml:7"), "{err}");
    }

    #[test]
    fn hex_and_srgb_colours_are_linearised() {
        let mut w = Vec::new();
        let c = parse_color(&op("srgb", &[("value", "#ff0000")]), ColorKind::Bounded, &mut w).unwrap();
        assert_eq!(c, Color::new(1.0, 0.0, 0.0));
        let c = parse_color(&op("srgb", &[("value", "0.5 0.5 0.5")]), ColorKind::Bounded, &mut w).unwrap();
        assert!((c.x - 0.214_041).abs() < 1e-5);
        let c = parse_color(&op("spectrum", &[("value", "0.25")]), ColorKind::Bounded, &mut w).unwrap();
        assert_eq!(c, Color::splat(0.25));
        assert!(parse_color(&op("spectrum", &[("value", "500:1, 400:1")]), ColorKind::Bounded, &mut w).is_err());
        assert!(parse_color(&op("rgb", &[("value", "0.5, -0.1, 0.2")]), ColorKind::Bounded, &mut w).is_err());
        // A sampled spectrum: 0.5 everywhere is a grey of luminance 0.5.
        let c = parse_color(&op("spectrum", &[("value", "360:0.5, 830:0.5")]), ColorKind::Bounded, &mut w).unwrap();
        assert!((octolux::math::luminance(c) - 0.5).abs() < 2e-3, "{c}");
        assert!(w.is_empty(), "{w:?}");
    }
}
