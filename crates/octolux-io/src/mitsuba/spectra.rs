//! Colour data needed to read Mitsuba scenes in RGB: the CIE 1931 2° observer, Mitsuba 3's
//! spectrum → linear sRGB conversion, its table of named dielectric IORs and the RGB values
//! its `conductor` presets take in RGB variants.
//!
//! Conventions (those of Mitsuba 3 `scalar_rgb`): a wavelength:value list is linearly
//! interpolated, integrated against the CIE curves on 1000 evenly spaced wavelengths in
//! [360, 830] nm, scaled so that a unit spectrum has luminance 1, converted with the Rec. 709
//! XYZ → RGB matrix and clamped to >= 0 (and to <= 1 for bounded quantities such as
//! reflectances).

use octolux::math::Color;

const CIE_MIN: f64 = 360.0;
const CIE_MAX: f64 = 830.0;
const CIE_SAMPLES: usize = 95;
/// Scale making a unit spectrum integrate to luminance 1 (Mitsuba's `MI_CIE_Y_NORMALIZATION`).
const CIE_Y_NORMALIZATION: f64 = 1.0 / 106.750_259_399_414_06;

const CIE_X: [f32; CIE_SAMPLES] = [
    0.0001299,
    0.0002321,
    0.0004149,
    0.0007416,
    0.001368,
    0.002236,
    0.004243,
    0.00765,
    0.01431,
    0.02319,
    0.04351,
    0.07763,
    0.13438,
    0.21477,
    0.2839,
    0.3285,
    0.34828,
    0.34806,
    0.3362,
    0.3187,
    0.2908,
    0.2511,
    0.19536,
    0.1421,
    0.09564,
    0.05795001,
    0.03201,
    0.0147,
    0.0049,
    0.0024,
    0.0093,
    0.0291,
    0.06327,
    0.1096,
    0.1655,
    0.2257499,
    0.2904,
    0.3597,
    0.4334499,
    0.5120501,
    0.5945,
    0.6784,
    0.7621,
    0.8425,
    0.9163,
    0.9786,
    1.0263,
    1.0567,
    1.0622,
    1.0456,
    1.0026,
    0.9384,
    0.8544499,
    0.7514,
    0.6424,
    0.5419,
    0.4479,
    0.3608,
    0.2835,
    0.2187,
    0.1649,
    0.1212,
    0.0874,
    0.0636,
    0.04677,
    0.0329,
    0.0227,
    0.01584,
    0.01135916,
    0.008110916,
    0.005790346,
    0.004109457,
    0.002899327,
    0.00204919,
    0.001439971,
    0.0009999493,
    0.0006900786,
    0.0004760213,
    0.0003323011,
    0.0002348261,
    0.0001661505,
    0.000117413,
    8.307527e-05,
    5.870652e-05,
    4.150994e-05,
    2.935326e-05,
    2.067383e-05,
    1.455977e-05,
    1.025398e-05,
    7.221456e-06,
    5.085868e-06,
    3.581652e-06,
    2.522525e-06,
    1.776509e-06,
    1.251141e-06,
];
const CIE_Y: [f32; CIE_SAMPLES] = [
    3.917e-06, 6.965e-06, 1.239e-05, 2.202e-05, 3.9e-05, 6.4e-05, 0.00012, 0.000217, 0.000396, 0.00064, 0.00121, 0.00218, 0.004, 0.0073,
    0.0116, 0.01684, 0.023, 0.0298, 0.038, 0.048, 0.06, 0.0739, 0.09098, 0.1126, 0.13902, 0.1693, 0.20802, 0.2586, 0.323, 0.4073, 0.503,
    0.6082, 0.71, 0.7932, 0.862, 0.9148501, 0.954, 0.9803, 0.9949501, 1.0, 0.995, 0.9786, 0.952, 0.9154, 0.87, 0.8163, 0.757, 0.6949,
    0.631, 0.5668, 0.503, 0.4412, 0.381, 0.321, 0.265, 0.217, 0.175, 0.1382, 0.107, 0.0816, 0.061, 0.04458, 0.032, 0.0232, 0.017, 0.01192,
    0.00821, 0.005723, 0.004102, 0.002929, 0.002091, 0.001484, 0.001047, 0.00074, 0.00052, 0.0003611, 0.0002492, 0.0001719, 0.00012,
    8.48e-05, 6e-05, 4.24e-05, 3e-05, 2.12e-05, 1.499e-05, 1.06e-05, 7.4657e-06, 5.2578e-06, 3.7029e-06, 2.6078e-06, 1.8366e-06,
    1.2934e-06, 9.1093e-07, 6.4153e-07, 4.5181e-07,
];
const CIE_Z: [f32; CIE_SAMPLES] = [
    0.0006061,
    0.001086,
    0.001946,
    0.003486,
    0.006450001,
    0.01054999,
    0.02005001,
    0.03621,
    0.06785001,
    0.1102,
    0.2074,
    0.3713,
    0.6456,
    1.0390501,
    1.3856,
    1.62296,
    1.74706,
    1.7826,
    1.77211,
    1.7441,
    1.6692,
    1.5281,
    1.28764,
    1.0419,
    0.8129501,
    0.6162,
    0.46518,
    0.3533,
    0.272,
    0.2123,
    0.1582,
    0.1117,
    0.07824999,
    0.05725001,
    0.04216,
    0.02984,
    0.0203,
    0.0134,
    0.008749999,
    0.005749999,
    0.0039,
    0.002749999,
    0.0021,
    0.0018,
    0.001650001,
    0.0014,
    0.0011,
    0.001,
    0.0008,
    0.0006,
    0.00034,
    0.00024,
    0.00019,
    0.0001,
    4.999999e-05,
    3e-05,
    2e-05,
    1e-05,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
    0.0,
];

/// CIE 1931 XYZ matching functions at `w` nm (linear interpolation of the 5 nm table, zero
/// outside [360, 830]).
fn cie_xyz(w: f64) -> [f64; 3] {
    if !(CIE_MIN..=CIE_MAX).contains(&w) {
        return [0.0; 3];
    }
    let t = (w - CIE_MIN) * ((CIE_SAMPLES - 1) as f64 / (CIE_MAX - CIE_MIN));
    let i0 = (t as usize).min(CIE_SAMPLES - 2);
    let f = t - i0 as f64;
    let lerp = |tab: &[f32; CIE_SAMPLES]| tab[i0] as f64 * (1.0 - f) + tab[i0 + 1] as f64 * f;
    [lerp(&CIE_X), lerp(&CIE_Y), lerp(&CIE_Z)]
}

/// Rec. 709 linear RGB from CIE XYZ.
fn xyz_to_rgb(c: [f64; 3]) -> [f64; 3] {
    [
        3.240479 * c[0] - 1.537150 * c[1] - 0.498535 * c[2],
        -0.969256 * c[0] + 1.875991 * c[1] + 0.041556 * c[2],
        0.055648 * c[0] - 0.204043 * c[1] + 1.057311 * c[2],
    ]
}

/// Convert a sampled spectrum (wavelengths in nm, strictly increasing, at least 2) to linear
/// RGB as Mitsuba 3 does in RGB mode. Returns the colour and whether it had to be clamped
/// (negative components, or components above 1 when `bounded`).
pub fn spectrum_to_rgb(wavelengths: &[f64], values: &[f64], bounded: bool) -> (Color, bool) {
    debug_assert!(wavelengths.len() == values.len() && wavelengths.len() >= 2);
    let (first, last) = (wavelengths[0], wavelengths[wavelengths.len() - 1]);
    let mut xyz = [0.0f64; 3];
    const STEPS: usize = 1000;
    for i in 0..STEPS {
        let w = CIE_MIN + (i as f64 / (STEPS - 1) as f64) * (CIE_MAX - CIE_MIN);
        if w < first || w > last {
            continue;
        }
        let idx = wavelengths.partition_point(|&x| x <= w).saturating_sub(1).min(wavelengths.len() - 2);
        let (w0, w1, v0, v1) = (wavelengths[idx], wavelengths[idx + 1], values[idx], values[idx + 1]);
        let v = ((w - w1) * v0 + (w0 - w) * v1) / (w0 - w1);
        let c = cie_xyz(w);
        for k in 0..3 {
            xyz[k] += c[k] * v;
        }
    }
    let scale = (CIE_MAX - CIE_MIN) / STEPS as f64 * CIE_Y_NORMALIZATION;
    let rgb = xyz_to_rgb([xyz[0] * scale, xyz[1] * scale, xyz[2] * scale]);
    let mut clamped = false;
    let mut out = [0.0f32; 3];
    for k in 0..3 {
        let mut v = rgb[k];
        if v < 0.0 {
            v = 0.0;
            clamped = true;
        }
        if bounded && v > 1.0 {
            v = 1.0;
            clamped = true;
        }
        out[k] = v as f32;
    }
    (Color::from_array(out), clamped)
}

/// Linear sRGB of the equal-energy spectrum of value 1 (CIE illuminant E at unit luminance):
/// what Mitsuba 3's RGB variants make of an emitter's single-valued `<spectrum>`.
pub fn equal_energy_rgb() -> Color {
    spectrum_to_rgb(&[CIE_MIN, CIE_MAX], &[1.0, 1.0], false).0
}

/// Inverse sRGB transfer function (encoded value in [0,1] -> linear).
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.040_45 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Mitsuba's table of named indices of refraction (Hecht, Optics; ~589 nm).
const IOR_TABLE: &[(&str, f32)] = &[
    ("vacuum", 1.0),
    ("helium", 1.000036),
    ("hydrogen", 1.000132),
    ("air", 1.000277),
    ("carbon dioxide", 1.00045),
    ("water", 1.3330),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.470),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.5750),
    ("diamond", 2.419),
];

/// Look up a named IOR (case-insensitive, as Mitsuba).
pub fn lookup_ior(name: &str) -> Option<f32> {
    let lower = name.trim().to_ascii_lowercase();
    IOR_TABLE.iter().find(|(n, _)| *n == lower).map(|(_, v)| *v)
}

/// Names accepted by [`lookup_ior`], for error messages.
pub fn ior_names() -> String {
    IOR_TABLE.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
}

/// RGB complex IOR `(eta, k)` of Mitsuba's conductor presets, as Mitsuba 3 computes them in RGB
/// mode: its measured spectra (`data/ior/<name>.{eta,k}.spd`, identical to the PBRT/Luxpop
/// data) passed through [`spectrum_to_rgb`] unbounded. The values were computed once with that
/// procedure and are listed here to avoid shipping the spectra.
const CONDUCTORS: &[(&str, [f32; 3], [f32; 3])] = &[
    ("Ag", [0.155276, 0.116728, 0.138388], [4.828355, 3.122222, 2.146901]),
    ("Al", [1.657501, 0.880405, 0.521244], [9.223811, 6.269502, 4.837004]),
    ("Au", [0.143036, 0.375307, 1.442045], [3.982997, 2.385556, 1.603359]),
    ("Cr", [4.369668, 2.916505, 1.654905], [5.206547, 4.231306, 3.754699]),
    ("Cu", [0.201006, 0.923749, 1.102215], [3.913262, 2.453045, 2.14209]),
];

/// `(eta, k)` of a conductor preset (case-sensitive like Mitsuba's file names); `"none"` is
/// octolux's perfect mirror `eta = k = 0`.
pub fn lookup_conductor(name: &str) -> Option<(Color, Color)> {
    if name == "none" {
        return Some((Color::ZERO, Color::ZERO));
    }
    CONDUCTORS.iter().find(|(n, _, _)| *n == name).map(|(_, e, k)| (Color::from_array(*e), Color::from_array(*k)))
}

/// Names accepted by [`lookup_conductor`], for messages.
pub fn conductor_names() -> String {
    let mut v: Vec<&str> = CONDUCTORS.iter().map(|(n, _, _)| *n).collect();
    v.push("none");
    v.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_spectrum_has_unit_luminance() {
        let (c, clamped) = spectrum_to_rgb(&[360.0, 830.0], &[1.0, 1.0], false);
        let y = octolux::math::luminance(c);
        assert!((y - 1.0).abs() < 2e-3, "luminance {y}");
        assert!(!clamped);
        // An equal-energy spectrum is reddish in sRGB (its white point is E, not D65).
        assert!(c.x > c.y && c.y > c.z, "{c}");
    }

    #[test]
    fn equal_energy_white_is_mitsubas() {
        // Mitsuba 3.9.1 renders an area emitter of <spectrum value="1"/> as this colour.
        let mitsuba = [1.204795f32, 0.948_291_5, 0.908_916_4];
        let c = equal_energy_rgb().to_array();
        for k in 0..3 {
            assert!((c[k] - mitsuba[k]).abs() < 2e-3, "{c:?} vs Mitsuba 3 {mitsuba:?}");
        }
    }

    #[test]
    fn copper_table_matches_its_spectrum() {
        // Mitsuba's data/ior/Cu.k.spd (Luxpop data), integrated again.
        let wl = [
            302.400421, 306.133759, 309.960449, 313.884003, 317.908142, 322.036835, 326.274139, 330.624481, 335.092377, 339.682678,
            344.400482, 349.251221, 354.240509, 359.374420, 364.659332, 370.102020, 375.709625, 381.489777, 387.450562, 393.600555,
            399.948975, 406.505493, 413.280579, 420.285339, 427.531647, 435.032196, 442.800629, 450.851562, 459.200653, 467.864838,
            476.862213, 486.212463, 495.936707, 506.057861, 516.600769, 527.592224, 539.061646, 551.040771, 563.564453, 576.670593,
            590.400818, 604.800842, 619.920898, 635.816284, 652.548279, 670.184753, 688.800964, 708.481018, 729.318665, 751.419250,
            774.901123, 799.897949, 826.561157, 855.063293, 885.601257,
        ];
        let k = [
            1.687000, 1.703313, 1.720000, 1.744563, 1.770000, 1.791625, 1.810000, 1.822125, 1.834000, 1.851750, 1.872000, 1.894250,
            1.916000, 1.931688, 1.950000, 1.972438, 2.015000, 2.121562, 2.210000, 2.177188, 2.130000, 2.160063, 2.210000, 2.249938,
            2.289000, 2.326000, 2.362000, 2.397625, 2.433000, 2.469187, 2.504000, 2.535875, 2.564000, 2.589625, 2.605000, 2.595562,
            2.583000, 2.576500, 2.599000, 2.678062, 2.809000, 3.010750, 3.240000, 3.458187, 3.670000, 3.863125, 4.050000, 4.239563,
            4.430000, 4.619563, 4.817000, 5.034125, 5.260000, 5.485625, 5.717000,
        ];
        let (c, _) = spectrum_to_rgb(&wl, &k, false);
        let (_, k_tab) = lookup_conductor("Cu").unwrap();
        assert!((c - k_tab).abs().max_element() < 1e-4, "{c} vs {k_tab}");
        assert_eq!(lookup_conductor("none"), Some((Color::ZERO, Color::ZERO)));
        assert!(lookup_conductor("Unobtainium").is_none());
    }

    #[test]
    fn ior_lookup_is_case_insensitive() {
        assert_eq!(lookup_ior("BK7"), Some(1.5046));
        assert_eq!(lookup_ior("water"), Some(1.333));
        assert!(lookup_ior("glass").is_none());
    }

    #[test]
    fn reflectance_spectra_are_bounded() {
        let (c, clamped) = spectrum_to_rgb(&[360.0, 830.0], &[2.0, 2.0], true);
        assert!(clamped);
        assert!(c.max_element() <= 1.0);
    }
}
