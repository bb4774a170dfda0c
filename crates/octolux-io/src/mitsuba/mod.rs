//! Mitsuba XML scene loader: Mitsuba 3 syntax and the 0.5/0.6 dialect of most research scenes
//! (root `version` < 2.0.0, camelCase parameter names), producing a [`SceneDesc`].
//!
//! Stages: `tree` reads the file(s) and applies the scene-language directives (`$param`,
//! `<default>`, `<include>`, `<path>`, dialect upgrade); `props` gives typed, use-tracked
//! access to a plugin's parameters (`spectra` holds the colour tables); this module walks the
//! scene and one module per plugin kind turns plugins into octolux descriptions: `sensor`
//! (sensor, film, rfilter, sampler), `bsdf`, `texture`, `shape` and `emitter`.
//!
//! Conventions and choices (each departure from Mitsuba is reported as one warning naming the
//! file, line and element; loading goes on):
//! - Defaults are Mitsuba 3's: film 768x576 with a Gaussian filter (stddev 0.5), sampler 4 spp,
//!   `near_clip` 0.01, focal length 50 mm when no `fov`, diffuse reflectance 0.5, dielectric
//!   `int_ior` bk7 / `ext_ior` air, plastic `int_ior` polypropylene, microfacet `alpha` 0.1,
//!   spot `cutoff_angle` 20° and `beam_width` 3/4 of it, emitter intensities 1.
//! - A shape without a bsdf gets Mitsuba's default `diffuse` (0.5). Top-level bsdfs are
//!   instantiated in document order, so material indices follow the file.
//! - `conductor` presets use Mitsuba 3's RGB eta/k values (module `spectra`); `"none"` (and the
//!   default) is a perfect mirror, stored as `eta = k = 0` (octolux's convention).
//! - Microfacet bsdfs (`roughconductor`, `roughdielectric`, `roughplastic`) use the file's
//!   `distribution` (Beckmann by default, or GGX) and anisotropic `alpha_u`/`alpha_v`
//!   (`roughplastic`: isotropic only, as in Mitsuba); `sample_visible = false` is read as
//!   true with a warning (a sampling choice: the same image in expectation). Mitsuba 0.6's
//!   `ward` and `phong` follow 0.6's definitions, including `ensureEnergyConservation`.
//! - `mask`, `bumpmap` and `normalmap` use their nested bsdf; `thinlens` is a pinhole camera.
//! - A bsdf of Mitsuba that octolux does not read (`hair`, `principled`, 0.6's `coating`...) is
//!   a warning and Mitsuba's default diffuse; a bsdf type that no Mitsuba has (`difuse`) is an
//!   error naming the closest type, as Mitsuba refuses the file too.
//! - The sampler type is irrelevant (only `sample_count` is read); `ldrfilm` is read as
//!   `hdrfilm`; tone-mapping and output parameters are ignored with a warning.
//! - Geometry is transformed to world space here; spheres keep an analytic form when their
//!   `to_world` is a similarity (uniform scale, rotation, translation), else it is an error.
//!   Meshes (`obj`, `ply`, `serialized`) and `rectangle`, `disk`, `cube` face the side Mitsuba 3
//!   gives them under any `to_world`, mirrors included (module `shape`,
//!   [`crate::mesh::place_mesh`]); a mesh with only degenerate triangles is skipped with one
//!   warning.

mod bsdf;
mod emitter;
mod environment;
mod props;
mod sensor;
mod shape;
pub(crate) mod spectra;
mod texture;
mod tree;

use crate::{IoError, LoadedScene};
use octolux::scene::material::TexFilter;
use octolux::scene::{FilmDesc, PixelFilter, SceneDesc};
use props::Props;
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use tree::Elem;

/// The candidate closest to `word` by edit distance (insertions, deletions, substitutions and
/// swaps of two neighbours), if it is close enough to be a typo of it: at most 2 edits, and
/// fewer than half of `word`'s letters. The first of equally close candidates wins.
pub(crate) fn did_you_mean<'a>(word: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let w: Vec<char> = word.chars().collect();
    let mut best: Option<(usize, &str)> = None;
    for c in candidates {
        let d = edit_distance(&w, &c.chars().collect::<Vec<_>>());
        let closer = match best {
            Some((b, _)) => d < b,
            None => true,
        };
        if d <= 2 && 2 * d < w.len() && closer {
            best = Some((d, c));
        }
    }
    best.map(|(_, c)| c)
}

/// Optimal string alignment distance (Levenshtein plus swaps of neighbours).
fn edit_distance(a: &[char], b: &[char]) -> usize {
    // rows i-2, i-1 and i of the table
    let mut prev2: Vec<usize> = vec![0; b.len() + 1];
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for i in 1..=a.len() {
        let mut cur = vec![i; b.len() + 1];
        for j in 1..=b.len() {
            let cost = usize::from(a[i - 1] != b[j - 1]);
            cur[j] = (prev[j] + 1).min(cur[j - 1] + 1).min(prev[j - 1] + cost);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                cur[j] = cur[j].min(prev2[j - 2] + 1);
            }
        }
        prev2 = std::mem::replace(&mut prev, cur);
    }
    prev[b.len()]
}

/// Load a Mitsuba XML scene. `defines` override `<default>` parameters (like `mitsuba -D`).
pub fn load(path: &Path, defines: &[(String, String)]) -> Result<LoadedScene, IoError> {
    let mut warnings = Vec::new();
    let tree = tree::read(path, defines, &mut warnings)?;
    build(&tree, path, warnings)
}

/// Load a scene from XML text; `path` names it in messages and anchors relative file names.
pub fn load_str(text: &str, path: &Path, defines: &[(String, String)]) -> Result<LoadedScene, IoError> {
    let mut warnings = Vec::new();
    let tree = tree::read_str(text, path, defines, &mut warnings)?;
    build(&tree, path, warnings)
}

fn build(tree: &tree::Tree, path: &Path, warnings: Vec<String>) -> Result<LoadedScene, IoError> {
    let mut ids = HashMap::new();
    let mut aliases = Vec::new();
    collect_ids(&tree.root, &mut ids, &mut aliases)?;
    for a in &aliases {
        let from = a.req_attr("id")?;
        let to = a.req_attr("as")?;
        let target = *ids.get(from).ok_or_else(|| a.loc.error(format!("<alias>: reference to unknown id \"{from}\"")))?;
        if ids.insert(to.to_string(), target).is_some() {
            return Err(a.loc.error(format!("<alias>: id \"{to}\" is already used")));
        }
    }
    RefCheck { ids: &ids, memo: HashMap::new(), path: Vec::new() }.subtree(&tree.root, 0)?;
    let mut referenced = HashSet::new();
    collect_refs(&tree.root, &mut referenced);
    for a in &aliases {
        if let (Some(id), Some(to)) = (a.attr("id"), a.attr("as")) {
            if referenced.contains(to) {
                referenced.insert(id.to_string());
            }
        }
    }
    let main_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let prefetched = shape::prefetch_meshes(&tree.root, &main_dir, &tree.search_dirs);
    let mut b = Builder {
        ids,
        referenced,
        main_dir,
        search_dirs: &tree.search_dirs,
        prefetched,
        desc: SceneDesc::default(),
        warnings,
        notes: Vec::new(),
        materials: HashMap::new(),
        images: HashMap::new(),
        mipmaps: HashMap::new(),
        default_material: None,
        sensors: Vec::new(),
        default_emitter_material: None,
        mesh_totals: (0, 0),
    };
    b.scene(&tree.root)?;
    Ok(LoadedScene { desc: b.desc, warnings: b.warnings, sensors: b.sensors, notes: b.notes })
}

/// The check of `<ref>`s before any plugin is built (issue 27): the builder follows a `<ref>`
/// into its target, so a cycle (`<bsdf id="x"><ref id="x"/></bsdf>`) would recurse until the
/// stack overflows, and a long chain of objects each holding a reference to the next would
/// too. A cycle is an error naming its ids at the `<ref>` that closes it; nesting through
/// references deeper than [`tree::MAX_XML_DEPTH`] levels is an error like nesting in a file.
/// Each target is walked once (its depth remembered), so shared objects cost nothing more.
struct RefCheck<'t> {
    ids: &'t HashMap<String, &'t Elem>,
    /// Deepest nesting below each target already walked.
    memo: HashMap<*const Elem, usize>,
    /// The references followed to the element being walked.
    path: Vec<(&'t str, *const Elem)>,
}

impl<'t> RefCheck<'t> {
    /// The deepest nesting below `e` (0 for a leaf), references followed; `base` is `e`'s.
    fn subtree(&mut self, e: &'t Elem, base: usize) -> Result<usize, IoError> {
        let mut deepest = 0;
        for c in &e.children {
            let below = match (c.tag.as_str(), c.attr("id").and_then(|id| self.ids.get(id).map(|t| (id, *t)))) {
                // an unknown id is reported where the reference is used
                ("ref", Some((id, target))) => self.target(c, id, target, base + 1)?,
                ("ref", None) => 0,
                _ => self.subtree(c, base + 1)?,
            };
            deepest = deepest.max(1 + below);
        }
        Ok(deepest)
    }

    fn target(&mut self, r: &'t Elem, id: &'t str, target: &'t Elem, base: usize) -> Result<usize, IoError> {
        let key = target as *const Elem;
        if let Some(pos) = self.path.iter().position(|&(_, k)| k == key) {
            let ids: Vec<&str> = self.path[pos..].iter().map(|&(i, _)| i).chain([id]).collect();
            return Err(r
                .loc
                .error(format!("<ref id=\"{id}\">: the references make a cycle: {} (an object cannot hold itself)", ids.join(" -> "))));
        }
        let depth = match self.memo.get(&key) {
            Some(&d) => d,
            None if base > tree::MAX_XML_DEPTH => 0,
            None => {
                self.path.push((id, key));
                let d = self.subtree(target, base)?;
                self.path.pop();
                self.memo.insert(key, d);
                d
            }
        };
        if base + depth > tree::MAX_XML_DEPTH {
            return Err(r
                .loc
                .error(format!("<ref id=\"{id}\">: objects are nested more than {} levels deep through references", tree::MAX_XML_DEPTH)));
        }
        Ok(depth)
    }
}

/// The ids named by `<ref>` elements anywhere under `e`.
fn collect_refs(e: &Elem, refs: &mut HashSet<String>) {
    for c in &e.children {
        if c.tag == "ref" {
            if let Some(id) = c.attr("id") {
                refs.insert(id.to_string());
            }
        }
        collect_refs(c, refs);
    }
}

/// Mitsuba integrators whose image octolux's `path` renders (path tracers: the volumetric and
/// differentiable variants give the same image on surface scenes).
pub const PATH_TRACERS: &[&str] = &["path", "volpath", "volpathmis", "prb", "prb_basic", "prbvolpath"];

/// Integrators of other methods that converge to the image a path tracer converges to (unbiased
/// or consistent light transport on surface scenes: bidirectional, particle and photon tracers,
/// Metropolis methods, path guiding): octolux's `path` renders that image, so a scene naming
/// one gets a note, not a warning, and its `max_depth` has a path tracer's meaning (Mitsuba's
/// default -1 when absent).
pub const SAME_IMAGE: &[&str] =
    &["bdpt", "ptracer", "photonmapper", "ppm", "sppm", "pssmlt", "mlt", "erpt", "guided_path", "volpath_simple"];

/// Map every object `id` to its element; duplicate ids are an error.
fn collect_ids<'t>(e: &'t Elem, ids: &mut HashMap<String, &'t Elem>, aliases: &mut Vec<&'t Elem>) -> Result<(), IoError> {
    for c in &e.children {
        if c.tag == "alias" {
            aliases.push(c);
            continue;
        }
        if c.tag != "ref" && !props::is_value(c) {
            if let Some(id) = c.attr("id") {
                if let Some(prev) = ids.insert(id.to_string(), c) {
                    return Err(c.loc.error(format!("{} has duplicate id \"{id}\" (previous at {})", c.describe(), prev.loc)));
                }
            }
        }
        collect_ids(c, ids, aliases)?;
    }
    Ok(())
}

struct Builder<'t> {
    ids: HashMap<String, &'t Elem>,
    /// Ids some `<ref>` names (directly or through an `<alias>`).
    referenced: HashSet<String>,
    main_dir: PathBuf,
    search_dirs: &'t [PathBuf],
    desc: SceneDesc,
    warnings: Vec<String>,
    /// See [`LoadedScene::notes`].
    notes: Vec<String>,
    /// Material index of each bsdf element already instantiated (by address).
    materials: HashMap<*const Elem, u32>,
    /// Image index of each texture file already read, per decoding (`raw`, 0.6's `gamma`).
    images: HashMap<(PathBuf, texture::Decode), u32>,
    /// The trilinear filter (MIP pyramid) of each image index that has one.
    mipmaps: HashMap<u32, TexFilter>,
    default_material: Option<u32>,
    /// The camera of every usable sensor, in file order.
    sensors: Vec<octolux::scene::camera::CameraDesc>,
    /// Black diffuse: the bsdf Mitsuba (3 and 0.6) gives an emitting shape that names none.
    default_emitter_material: Option<u32>,
    /// Mesh files read ahead in parallel ([`shape::prefetch_meshes`]), taken on first use.
    prefetched: HashMap<PathBuf, Result<crate::mesh::RawMesh, IoError>>,
    /// Vertices and triangles of every mesh shape so far, checked against the memory budget
    /// as a whole (`shape.rs`: one mesh file named by many shapes is read once per shape).
    mesh_totals: (u64, u64),
}

/// Mitsuba 3's film when a scene gives none.
const DEFAULT_FILM: FilmDesc = FilmDesc { width: 768, height: 576, filter: PixelFilter::Gaussian { stddev: 0.5 }, sample_border: false };

impl<'t> Builder<'t> {
    fn warn(&mut self, e: &Elem, msg: impl std::fmt::Display) {
        self.warnings.push(e.warning(msg));
    }

    /// Parameters `names` of `p` that Mitsuba's `plugin` does not have either (Mitsuba ignores
    /// them too): used up with a note each, not a warning.
    fn not_mitsuba_params(&mut self, p: &props::Props<'t>, names: &[&str], plugin: &str) {
        for n in names {
            if let Some(entry) = p.get(n) {
                self.notes
                    .push(format!("{}: `{n}` is not a parameter of Mitsuba's {plugin} (Mitsuba ignores it too); ignored", entry.elem.loc));
            }
        }
    }

    fn props(&self, e: &'t Elem) -> Result<Props<'t>, IoError> {
        Props::new(e, &self.ids)
    }

    fn scene(&mut self, root: &'t Elem) -> Result<(), IoError> {
        self.desc.film = DEFAULT_FILM;
        let mut have_sensor = false;
        for c in &root.children {
            match c.tag.as_str() {
                "integrator" => self.integrator(c)?,
                "sensor" => {
                    if have_sensor {
                        // Read for `render --sensors`, without changing the first one's camera,
                        // film and sample count.
                        let kept = (self.desc.camera.clone(), self.desc.film, self.desc.hints.spp);
                        if self.sensor(c)? {
                            self.sensors.push(self.desc.camera.clone());
                            if self.desc.film != kept.1 {
                                self.warn(c, "this sensor's film differs from the first one's; its frame uses the first film");
                            }
                            let n = self.sensors.len();
                            self.warn(
                                c,
                                format!("a single image uses the first sensor only; this one is frame {n} of `octolux render --sensors`"),
                            );
                        }
                        (self.desc.camera, self.desc.film, self.desc.hints.spp) = kept;
                    } else {
                        have_sensor = self.sensor(c)?;
                        if have_sensor {
                            self.sensors.push(self.desc.camera.clone());
                        }
                    }
                }
                "bsdf" => {
                    self.material_index(c)?;
                }
                "shape" => self.shape(c)?,
                "emitter" => self.emitter(c)?,
                // Instantiated when referenced; a bitmap's file must exist even when unused.
                "texture" => self.scene_level_texture(c)?,
                "alias" => {}
                "ref" => self.warn(c, "a reference at scene level does nothing; ignored"),
                "medium" | "phase" | "volume" => self.warn(c, "participating media are not supported; ignored"),
                t if props::is_value(c) => self.warn(c, format!("<{t}> at scene level is not a scene parameter; ignored")),
                t => self.warn(c, format!("unsupported element <{t}>; ignored")),
            }
        }
        if !have_sensor {
            self.warnings.push(format!("{}: {}: no usable sensor; using Mitsuba's default camera and film", root.loc, root.describe()));
        }
        Ok(())
    }

    fn integrator(&mut self, e: &'t Elem) -> Result<(), IoError> {
        let ty = e.req_attr("type")?;
        let p = self.props(e)?;
        let depth = p.int("max_depth")?;
        if let Some(d) = depth {
            // the one check of the value, as for the flag, --set, settings files and caches
            crate::settings::check_max_depth(d).map_err(|m| e.loc.error(format!("{}: max_depth {m}", e.describe())))?;
            if d > i32::MAX as i64 {
                return Err(e.loc.error(format!("{}: max_depth {d} is too large (at most {})", e.describe(), i32::MAX)));
            }
        }
        // Other methods whose max_depth means a path tracer's (unbounded by default).
        let path_like = PATH_TRACERS.contains(&ty) || SAME_IMAGE.contains(&ty);
        self.desc.hints.max_depth = depth.map(|d| d as i32).or(path_like.then_some(-1));
        self.desc.hints.integrator = Some(ty.to_string());
        // Russian roulette only changes the variance.
        p.accept(&["rr_depth"]);
        // The parameters of another method's integrator (sppm's photon counts, ...) say nothing
        // about the image octolux renders: one line names them all. A path tracer's are
        // reported one by one, since some (`hide_emitters`, `strict_normals`) change its image.
        if !PATH_TRACERS.contains(&ty) {
            let names = p.take_unused_values();
            if !names.is_empty() {
                let msg = format!(
                    "parameters of the \"{ty}\" integrator are ignored (octolux's integrator and its settings are chosen \
                     on its command line; only max_depth is read as a default): {}",
                    names.join(", ")
                );
                // Another method's tuning of how it converges (sppm's photon counts, ...) does
                // not change the image it converges to: a note. An unknown type's: a warning.
                if path_like {
                    self.notes.push(e.warning(msg));
                } else {
                    self.warn(e, msg);
                }
            }
        }
        p.finish(&mut self.warnings);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::did_you_mean;

    #[test]
    fn typos_find_their_word_and_strangers_find_none() {
        let words = ["diffuse", "dielectric", "roughconductor", "plastic", "roughplastic", "hk"];
        assert_eq!(did_you_mean("difuse", words), Some("diffuse"));
        assert_eq!(did_you_mean("Diffuse", words), Some("diffuse"));
        assert_eq!(did_you_mean("idffuse", words), Some("diffuse"), "a swap is one edit");
        assert_eq!(did_you_mean("roughconductr", words), Some("roughconductor"));
        assert_eq!(did_you_mean("plastc", words), Some("plastic"));
        assert_eq!(did_you_mean("roughplastik", words), Some("roughplastic"));
        assert_eq!(did_you_mean("glass", words), None);
        assert_eq!(did_you_mean("disney", words), None);
        // a short word needs a closer match: "hx" is 1 edit from "hk", half of its letters
        assert_eq!(did_you_mean("hx", words), None);
        assert_eq!(did_you_mean("", words), None);
    }
}
