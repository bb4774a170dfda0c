//! First stage of the Mitsuba loader: read the XML file(s) into an owned element tree with
//! every scene-language directive already applied, so that later stages only see plugins and
//! properties.
//!
//! Applied here, in document order like Mitsuba's own parser:
//! - `$name` substitution in every attribute from the parameter list (command-line `defines`
//!   first, then each `<default name value>` met so far, which never overrides an existing
//!   entry); longer names are replaced first; a `$` left over is an error naming it;
//! - `<include filename>` (resolved relative to the including file, then the main scene's
//!   folder, then `<path>` folders): the children of an included `<scene>` are spliced in place,
//!   any other root element is inserted as is;
//! - budgets against amplification (issue 27): a substituted value has at most
//!   [`MAX_VALUE_BYTES`] and all substitutions together [`MAX_SUBSTITUTED_BYTES`]; a scene has
//!   at most [`MAX_INCLUDES`] includes and [`MAX_INCLUDED_BYTES`] of included text, besides the
//!   include depth of 15;
//! - `<path value>` adds a folder to the resource search path;
//! - the 0.5/0.6 dialect (root `version` < 2.0.0): parameter names are converted from
//!   camelCase to snake_case exactly like Mitsuba 3's `upgrade_tree`, `<lookAt>` becomes
//!   `<lookat>`, and `diffuse_reflectance` of a `diffuse` bsdf becomes `reflectance`.
//!
//! Every element keeps its file and line ([`Loc`]) for messages.

use crate::IoError;
use std::fmt;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// Maximal nesting of `<include>` (Mitsuba uses the same kind of limit against cycles).
const MAX_INCLUDE_DEPTH: usize = 15;
/// Most `<include>`s in one scene, all files together: files that include each other several
/// times multiply (12 files of 4 includes each make 4^11), which the depth limit lets through.
pub(crate) const MAX_INCLUDES: usize = 10_000;
/// Most bytes of included text in one scene, all files together.
pub(crate) const MAX_INCLUDED_BYTES: u64 = 256 << 20;
/// Longest attribute value once `$name`s are substituted. A chain of `<default>`s, each value
/// ten copies of the one before, would otherwise grow tenfold per link (a 1 KB file asked for
/// 9.6 GB); real values (a matrix, a file name, a spectrum) are far shorter.
pub(crate) const MAX_VALUE_BYTES: usize = 64 << 10;
/// Most bytes that substitution may produce in one scene, all values together.
pub(crate) const MAX_SUBSTITUTED_BYTES: usize = 64 << 20;
/// Maximal nesting of XML elements in one file. Real scenes nest a dozen levels at most; the
/// bound keeps the recursive stages of the loader far from the end of the stack.
pub(crate) const MAX_XML_DEPTH: usize = 256;

/// A parsed document with a table of line starts: the line of a byte offset is a binary search
/// (roxmltree's `text_pos_at` scans the text from its start, quadratic over a whole file).
struct Doc<'a, 'i> {
    doc: &'a roxmltree::Document<'i>,
    /// Byte offsets of the `\n` characters of the text.
    newlines: Vec<usize>,
}

impl<'a, 'i> Doc<'a, 'i> {
    fn new(doc: &'a roxmltree::Document<'i>) -> Self {
        let newlines = doc.input_text().bytes().enumerate().filter(|&(_, b)| b == b'\n').map(|(i, _)| i).collect();
        Doc { doc, newlines }
    }
    /// 1-based line of byte offset `pos`.
    fn row(&self, pos: usize) -> u32 {
        (self.newlines.partition_point(|&n| n < pos) + 1).min(u32::MAX as usize) as u32
    }
}

/// Refuse elements nested deeper than [`MAX_XML_DEPTH`] before parsing, with the line of the
/// first element too deep. A lexical scan: start tags (`<name`) deepen, end tags (`</`) and
/// empty-element ends (`/>`) come back up; comments, CDATA, processing instructions and the
/// DOCTYPE are skipped. Malformed text is left for the XML parser to report.
fn check_nesting(text: &str, file: &Path) -> Result<(), IoError> {
    let b = text.as_bytes();
    let mut depth = 0usize;
    let mut i = 0;
    let skip_to = |from: usize, end: &str| text[from..].find(end).map(|p| from + p + end.len()).unwrap_or(b.len());
    while let Some(p) = text[i..].find('<') {
        i += p;
        let rest = &text[i..];
        if rest.starts_with("<!--") {
            i = skip_to(i, "-->");
        } else if rest.starts_with("<![CDATA[") {
            i = skip_to(i, "]]>");
        } else if rest.starts_with("<?") {
            i = skip_to(i, "?>");
        } else if rest.starts_with("<!") {
            i = skip_to(i, ">");
        } else if rest.starts_with("</") {
            depth = depth.saturating_sub(1);
            i = skip_to(i, ">");
        } else {
            // A start tag: find its end, outside quoted attribute values.
            let mut j = i + 1;
            let mut quote = None;
            while j < b.len() {
                match (quote, b[j]) {
                    (None, b'"' | b'\'') => quote = Some(b[j]),
                    (Some(q), c) if c == q => quote = None,
                    (None, b'>') => break,
                    _ => {}
                }
                j += 1;
            }
            let empty = j > i + 1 && b.get(j - 1) == Some(&b'/');
            if !empty {
                depth += 1;
                if depth > MAX_XML_DEPTH {
                    let line = text[..i].bytes().filter(|&c| c == b'\n').count() + 1;
                    return Err(IoError::parse(
                        file,
                        line.min(u32::MAX as usize) as u32,
                        format!("elements are nested more than {MAX_XML_DEPTH} levels deep"),
                    ));
                }
            }
            i = (j + 1).min(b.len());
        }
    }
    Ok(())
}

/// Where an element was written.
#[derive(Clone, Debug)]
pub(crate) struct Loc {
    pub file: Rc<PathBuf>,
    pub line: u32,
}

impl fmt::Display for Loc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.file.display(), self.line)
    }
}

impl Loc {
    /// An error at this place.
    pub fn error(&self, msg: impl Into<String>) -> IoError {
        IoError::parse(&self.file, self.line, msg)
    }
    /// The folder of the file this element was read from.
    pub fn dir(&self) -> &Path {
        self.file.parent().unwrap_or_else(|| Path::new("."))
    }
}

/// One XML element after directive processing.
#[derive(Clone, Debug)]
pub(crate) struct Elem {
    pub tag: String,
    pub attrs: Vec<(String, String)>,
    pub children: Vec<Elem>,
    pub loc: Loc,
    /// Written in the 0.5/0.6 dialect (names already converted to snake_case): for plugins whose
    /// conventions differ between the versions (the `sunsky` frame).
    pub legacy: bool,
}

impl Elem {
    pub fn attr(&self, name: &str) -> Option<&str> {
        self.attrs.iter().find(|(n, _)| n == name).map(|(_, v)| v.as_str())
    }
    /// A required attribute.
    pub fn req_attr(&self, name: &str) -> Result<&str, IoError> {
        self.attr(name).ok_or_else(|| self.loc.error(format!("{} is missing the attribute \"{name}\"", self.describe())))
    }
    /// `<tag type="..." id="..." name="...">` for messages.
    pub fn describe(&self) -> String {
        let mut s = format!("<{}", self.tag);
        for key in ["type", "name", "id"] {
            if let Some(v) = self.attr(key) {
                s.push_str(&format!(" {key}=\"{v}\""));
            }
        }
        s.push('>');
        s
    }
    /// `file:line: <tag ...>: msg`, the format of every warning.
    pub fn warning(&self, msg: impl fmt::Display) -> String {
        format!("{}: {}: {msg}", self.loc, self.describe())
    }
}

/// The processed document.
pub(crate) struct Tree {
    /// The root element (normally `<scene>`).
    pub root: Elem,
    /// Extra resource folders from `<path>` elements, in order of appearance.
    pub search_dirs: Vec<PathBuf>,
}

/// Read and process the scene file at `path`.
pub(crate) fn read(path: &Path, defines: &[(String, String)], warnings: &mut Vec<String>) -> Result<Tree, IoError> {
    let text = crate::files::read_to_string(path)?;
    read_str(&text, path, defines, warnings)
}

/// Process scene text as if read from `path` (used for messages and relative file names).
pub(crate) fn read_str(text: &str, path: &Path, defines: &[(String, String)], warnings: &mut Vec<String>) -> Result<Tree, IoError> {
    // a name given twice: the last value wins (as a later option wins), with a warning
    let mut given: Vec<(String, String)> = Vec::new();
    for (name, value) in defines {
        match given.iter_mut().find(|(n, _)| n == name) {
            Some(first) => {
                warnings.push(format!("-D {name}={value} repeats -D {name}={}: the last value wins", first.1));
                first.1 = value.clone();
            }
            None => given.push((name.clone(), value.clone())),
        }
    }
    let defines = &given[..];
    let mut b = Builder {
        params: defines.to_vec(),
        defines_used: vec![false; defines.len()],
        main_dir: path.parent().map(Path::to_path_buf).unwrap_or_default(),
        search_dirs: Vec::new(),
        warnings,
        nesting: 0,
        includes: 0,
        included_bytes: 0,
        substituted_bytes: 0,
    };
    let file = Rc::new(path.to_path_buf());
    let mut out = Vec::new();
    b.document(text, &file, None, 0, &mut out)?;
    if out.len() != 1 {
        return Err(IoError::invalid(path, "the document has no root element"));
    }
    // A define that neither overrides a <default> nor fills a $name changes nothing: say so.
    for ((name, value), used) in defines.iter().zip(&b.defines_used) {
        if !used {
            b.warnings.push(format!("-D {name}={value} is unused: {} has no <default name=\"{name}\"> and no ${name}", path.display()));
        }
    }
    let root = out.remove(0);
    if root.tag != "scene" {
        return Err(root.loc.error(format!("the root element must be <scene>, not <{}>", root.tag)));
    }
    Ok(Tree { root, search_dirs: b.search_dirs })
}

/// A parsed `major.minor.patch` version.
fn parse_version(v: &str) -> Option<(u32, u32, u32)> {
    let parts: Vec<&str> = v.trim().split('.').collect();
    if parts.len() != 3 {
        return None;
    }
    Some((parts[0].parse().ok()?, parts[1].parse().ok()?, parts[2].parse().ok()?))
}

/// Mitsuba 3's camelCase → snake_case rule (`upgrade_tree`): an underscore goes between a lower-
/// case letter and the upper-case run that follows it, and the run is lower-cased.
pub(crate) fn camel_to_snake(name: &str) -> String {
    let mut s: Vec<u8> = name.as_bytes().to_vec();
    let mut i = 0;
    while i + 1 < s.len() {
        if s[i].is_ascii_lowercase() && s[i + 1].is_ascii_uppercase() {
            s.insert(i + 1, b'_');
            i += 2;
            while i < s.len() && s[i].is_ascii_uppercase() {
                s[i] = s[i].to_ascii_lowercase();
                i += 1;
            }
        }
        i += 1;
    }
    String::from_utf8(s).unwrap_or_else(|_| name.to_string())
}

struct Builder<'w> {
    params: Vec<(String, String)>,
    /// Per command-line define (the first entries of `params`): whether a `<default>` of its
    /// name or a `$name` reference met it.
    defines_used: Vec<bool>,
    main_dir: PathBuf,
    search_dirs: Vec<PathBuf>,
    warnings: &'w mut Vec<String>,
    /// Elements open around the current one, across included files.
    nesting: usize,
    /// `<include>`s met so far and the bytes of their text (module docs: budgets).
    includes: usize,
    included_bytes: u64,
    /// Bytes produced by `$name` substitution so far.
    substituted_bytes: usize,
}

impl Builder<'_> {
    /// Parse one XML text and append what it contributes to `out`: for the main file
    /// (`legacy_parent == None`) its root element; for an included file (`Some(dialect of the
    /// includer)`) the children of a `<scene>` root, or any other root element itself.
    fn document(
        &mut self,
        text: &str,
        file: &Rc<PathBuf>,
        legacy_parent: Option<bool>,
        depth: usize,
        out: &mut Vec<Elem>,
    ) -> Result<(), IoError> {
        let opts = roxmltree::ParsingOptions { allow_dtd: true, ..Default::default() };
        check_nesting(text, file)?;
        let doc = roxmltree::Document::parse_with_options(text, opts)
            .map_err(|e| IoError::parse(file, e.pos().row, format!("malformed XML: {e}")))?;
        let doc = Doc::new(&doc);
        let root = doc.doc.root_element();
        let line = doc.row(root.range().start);
        match legacy_parent {
            None => {
                if root.attribute("version").is_none() {
                    self.warnings.push(format!(
                        "{}:{line}: <{}>: no version attribute; assuming Mitsuba 3 syntax",
                        file.display(),
                        root.tag_name().name()
                    ));
                }
                self.element(&doc, root, file, false, depth, out)
            }
            Some(legacy) => {
                if root.tag_name().name() == "scene" {
                    let legacy = self.version_of(&doc, root, file)?.unwrap_or(legacy);
                    for child in root.children() {
                        self.node(&doc, child, file, legacy, depth, out)?;
                    }
                    Ok(())
                } else {
                    self.element(&doc, root, file, legacy, depth, out)
                }
            }
        }
    }

    /// `Some(is_legacy)` when the element carries a version attribute.
    fn version_of(&mut self, doc: &Doc, node: roxmltree::Node, file: &Rc<PathBuf>) -> Result<Option<bool>, IoError> {
        match node.attribute("version") {
            None => Ok(None),
            Some(v) => {
                let v = self.substitute(v, doc, node, file)?;
                let (major, _, _) = parse_version(&v)
                    .ok_or_else(|| IoError::parse(file, doc.row(node.range().start), format!("could not parse version number \"{v}\"")))?;
                Ok(Some(major < 2))
            }
        }
    }

    fn node(
        &mut self,
        doc: &Doc,
        node: roxmltree::Node,
        file: &Rc<PathBuf>,
        legacy: bool,
        depth: usize,
        out: &mut Vec<Elem>,
    ) -> Result<(), IoError> {
        if node.is_element() {
            return self.element(doc, node, file, legacy, depth, out);
        }
        if node.is_text() && node.text().is_some_and(|t| !t.trim().is_empty()) {
            let line = doc.row(node.range().start);
            self.warnings.push(format!("{}:{line}: unexpected text content ignored", file.display()));
        }
        Ok(())
    }

    /// Replace `$name` references in an attribute value.
    fn substitute(&mut self, value: &str, doc: &Doc, node: roxmltree::Node, file: &Rc<PathBuf>) -> Result<String, IoError> {
        if !value.contains('$') {
            return Ok(value.to_string());
        }
        let mut params: Vec<(usize, &(String, String))> = self.params.iter().enumerate().collect();
        params.sort_by_key(|p| std::cmp::Reverse(p.1 .0.len()));
        let mut v = value.to_string();
        let line = || doc.row(node.range().start);
        for (i, (name, val)) in params {
            let reference = format!("${name}");
            let count = v.matches(&reference).count();
            if count > 0 {
                if let Some(u) = self.defines_used.get_mut(i) {
                    *u = true;
                }
                // the length after the replacement, known before it is made
                let grown = (v.len() - count * reference.len()).saturating_add(count.saturating_mul(val.len()));
                if grown > MAX_VALUE_BYTES {
                    return Err(IoError::parse(
                        file,
                        line(),
                        format!(
                            "the value of <{}> would grow to {grown} bytes once ${name} is substituted, more than {MAX_VALUE_BYTES} \
                             (<default>s whose values repeat each other multiply)",
                            node.tag_name().name()
                        ),
                    ));
                }
                self.substituted_bytes += grown;
                if self.substituted_bytes > MAX_SUBSTITUTED_BYTES {
                    return Err(IoError::parse(
                        file,
                        line(),
                        format!("$name substitution has produced more than {MAX_SUBSTITUTED_BYTES} bytes in this scene"),
                    ));
                }
                v = v.replace(&reference, val);
            }
        }
        if let Some(pos) = v.find('$') {
            let name: String = v[pos + 1..].chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
            return Err(IoError::parse(
                file,
                line(),
                format!("undefined parameter \"${name}\" in \"{value}\" (define it with <default name=\"{name}\" value=\"...\"/> or -D {name}=...)"),
            ));
        }
        Ok(v)
    }

    fn element(
        &mut self,
        doc: &Doc,
        node: roxmltree::Node,
        file: &Rc<PathBuf>,
        legacy: bool,
        depth: usize,
        out: &mut Vec<Elem>,
    ) -> Result<(), IoError> {
        let loc = Loc { file: file.clone(), line: doc.row(node.range().start) };
        let mut tag = node.tag_name().name().to_string();
        let legacy = self.version_of(doc, node, file)?.unwrap_or(legacy);
        let mut attrs = Vec::new();
        for a in node.attributes() {
            if a.name() == "version" {
                continue;
            }
            let mut v = self.substitute(a.value(), doc, node, file)?;
            if legacy && a.name() == "name" && tag != "default" {
                v = camel_to_snake(&v);
            }
            attrs.push((a.name().to_string(), v));
        }
        if legacy && tag == "lookAt" {
            tag = "lookat".into();
        }
        let elem = Elem { tag, attrs, children: Vec::new(), loc, legacy };
        match elem.tag.as_str() {
            "default" => {
                let name = elem.req_attr("name")?.to_string();
                let value = elem.req_attr("value")?.to_string();
                if name.is_empty() {
                    return Err(elem.loc.error("<default>: the name must not be empty"));
                }
                for (used, (n, _)) in self.defines_used.iter_mut().zip(&self.params) {
                    *used |= *n == name;
                }
                if !self.params.iter().any(|(n, _)| *n == name) {
                    self.params.push((name, value));
                }
                Ok(())
            }
            "path" => {
                let p = PathBuf::from(elem.req_attr("value")?);
                let p = if p.is_absolute() { p } else { elem.loc.dir().join(p) };
                if !p.is_dir() {
                    return Err(elem.loc.error(format!("<path>: folder \"{}\" not found", p.display())));
                }
                self.search_dirs.insert(0, p);
                Ok(())
            }
            "include" => {
                let name = elem.req_attr("filename")?;
                if depth >= MAX_INCLUDE_DEPTH {
                    return Err(elem.loc.error(format!("<include> nested more than {MAX_INCLUDE_DEPTH} levels deep (a cycle?)")));
                }
                let path = self.resolve(&elem.loc, name).ok_or_else(|| {
                    elem.loc.error(format!("included file \"{name}\" not found (looked next to {})", elem.loc.file.display()))
                })?;
                self.includes += 1;
                if self.includes > MAX_INCLUDES {
                    return Err(elem.loc.error(format!(
                        "<include>: more than {MAX_INCLUDES} files included in all (files that include each other several times multiply)"
                    )));
                }
                let text = crate::files::read_to_string(&path).map_err(|e| elem.loc.error(format!("cannot read included file {e}")))?;
                self.included_bytes += text.len() as u64;
                if self.included_bytes > MAX_INCLUDED_BYTES {
                    return Err(elem.loc.error(format!(
                        "<include>: more than {} of included text in all",
                        octolux::budget::format_bytes(MAX_INCLUDED_BYTES)
                    )));
                }
                let inc = Rc::new(path);
                self.document(&text, &inc, Some(legacy), depth + 1, out)
            }
            _ => {
                let mut elem = elem;
                if self.nesting >= MAX_XML_DEPTH {
                    return Err(elem
                        .loc
                        .error(format!("elements are nested more than {MAX_XML_DEPTH} levels deep (included files count)")));
                }
                self.nesting += 1;
                let mut children = Vec::new();
                for child in node.children() {
                    self.node(doc, child, file, legacy, depth, &mut children)?;
                }
                self.nesting -= 1;
                if legacy && elem.tag == "bsdf" && elem.attr("type") == Some("diffuse") {
                    for c in &mut children {
                        for (k, v) in &mut c.attrs {
                            if k == "name" && v == "diffuse_reflectance" {
                                *v = "reflectance".into();
                            }
                        }
                    }
                }
                elem.children = children;
                out.push(elem);
                Ok(())
            }
        }
    }

    /// Resolve a file name relative to the element's file, the main scene folder and the
    /// `<path>` folders, in that order.
    fn resolve(&self, loc: &Loc, name: &str) -> Option<PathBuf> {
        resolve_file(loc, name, &self.main_dir, &self.search_dirs)
    }
}

/// Find a referenced file: absolute paths as they are; relative ones next to the file that
/// names them, then in the main scene folder, then in the `<path>` folders.
pub(crate) fn resolve_file(loc: &Loc, name: &str, main_dir: &Path, search_dirs: &[PathBuf]) -> Option<PathBuf> {
    let p = Path::new(name);
    if p.is_absolute() {
        return p.exists().then(|| p.to_path_buf());
    }
    let candidates: Vec<PathBuf> = std::iter::once(loc.dir())
        .chain(std::iter::once(main_dir))
        .chain(search_dirs.iter().map(PathBuf::as_path))
        .map(|d| d.join(p))
        .collect();
    // the first regular file; else the first thing of that name, which the reader then refuses
    // saying what it is (a folder, a device), rather than "not found"
    candidates.iter().find(|c| c.is_file()).or_else(|| candidates.iter().find(|c| c.exists())).cloned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camel_case_names_follow_mitsuba_upgrade_rule() {
        assert_eq!(camel_to_snake("toWorld"), "to_world");
        assert_eq!(camel_to_snake("intIOR"), "int_ior");
        assert_eq!(camel_to_snake("sampleCount"), "sample_count");
        assert_eq!(camel_to_snake("specularReflectance"), "specular_reflectance");
        assert_eq!(camel_to_snake("max_depth"), "max_depth");
        assert_eq!(camel_to_snake("uscale"), "uscale");
        assert_eq!(camel_to_snake("alphaU"), "alpha_u");
    }

    #[test]
    fn versions_parse() {
        assert_eq!(parse_version("0.5.0"), Some((0, 5, 0)));
        assert_eq!(parse_version("3.0.0"), Some((3, 0, 0)));
        assert_eq!(parse_version("3.0"), None);
    }
}
