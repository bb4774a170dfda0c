//! The doc comments of the crate's public structs and enums, their fields and variants,
//! gathered from the sources at build time (`build.rs`). The settings reference
//! (`octolux settings`, docs/guide/settings.md) reads the serde settings structs' docs from
//! here, so a setting is documented once, where it is defined.

/// One public struct or enum.
#[derive(Debug)]
pub struct TypeDoc {
    pub name: &'static str,
    /// Its module below the crate root (`caches::octree::settings`).
    pub module: &'static str,
    pub doc: &'static str,
    /// Whether it derives `Deserialize` (a type with a hand-written serde is `false`).
    pub deserialize: bool,
    /// `#[serde(rename_all = ...)]`.
    pub rename_all: Option<&'static str>,
    pub kind: TypeKind,
}

/// A struct's fields or an enum's variants.
#[derive(Debug)]
pub enum TypeKind {
    Struct(&'static [FieldDoc]),
    Enum(&'static [VariantDoc]),
    /// A tuple or unit struct.
    Other,
}

/// A named field (or, in a tuple variant, the types it holds, comma-separated, with no name).
#[derive(Debug)]
pub struct FieldDoc {
    pub name: &'static str,
    /// The type as written in the source (`Option<SceneLength>`).
    pub ty: &'static str,
    pub doc: &'static str,
    /// `#[serde(rename = ...)]`.
    pub rename: Option<&'static str>,
}

/// An enum variant.
#[derive(Debug)]
pub struct VariantDoc {
    pub name: &'static str,
    pub doc: &'static str,
    /// `#[serde(rename = ...)]`.
    pub rename: Option<&'static str>,
    /// `#[serde(alias = ...)]`.
    pub aliases: &'static [&'static str],
    pub shape: VariantShape,
    /// The fields of a struct variant, or the one entry of a tuple variant.
    pub fields: &'static [FieldDoc],
}

/// What a variant holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VariantShape {
    Unit,
    Tuple,
    Struct,
}

/// Every public struct and enum of the crate, in source order.
pub static TYPES: &[TypeDoc] = include!(concat!(env!("OUT_DIR"), "/type_docs.rs"));

/// The types called `name` (several modules may use one name).
pub fn find(name: &str) -> impl Iterator<Item = &'static TypeDoc> + '_ {
    TYPES.iter().filter(move |t| t.name == name)
}

impl TypeDoc {
    /// The serde name of a variant or a field called `rust` in Rust, by this type's
    /// `rename_all` (`snake_case`, `lowercase`, ...) unless renamed.
    pub fn serde_name(&self, rust: &str, rename: Option<&str>) -> String {
        if let Some(r) = rename {
            return r.to_string();
        }
        match self.rename_all {
            Some("snake_case") => snake_case(rust),
            Some("lowercase") => rust.to_lowercase(),
            Some("kebab-case") => snake_case(rust).replace('_', "-"),
            Some("SCREAMING_SNAKE_CASE") => snake_case(rust).to_uppercase(),
            _ => rust.to_string(),
        }
    }
}

/// serde's `snake_case` of a Rust name (`IrradianceAll` -> `irradiance_all`; a field name is
/// unchanged).
pub fn snake_case(s: &str) -> String {
    let mut out = String::new();
    for (i, c) in s.char_indices() {
        if i > 0 && c.is_uppercase() {
            out.push('_');
        }
        out.push(c.to_ascii_lowercase());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_settings_types_and_their_docs_are_gathered() {
        let t = find("OctreeSettings").next().expect("OctreeSettings");
        assert!(t.deserialize && t.module == "caches::octree::settings", "{t:?}");
        let TypeKind::Struct(fields) = t.kind else { panic!("a struct: {t:?}") };
        let h = fields.iter().find(|f| f.name == "h_max").expect("h_max");
        assert_eq!(h.ty, "Depth");
        assert!(h.doc.starts_with("Maximum depth (root = depth 0)"), "{}", h.doc);
        let e = find("Estimator").next().expect("Estimator");
        let TypeKind::Enum(vs) = e.kind else { panic!("an enum") };
        let names: Vec<String> = vs.iter().map(|v| e.serde_name(v.name, v.rename)).collect();
        assert_eq!(names, ["paper", "cosine", "geometry_area"]);
        assert_eq!(snake_case("UnderNMin"), "under_n_min");
    }
}
