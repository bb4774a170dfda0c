//! Gathers the doc comments of the crate's types (structs, enums, their fields and variants)
//! into a table the crate embeds (`src/type_docs.rs`): the settings reference that
//! `octolux settings` prints and docs/guide/settings.md holds is taken from the serde structs'
//! own doc comments, so the two never drift. The sources are parsed with `syn` (already built
//! for the derive macros); a file that does not parse is skipped (rustc reports it).
//!
//! It also probes Embree for the tests that need it (`cfg(missing = "embree")`, see
//! `crates/octolux-probe`).

use quote::ToTokens;
use std::fmt::Write as _;
use std::path::Path;

fn main() {
    octolux_probe::build_script(&["embree"]);
    println!("cargo:rerun-if-changed=src");
    let mut files = Vec::new();
    collect(Path::new("src"), &mut files);
    files.sort();
    let mut out = String::from("&[\n");
    for f in &files {
        let Ok(text) = std::fs::read_to_string(f) else { continue };
        let Ok(file) = syn::parse_file(&text) else { continue };
        let module = f.strip_prefix("src").unwrap_or(f).with_extension("").to_string_lossy().replace(['/', '\\'], "::");
        items(&file.items, &module, &mut out);
    }
    out.push_str("]\n");
    let dest = Path::new(&std::env::var("OUT_DIR").expect("OUT_DIR")).join("type_docs.rs");
    std::fs::write(dest, out).expect("write type_docs.rs");
}

fn collect(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            collect(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

fn items(list: &[syn::Item], module: &str, out: &mut String) {
    for item in list {
        match item {
            syn::Item::Struct(s) if matches!(s.vis, syn::Visibility::Public(_)) => {
                let fields = fields(&s.fields);
                let kind = match &s.fields {
                    syn::Fields::Named(_) => format!("TypeKind::Struct(&[{fields}])"),
                    _ => "TypeKind::Other".to_string(),
                };
                entry(out, &s.ident.to_string(), module, &s.attrs, &kind);
            }
            syn::Item::Enum(e) if matches!(e.vis, syn::Visibility::Public(_)) => {
                let mut variants = String::new();
                for v in &e.variants {
                    let (shape, fields) = match &v.fields {
                        syn::Fields::Unit => ("VariantShape::Unit", String::new()),
                        syn::Fields::Unnamed(u) => {
                            let ty = u.unnamed.iter().map(|f| type_text(&f.ty)).collect::<Vec<_>>().join(", ");
                            ("VariantShape::Tuple", format!("FieldDoc {{ name: \"\", ty: {ty:?}, doc: \"\", rename: None }}"))
                        }
                        syn::Fields::Named(_) => ("VariantShape::Struct", fields(&v.fields)),
                    };
                    let _ = write!(
                        variants,
                        "VariantDoc {{ name: {:?}, doc: {:?}, rename: {}, aliases: &[{}], shape: {shape}, fields: &[{fields}] }}, ",
                        v.ident.to_string(),
                        doc(&v.attrs),
                        opt(serde_value(&v.attrs, "rename")),
                        serde_values(&v.attrs, "alias").iter().map(|a| format!("{a:?}")).collect::<Vec<_>>().join(", ")
                    );
                }
                entry(out, &e.ident.to_string(), module, &e.attrs, &format!("TypeKind::Enum(&[{variants}])"));
            }
            syn::Item::Mod(m) => {
                if let Some((_, inner)) = &m.content {
                    items(inner, &format!("{module}::{}", m.ident), out);
                }
            }
            _ => {}
        }
    }
}

fn entry(out: &mut String, name: &str, module: &str, attrs: &[syn::Attribute], kind: &str) {
    let serde = attrs.iter().any(|a| a.path().is_ident("derive") && a.to_token_stream().to_string().contains("Deserialize"));
    let _ = writeln!(
        out,
        "TypeDoc {{ name: {name:?}, module: {module:?}, doc: {:?}, deserialize: {serde}, rename_all: {}, kind: {kind} }},",
        doc(attrs),
        opt(serde_value(attrs, "rename_all")),
    );
}

fn fields(f: &syn::Fields) -> String {
    let mut s = String::new();
    for field in f.iter() {
        let Some(ident) = &field.ident else { continue };
        let _ = write!(
            s,
            "FieldDoc {{ name: {:?}, ty: {:?}, doc: {:?}, rename: {} }}, ",
            ident.to_string().trim_start_matches("r#"),
            type_text(&field.ty),
            doc(&field.attrs),
            opt(serde_value(&field.attrs, "rename"))
        );
    }
    s
}

fn opt(v: Option<String>) -> String {
    v.map_or("None".to_string(), |v| format!("Some({v:?})"))
}

/// A type as written, without the spaces the token printer puts in (`Option<SceneLength>`).
fn type_text(t: &syn::Type) -> String {
    t.to_token_stream().to_string().replace(' ', "")
}

/// The doc comment: its lines joined, each stripped of the one space after `///`.
fn doc(attrs: &[syn::Attribute]) -> String {
    let mut lines = Vec::new();
    for a in attrs {
        if let syn::Meta::NameValue(nv) = &a.meta {
            if nv.path.is_ident("doc") {
                if let syn::Expr::Lit(syn::ExprLit { lit: syn::Lit::Str(s), .. }) = &nv.value {
                    let v = s.value();
                    lines.push(v.strip_prefix(' ').unwrap_or(&v).to_string());
                }
            }
        }
    }
    lines.join("\n").trim().to_string()
}

/// The values of `#[serde(key = "...")]` attributes.
fn serde_values(attrs: &[syn::Attribute], key: &str) -> Vec<String> {
    let mut found = Vec::new();
    for a in attrs.iter().filter(|a| a.path().is_ident("serde")) {
        let _ = a.parse_nested_meta(|m| {
            if m.path.is_ident(key) {
                let v: syn::LitStr = m.value()?.parse()?;
                found.push(v.value());
            } else if m.input.peek(syn::Token![=]) {
                let _: syn::Expr = m.value()?.parse()?;
            } else if m.input.peek(syn::token::Paren) {
                let _ = m.parse_nested_meta(|inner| {
                    if inner.input.peek(syn::Token![=]) {
                        let _: syn::Expr = inner.value()?.parse()?;
                    }
                    Ok(())
                });
            }
            Ok(())
        });
    }
    found
}

fn serde_value(attrs: &[syn::Attribute], key: &str) -> Option<String> {
    serde_values(attrs, key).into_iter().next()
}
