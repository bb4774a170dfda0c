//! The settings reference: every key of an integrator's settings with its default, its type
//! and its doc, taken from the serde structs' own doc comments (`octolux::type_docs`) and
//! their defaults (`IntegratorSettings::default_for`). `octolux settings [INTEGRATOR]` prints
//! it ([`text`]); docs/guide/settings.md is [`markdown`] (a test fails when the page is stale).

use octolux::integrators::IntegratorSettings;
use octolux::type_docs::{self, FieldDoc, TypeDoc, TypeKind, VariantShape};
use serde_json::Value;

/// One key of an integrator's settings.
#[derive(Clone, Debug, PartialEq)]
pub struct KeyDoc {
    /// Dotted, as `--set` takes it (`global.h_max`).
    pub key: String,
    pub default: Value,
    /// What values it takes, in words (`integer`, `` `a` | `b` ``, ...).
    pub ty: String,
    pub doc: String,
    /// An enum's values (serde names, as every front end spells them) and their docs.
    pub values: Vec<(String, String)>,
}

/// Types whose serde is written by hand (no derive): what they take, in words.
const CUSTOM: &[(&str, &str)] = &[("Depth", "integer from 0 to 21, or `\"auto\"`")];

/// The keys of the integrator called `name` (one of `IntegratorSettings::NAMES`), in the order
/// of the struct's fields; `None` for another name.
pub fn keys(name: &str) -> Option<Vec<KeyDoc>> {
    let defaults = serde_json::to_value(IntegratorSettings::default_for(name)?).ok()?;
    let root = root_type(name)?;
    let mut out = Vec::new();
    walk(root, &defaults, "", &mut out);
    Some(out)
}

/// The settings struct of the integrator called `name`: the payload of its variant of
/// `IntegratorSettings`.
fn root_type(name: &str) -> Option<&'static TypeDoc> {
    let e = type_docs::find("IntegratorSettings").next()?;
    let TypeKind::Enum(variants) = e.kind else { return None };
    let v = variants.iter().find(|v| e.serde_name(v.name, v.rename) == name)?;
    lookup(v.fields.first()?.ty)
}

/// The one settings type called `name` (the last segment of a path).
fn lookup(name: &str) -> Option<&'static TypeDoc> {
    let name = name.rsplit("::").next().unwrap_or(name);
    type_docs::find(name).find(|t| t.deserialize || CUSTOM.iter().any(|(n, _)| *n == t.name))
}

/// `T` of `Option<T>`.
fn strip_option(ty: &str) -> (&str, bool) {
    match ty.strip_prefix("Option<").and_then(|t| t.strip_suffix('>')) {
        Some(inner) => (inner, true),
        None => (ty, false),
    }
}

fn walk(t: &TypeDoc, v: &Value, prefix: &str, out: &mut Vec<KeyDoc>) {
    let TypeKind::Struct(fields) = t.kind else { return };
    for f in fields {
        let name = t.serde_name(f.name, f.rename);
        let Some(value) = v.get(&name) else { continue };
        let key = if prefix.is_empty() { name } else { format!("{prefix}.{name}") };
        let (inner, _) = strip_option(f.ty);
        match lookup(inner) {
            Some(sub) if matches!(sub.kind, TypeKind::Struct(_)) && value.is_object() => walk(sub, value, &key, out),
            _ => out.push(leaf(key, f, value)),
        }
    }
}

fn leaf(key: String, f: &FieldDoc, value: &Value) -> KeyDoc {
    let (inner, optional) = strip_option(f.ty);
    let t = lookup(inner);
    let mut ty = type_words(inner);
    if optional {
        ty.push_str(", or `null`");
    }
    // a field without a doc of its own takes its type's (`view: OctreeView`)
    let doc = if f.doc.is_empty() { t.map_or("", |t| t.doc) } else { f.doc };
    let custom = CUSTOM.iter().any(|(n, _)| *n == inner);
    let values = match t.map(|t| (t, &t.kind)) {
        Some((t, TypeKind::Enum(vs))) if !custom => vs
            .iter()
            .map(|v| {
                let mut d = clean(v.doc);
                if v.shape == VariantShape::Struct {
                    for field in v.fields.iter().filter(|f| !f.doc.is_empty()) {
                        d.push_str(&format!(" `{}`: {}", field.name, clean(field.doc)));
                    }
                }
                (t.serde_name(v.name, v.rename), d)
            })
            .collect(),
        _ => vec![],
    };
    KeyDoc { key, default: value.clone(), ty, doc: clean(doc), values }
}

/// A Rust type in words.
fn type_words(ty: &str) -> String {
    if let Some((_, w)) = CUSTOM.iter().find(|(n, _)| *n == ty) {
        return w.to_string();
    }
    match ty {
        "u8" | "u16" | "u32" | "u64" | "usize" => return "integer ≥ 0".into(),
        "i8" | "i16" | "i32" | "i64" | "isize" => return "integer".into(),
        "f32" | "f64" => return "number".into(),
        "bool" => return "`true` or `false`".into(),
        "String" => return "string".into(),
        _ => {}
    }
    let Some(t) = lookup(ty) else { return format!("`{ty}`") };
    match t.kind {
        TypeKind::Enum(vs) => vs
            .iter()
            .map(|v| {
                let name = t.serde_name(v.name, v.rename);
                match v.shape {
                    VariantShape::Unit => format!("`\"{name}\"`"),
                    VariantShape::Tuple => format!("`{{\"{name}\": {}}}`", v.fields.first().map_or("…".into(), |f| plain_type(f.ty))),
                    VariantShape::Struct => {
                        let inner: Vec<String> = v.fields.iter().map(|f| format!("\"{}\": {}", f.name, plain_type(f.ty))).collect();
                        format!("`{{\"{name}\": {{{}}}}}`", inner.join(", "))
                    }
                }
            })
            .collect::<Vec<_>>()
            .join(" | "),
        _ => format!("`{ty}`"),
    }
}

/// A type inside a code span: `integer`, `number`, ... or its name.
fn plain_type(ty: &str) -> String {
    let (inner, optional) = strip_option(ty);
    let w = match inner {
        "u8" | "u16" | "u32" | "u64" | "usize" | "i32" | "i64" => "integer".to_string(),
        "f32" | "f64" => "number".to_string(),
        "bool" => "bool".to_string(),
        other => match lookup(other) {
            Some(t @ TypeDoc { kind: TypeKind::Enum(vs), .. }) if vs.iter().all(|v| v.shape == VariantShape::Unit) => {
                vs.iter().map(|v| format!("\"{}\"", t.serde_name(v.name, v.rename))).collect::<Vec<_>>().join("|")
            }
            _ => other.to_string(),
        },
    };
    if optional {
        format!("{w}|null")
    } else {
        w
    }
}

/// A doc comment as plain Markdown: intra-doc links (`` [`X`] ``, `[text](path)`) as their
/// text (a path's `crate::`, `super::`, `Self::` dropped), other brackets kept, lines joined
/// into one paragraph.
fn clean(doc: &str) -> String {
    let mut s = String::new();
    let mut rest = doc;
    while let Some(i) = rest.find('[') {
        s.push_str(&rest[..i]);
        let after = &rest[i + 1..];
        let Some(j) = after.find(']') else {
            s.push('[');
            rest = after;
            continue;
        };
        let inner = &after[..j];
        let tail = &after[j + 1..];
        let inline = tail.starts_with('(') && tail.contains(')');
        let code = inner.len() >= 2 && inner.starts_with('`') && inner.ends_with('`');
        if inline {
            s.push_str(inner);
            rest = &tail[tail.find(')').map_or(0, |k| k + 1)..];
        } else if code {
            let mut text = inner.to_string();
            for prefix in ["crate::", "super::", "self::", "Self::"] {
                text = text.replace(prefix, "");
            }
            s.push_str(&text);
            rest = tail;
        } else {
            s.push('[');
            rest = after;
        }
    }
    s.push_str(rest);
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// A value as settings files and `--set` write it; a number stored as `f32` in its shortest
/// form (`0.2`, not `0.20000000298023224`).
fn shown(v: &Value) -> String {
    match v {
        Value::Number(n) if !n.is_i64() && !n.is_u64() => {
            let x = n.as_f64().unwrap_or(0.0);
            let f = x as f32;
            if f as f64 == x {
                format!("{f:?}")
            } else {
                format!("{x:?}")
            }
        }
        Value::Object(m) => {
            let items: Vec<String> = m.iter().map(|(k, v)| format!("{}: {}", Value::String(k.clone()), shown(v))).collect();
            format!("{{{}}}", items.join(", "))
        }
        Value::Array(a) => format!("[{}]", a.iter().map(shown).collect::<Vec<_>>().join(", ")),
        _ => v.to_string(),
    }
}

/// Words wrapped at `width` columns, each line indented by `indent`.
fn wrap(text: &str, indent: &str, width: usize) -> String {
    let mut out = String::new();
    let mut line = String::new();
    for w in text.split_whitespace() {
        if !line.is_empty() && indent.len() + line.chars().count() + 1 + w.chars().count() > width {
            out.push_str(indent);
            out.push_str(&line);
            out.push('\n');
            line.clear();
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(w);
    }
    if !line.is_empty() {
        out.push_str(indent);
        out.push_str(&line);
        out.push('\n');
    }
    out
}

/// `text` as a list item: its first line after `first`, the others indented to match.
fn item(text: &str, first: &str, width: usize) -> String {
    let pad = " ".repeat(first.chars().count());
    let w = wrap(text, &pad, width);
    w.replacen(&pad, first, 1)
}

/// How to give a key, said once above each listing.
const HOW: &str = "Give a key with `--set KEY=VALUE` (dotted keys; the value is JSON when it parses, else a string), in a \
                   `--settings` file (JSON or TOML, nested tables; an optional `type` names the integrator), or in Python's \
                   `settings` dict (nested). An enum value may be written with `-` for `_` (`geometry-area`).";

/// The listing `octolux settings NAME` prints; `None` for an unknown name.
pub fn text(name: &str) -> Option<String> {
    let keys = keys(name)?;
    let mut s = format!("{name} settings\n{}\n", wrap(HOW, "", 96));
    for k in keys {
        s.push_str(&format!("{} = {}    ({})\n", k.key, shown(&k.default), k.ty.replace('`', "")));
        s.push_str(&wrap(&k.doc.replace('`', ""), "    ", 100));
        for (v, d) in &k.values {
            s.push_str(&item(&format!("{v}: {}", d.replace('`', "")), "    - ", 100));
        }
    }
    Some(s)
}

/// docs/guide/settings.md: every integrator's keys.
pub fn markdown() -> String {
    let mut s = String::from(
        "# Settings reference\n\n<!-- Generated by `octolux settings --markdown` from the settings structs' doc comments; \
         a test fails when this page is stale. Edit the doc comments, then regenerate:\n     \
         cargo run -p octolux-cli -- settings --markdown > docs/guide/settings.md -->\n\n",
    );
    s.push_str(&wrap(HOW, "", 100));
    s.push('\n');
    s.push_str(&wrap(
        "Every integrator's settings below, with their defaults. `octolux settings INTEGRATOR` prints the same in a \
         terminal; `out.json`'s `integrator_settings` holds the values a render used.",
        "",
        100,
    ));
    for &name in IntegratorSettings::NAMES {
        s.push_str(&format!("\n## `{name}`\n\n"));
        for k in keys(name).unwrap_or_default() {
            s.push_str(&format!("- **`{}`** = `{}` — {}\n", k.key, shown(&k.default), k.ty));
            if !k.doc.is_empty() {
                s.push_str(&wrap(&k.doc, "  ", 100));
            }
            for (v, d) in &k.values {
                s.push_str(&item(&format!("`\"{v}\"`: {d}"), "  - ", 100));
            }
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clean_keeps_the_text_of_links() {
        assert_eq!(clean("see [`Mode`] and [the docs](docs/a.md), [`super::x`]\nnext"), "see `Mode` and the docs, `x` next");
        assert_eq!(clean("an [open bracket"), "an [open bracket");
        assert_eq!(clean("C + [u < q] (L - C) / q"), "C + [u < q] (L - C) / q");
        assert_eq!(shown(&serde_json::json!({"a": 0.2f32, "b": [1, 0.5]})), r#"{"a": 0.2, "b": [1, 0.5]}"#);
    }

    #[test]
    fn wrap_keeps_words_whole() {
        assert_eq!(wrap("aa bb cc", "  ", 7), "  aa bb\n  cc\n");
    }
}
