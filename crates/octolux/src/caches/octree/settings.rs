//! User settings of the incident-radiance octree and their validation (paper §3, §5, §7).
//!
//! Defaults are the paper's configuration where it states one (`h_max = 6`, `epsilon = 0.2`,
//! `alpha = 1.5`, the paper's estimator, compressed storage). For the values the paper leaves
//! open, see the field docs; every choice is a setting, never hidden.

use super::OctreeError;
use serde::{Deserialize, Serialize};

/// Density estimator that turns the photons of a (possibly enlarged) cell into the six
/// incident-radiance matrices. See the derivation in the `caches::octree` module docs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Estimator {
    /// The paper's eq. 5.4: `M = (1/ΔA) Σ w_p C_pᵀ`, `ΔA` = area of one face of the
    /// (enlarged) cell. Estimates `(A/ΔA) ∫ L(w) cosθ w dω`: too dark at grazing incidence.
    #[default]
    Paper,
    /// Each photon divided by `max(|w_p·ng_p|, min_cos)`, `ΔA` as the paper: estimates
    /// `(A/ΔA) ∫ L(w) w dω`, exact for one plane crossing the cell parallel to a face.
    Cosine,
    /// `1/cos` and `ΔA` replaced by the lit geometry inside the (enlarged) cell: each photon
    /// is divided by the lit projected area `A⊥(w_p)` of the given triangles clipped to the
    /// cell (the paper's own proposed fix, §7/§8). Needs the triangle list at build time.
    GeometryArea,
}

/// How a photon is assigned to the six axis matrices `M_a^±` (§5.2). The query is the
/// paper's in both cases: `M(N) = Σ_a M_a^{s(N_a)} N_a²`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Split {
    /// The paper's: a photon belongs to `M_a^{sign(w_a)}` for each axis, by the sign of its
    /// incident direction `w`. For a surface whose normal is not along an axis, the matrices
    /// read by the query miss the photons whose `w` lies on the other side of an axis: under a
    /// uniform incident field a plane tilted by 17° reads 5% too little irradiance, 30° 11%,
    /// 45° 15% (the rotated blocks of the Cornell box come out about 15% too dark).
    #[default]
    Direction,
    /// By the surface the photon landed on: a photon with geometric normal `ng` adds to
    /// `M_a^{sign(ng_a)}` with weight `ng_a² / Σ_b ng_b⁴` for each axis with `ng_a ≠ 0`. For a
    /// plane of any orientation the query then returns exactly its irradiance vector
    /// (`Σ_a N_a² · N_a²/Σ_b N_b⁴ = 1`), and surfaces that face different half-axes
    /// (a floor and a wall in a corner) stay in different matrices. Needs the photons' normals.
    Normal,
}

/// How the leaf matrices are kept in memory.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Storage {
    /// Paper §6: 6 bytes per matrix (θ/φ direction bytes + RGBE), 36 bytes per leaf.
    #[default]
    Compressed,
    /// Six full 3x3 f32 matrices, 216 bytes per leaf.
    Full,
}

/// Which leaves gather photons from the `epsilon`-enlarged cell (an open point of §3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Enlarge {
    /// Every valid leaf uses the enlarged cell. This is the default: §3 defines `epsilon` as a
    /// property of the cell ("virtually enlarges the cell"), fig. 3 shows it acting on the
    /// whole image, and enlarging every leaf also overlaps neighbouring estimates, which
    /// lowers the jumps between leaves.
    #[default]
    All,
    /// Only leaves with fewer than `n_min` photons of their own are enlarged (the reading
    /// "to gather more photons when the density is too low").
    UnderNMin,
}

/// The depth limit `h_max` of an octree: a fixed depth (root = 0), or `auto`, derived at
/// build time from the photon count, `n_max` and the scene's surface area
/// ([`auto_depth`]). Serde: a number or the string `"auto"`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Depth {
    Auto,
    Fixed(u32),
}

impl Serialize for Depth {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Depth::Auto => s.serialize_str("auto"),
            Depth::Fixed(d) => s.serialize_u32(*d),
        }
    }
}

impl<'de> Deserialize<'de> for Depth {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl serde::de::Visitor<'_> for V {
            type Value = Depth;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                write!(f, "a depth from 0 to {MAX_DEPTH} or \"auto\"")
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Depth, E> {
                u32::try_from(v).map(Depth::Fixed).map_err(|_| E::custom(format!("h_max = {v} is above the maximum depth {MAX_DEPTH}")))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Depth, E> {
                u64::try_from(v).map_err(|_| E::custom(format!("h_max = {v} is negative"))).and_then(|v| self.visit_u64(v))
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Depth, E> {
                match v {
                    "auto" => Ok(Depth::Auto),
                    _ => Err(E::custom(format!("h_max = \"{v}\": expected a depth from 0 to {MAX_DEPTH} or \"auto\""))),
                }
            }
        }
        d.deserialize_any(V)
    }
}

/// Levels of headroom of the automatic depth below the depth of the *average* leaf: with the
/// rounding up, leaves may still split to `n_max` where the photon density is 32 to 128 times
/// the scene's average (see [`auto_depth`]). Measured (160x90 and 128², 250k and 1M photons,
/// `docs/guide/octree.md`): 1.5 levels left veach-lamp's bright lamp too coarse at 250k photons
/// (relMSE 0.96 against 0.48 one level deeper) and sponza at 1M (0.0117 against 0.0095);
/// one more level changed nothing on the Cornell boxes, whose leaves stop splitting first.
pub const AUTO_HEADROOM: f64 = 2.5;

/// The automatic depth limit (`h_max = "auto"`).
///
/// Derivation. `n` photons stored on surfaces of total area `A` (scene units²) have a mean
/// density `n / A`. A leaf of edge `s` crossed by a surface holds about `s²` of it (exactly
/// for a plane parallel to a face), so it holds `n_max` photons, the split threshold, where
/// `s* = sqrt(n_max A / n)`: the size of a leaf where the light is average. The root cube of
/// edge `S` reaches it at depth `log2(S / s*)`. The limit adds [`AUTO_HEADROOM`] levels, so
/// that brighter regions (32 to 128x the mean density) are still split down to `n_max`
/// photons, and rounds up: `h = ceil(log2(S / s*) + AUTO_HEADROOM)`, clamped to
/// `[1, MAX_DEPTH]`. The ratio `A / S²` and the photon count fix it: a scene scaled by any
/// factor gets the same depth (the same leaves relative to the scene), a house (large `A / S²`)
/// gets leaves sized to its photon density rather than to a Cornell box's, and 4x the photons
/// give one more level. On the paper's Cornell box (`A ≈ 6.4 S²`, ~1M photons, `n_max` 500)
/// it gives 7, one above the paper's 6; at that photon count no leaf splits below 6 there.
pub fn auto_depth(photons: usize, area: f64, cube_edge: f64, n_max: u32) -> u32 {
    if photons == 0 || !(area > 0.0) || !(cube_edge > 0.0) || !area.is_finite() || !cube_edge.is_finite() {
        return 1;
    }
    let leaf = (n_max.max(1) as f64 * area / photons as f64).sqrt();
    let h = ((cube_edge / leaf).log2() + AUTO_HEADROOM).ceil();
    if h.is_nan() {
        return 1;
    }
    h.clamp(1.0, MAX_DEPTH as f64) as u32
}

/// Settings of [`super::Octree::build`] and of its queries. Serde: every field optional.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OctreeSettings {
    /// Maximum depth (root = depth 0): fixed, or `auto` ([`auto_depth`]). Paper: 6, the
    /// default here; the `octree` integrator's default for its global tree is `auto`. At most
    /// 21 (63-bit Morton keys).
    pub h_max: Depth,
    /// Least photon count for a trustworthy leaf. Used by `Enlarge::UnderNMin` and by
    /// `split_respects_n_min`. Default 50 (a tenth of `n_max`: ~14% relative noise).
    pub n_min: u32,
    /// A cell with more than `n_max` photons is split (until `h_max`). Default 500. The paper
    /// gives no value; its table 1 reports 1834 valid leaves, 205 photons per leaf and a mean
    /// cell size of 30.69 (≈ 0.055 of a 555-unit Cornell box) for ≈ 376k photons at
    /// `h_max = 6`. On a synthetic Cornell distribution (the same photon count on the walls
    /// of a box) `n_max = 500` gives 1675 leaves, 224 photons per leaf and cells of 0.055 of
    /// the box; 400 gives 2240 leaves of 168 photons (test `default_n_max_matches_table_1`).
    pub n_max: u32,
    /// Cell enlargement for the photon gathering: the enlarged cell has edge `(1+epsilon) s`,
    /// same centre. Paper: 0.2 (fig. 3 also shows 0.6).
    pub epsilon: f32,
    /// Query box side = `alpha` × smallest leaf edge (§7). Paper: 1.5.
    pub alpha: f32,
    pub estimator: Estimator,
    pub split: Split,
    pub storage: Storage,
    pub enlarge: Enlarge,
    /// When true, a split that would leave a non-empty child with fewer than `n_min` photons
    /// is refused (the leaf then may hold more than `n_max`). Default false: the paper says
    /// leaves in shadow may end under `n_min`, i.e. `n_min` does not stop the subdivision.
    pub split_respects_n_min: bool,
    /// Lower clamp of the cosine in the `1/cos` estimators (`Cosine`, `GeometryArea`), in
    /// (0, 1]. Default 0.1: under a diffuse incident field only `min_cos² = 1%` of the flux
    /// arrives below it, and the clamp bounds the photon weights to 10×.
    pub min_cos: f32,
}

impl Default for OctreeSettings {
    fn default() -> Self {
        OctreeSettings {
            h_max: Depth::Fixed(6),
            n_min: 50,
            n_max: 500,
            epsilon: 0.2,
            alpha: 1.5,
            estimator: Estimator::Paper,
            split: Split::Direction,
            storage: Storage::Compressed,
            enlarge: Enlarge::All,
            split_respects_n_min: false,
            min_cos: 0.1,
        }
    }
}

/// Deepest level a 63-bit Morton key can address.
pub const MAX_DEPTH: u32 = 21;
/// Largest `epsilon`: an enlarged cell 11 times its leaf's edge. The paper uses 0.2 and 0.6;
/// far beyond, each leaf gathers the photons of a large part of the scene over an area that
/// grows with the square of the enlargement, and the indirect light fades to nothing
/// (`--epsilon 1e30` rendered it black, exit 0).
pub const MAX_EPSILON: f32 = 10.0;
/// Largest `alpha`: a query box 100 times the smallest leaf's edge (the paper's 1.5).
pub const MAX_ALPHA: f32 = 100.0;

impl OctreeSettings {
    /// Check every field; the message names the field and the rule it breaks.
    pub fn validate(&self) -> Result<(), OctreeError> {
        let bad = |msg: String| Err(OctreeError::InvalidSettings(msg));
        if let Depth::Fixed(h) = self.h_max {
            if h > MAX_DEPTH {
                return bad(format!("h_max = {h} is above the maximum depth {MAX_DEPTH}"));
            }
        }
        if self.n_max == 0 {
            return bad("n_max must be at least 1".into());
        }
        if self.n_min > self.n_max {
            return bad(format!("n_min = {} is above n_max = {}", self.n_min, self.n_max));
        }
        if !self.epsilon.is_finite() || self.epsilon < 0.0 || self.epsilon > MAX_EPSILON {
            return bad(format!("epsilon = {} must be in [0, {MAX_EPSILON}]", self.epsilon));
        }
        if !self.alpha.is_finite() || self.alpha <= 0.0 || self.alpha > MAX_ALPHA {
            return bad(format!("alpha = {} must be in (0, {MAX_ALPHA}]", self.alpha));
        }
        if !self.min_cos.is_finite() || self.min_cos <= 0.0 || self.min_cos > 1.0 {
            return bad(format!("min_cos = {} must be in (0, 1]", self.min_cos));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_bad_settings_are_refused() {
        let d = OctreeSettings::default();
        assert!(d.validate().is_ok());
        assert_eq!((d.h_max, d.epsilon, d.alpha), (Depth::Fixed(6), 0.2, 1.5));
        let cases: Vec<(OctreeSettings, &str)> = vec![
            (OctreeSettings { n_min: 600, n_max: 400, ..d.clone() }, "n_min"),
            (OctreeSettings { n_max: 0, n_min: 0, ..d.clone() }, "n_max"),
            (OctreeSettings { h_max: Depth::Fixed(22), ..d.clone() }, "h_max"),
            (OctreeSettings { epsilon: -0.1, ..d.clone() }, "epsilon"),
            (OctreeSettings { epsilon: f32::NAN, ..d.clone() }, "epsilon"),
            (OctreeSettings { alpha: 0.0, ..d.clone() }, "alpha"),
            (OctreeSettings { alpha: f32::INFINITY, ..d.clone() }, "alpha"),
            (OctreeSettings { alpha: f32::NAN, ..d.clone() }, "alpha"),
            (OctreeSettings { min_cos: 0.0, ..d.clone() }, "min_cos"),
            (OctreeSettings { min_cos: 1.5, ..d.clone() }, "min_cos"),
        ];
        for (s, field) in cases {
            match s.validate() {
                Err(OctreeError::InvalidSettings(msg)) => assert!(msg.contains(field), "{msg} should name {field}"),
                other => panic!("{s:?} gave {other:?}"),
            }
        }
        assert!(OctreeSettings { h_max: Depth::Fixed(21), ..d.clone() }.validate().is_ok());
    }

    #[test]
    fn serde_fills_missing_fields_with_defaults() {
        let s: OctreeSettings = serde_json::from_str(r#"{"h_max": 4, "estimator": "geometry_area", "storage": "full"}"#).unwrap();
        assert_eq!(s.h_max, Depth::Fixed(4));
        assert_eq!(s.estimator, Estimator::GeometryArea);
        assert_eq!(s.storage, Storage::Full);
        assert_eq!(s.n_max, OctreeSettings::default().n_max);
        let back: OctreeSettings = serde_json::from_str(&serde_json::to_string(&s).unwrap()).unwrap();
        assert_eq!(back, s);
        let a: OctreeSettings = serde_json::from_str(r#"{"h_max": "auto"}"#).unwrap();
        assert_eq!(a.h_max, Depth::Auto);
        assert_eq!(serde_json::to_value(&a).unwrap()["h_max"], "auto");
        for bad in [r#"{"h_max": "deep"}"#, r#"{"h_max": -1}"#, r#"{"h_max": 1.5}"#] {
            assert!(serde_json::from_str::<OctreeSettings>(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn auto_depth_follows_the_photon_density() {
        // the paper's Cornell box: A = 6.4 S², 1M photons, n_max 500 -> s* = 0.057 S,
        // log2(S/s*) = 4.14, depth ceil(4.14 + 2.5) = 7
        assert_eq!(auto_depth(1_000_000, 6.4, 1.0, 500), 7);
        // scale-free: the same box 100x larger
        assert_eq!(auto_depth(1_000_000, 6.4e4, 100.0, 500), 7);
        // 4x the photons: one level more; 4x the area: one level less
        assert_eq!(auto_depth(4_000_000, 6.4, 1.0, 500), 8);
        assert_eq!(auto_depth(1_000_000, 25.6, 1.0, 500), 6);
        // degenerate inputs stay in range
        assert_eq!(auto_depth(0, 1.0, 1.0, 500), 1);
        assert_eq!(auto_depth(10, 0.0, 1.0, 500), 1);
        assert_eq!(auto_depth(usize::MAX, 1e-30, 1.0, 1), MAX_DEPTH);
    }
}
