//! glTF 2.0 scenes (`.gltf` with its buffers and images, or `.glb`; issue 15, item 3), read
//! with the `gltf` crate, which validates the document.
//!
//! What is read, and how it maps onto octolux:
//! - the default scene (else the first), its node tree with every node's transform;
//! - mesh primitives in `TRIANGLES` mode: positions, normals, first texture coordinates,
//!   indices (a transform that mirrors reverses the winding, as the specification says);
//!   other modes are skipped with a warning; glTF's texture origin is the image's top left,
//!   so v becomes 1 − v (Mitsuba's and octolux's origin is the bottom left);
//! - metallic-roughness materials. glTF's BRDF is a GGX microfacet model (alpha = roughness²)
//!   that blends, by `metallic`, a dielectric (IOR 1.5: a specular coat over the base colour
//!   as diffuse) and a metal whose reflectance is the base colour. octolux renders it as
//!   `roughplastic` (GGX, IOR 1.5, base colour (texture) as diffuse reflectance) for
//!   metallic 0, `roughconductor` with a perfect mirror tinted by the base colour for
//!   metallic 1, and a `blendbsdf` of the two in between; every material is two-sided (as
//!   Blender and most viewers shade it). The base-colour texture is read; metallic-roughness,
//!   normal, occlusion and emissive textures are replaced by their factors, with a warning;
//! - emissive materials (`emissiveFactor` × `KHR_materials_emissive_strength`) make their
//!   primitives area lights of that radiance (W/(m² sr), front side);
//! - cameras: the first perspective camera in the node tree is the scene's camera (`yfov`
//!   along the vertical axis; glTF cameras look down −z with +y up), every perspective camera
//!   is a sensor for `--sensors`; the film is 640 pixels wide with the first camera's aspect
//!   ratio (else 640×480);
//! - `KHR_lights_punctual`: photometric units converted at 683 lm/W — point and spot lights'
//!   candela become W/sr (intensity / 683), a directional light's lux W/m²; spot cones from
//!   `innerConeAngle` / `outerConeAngle`; `range` is ignored (physical falloff), with a warning.
//!
//! A scene without any light gets none: octolux warns that it renders black.

use crate::{IoError, LoadedScene};
use glam::{Mat4, Vec2, Vec3};
use octolux::math::{Color, Frame};
use octolux::scene::camera::{CameraDesc, FovAxis};
use octolux::scene::material::microfacet::{Microfacet, MicrofacetKind, Roughness};
use octolux::scene::material::{Material, Texture};
use octolux::scene::{FilmDesc, Geometry, Light, SceneDesc, ShapeDesc, TriMesh};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

/// Width of the film of a glTF scene (its height follows the camera's aspect ratio).
pub const FILM_WIDTH: u32 = 640;
/// Photometric to radiometric units at 555 nm (lm/W).
const LUMENS_PER_WATT: f32 = 683.0;
/// glTF's dielectric index of refraction (F0 = 0.04).
const IOR: f32 = 1.5;

struct Loader<'a> {
    path: &'a Path,
    buffers: Vec<Vec<u8>>,
    desc: SceneDesc,
    warnings: Vec<String>,
    /// glTF material index (None: the default material) -> octolux material and emission.
    materials: HashMap<Option<usize>, (u32, Option<Color>)>,
    /// glTF image index -> octolux image index.
    images: HashMap<usize, u32>,
    cameras: Vec<(CameraDesc, Option<f32>)>,
}

/// Whether buffer and image URIs may name files outside the glTF file's folder
/// ([`allow_outside_uris`]).
static ALLOW_OUTSIDE: AtomicBool = AtomicBool::new(false);

/// Let the URIs of glTF buffers and images name files outside the glTF file's folder (absolute
/// paths, `../`): the CLI's `--allow-outside-uris`. Off by default: a downloaded scene then
/// reads only files beside it, never `/etc/...`.
pub fn allow_outside_uris(allow: bool) {
    ALLOW_OUTSIDE.store(allow, Ordering::Relaxed);
}

/// Most node instances of a scene's node tree (a node listed as a child twice is instanced
/// twice, so the tree of a small file can make many).
pub const MAX_NODE_INSTANCES: u64 = 1_000_000;

/// Load a `.gltf` or `.glb` scene.
pub fn load(path: &Path) -> Result<LoadedScene, IoError> {
    let bytes = crate::files::read(path)?;
    load_bytes(path, &bytes)
}

/// Load a glTF scene from the bytes of its file; `path` names it in messages and anchors its
/// relative URIs (which may not leave its folder, [`allow_outside_uris`]).
pub fn load_bytes(path: &Path, bytes: &[u8]) -> Result<LoadedScene, IoError> {
    octolux::budget::check_items(|| format!("a glTF file of {} bytes", bytes.len()), bytes.len() as u64, 4)
        .map_err(|e| IoError::invalid(path, e.to_string()))?;
    let not_valid = |e: gltf::Error| IoError::invalid(path, format!("not a valid glTF 2.0 file: {e}"));
    // A .glb is split here: the gltf crate's splitter subtracts the header's size from the
    // length it gives before checking it (an overflow panic, found by the fuzz target).
    let (json_bytes, blob) = if bytes.starts_with(b"glTF") {
        let (json, bin) = split_glb(bytes).map_err(|m| IoError::invalid(path, format!("not a valid .glb file: {m}")))?;
        (json, bin.map(<[u8]>::to_vec))
    } else {
        (bytes, None)
    };
    let root = gltf::json::deserialize::from_slice(json_bytes).map_err(|e| not_valid(gltf::Error::Deserialize(e)))?;
    let gltf = gltf::Gltf { document: gltf::Document::from_json_without_validation(root), blob };
    // The gltf crate's validation reads the accessor a POSITION names before it checks that
    // the accessor exists (an index out of bounds: a panic, found by the fuzz target): checked
    // here first, then the crate validates the rest.
    let json = gltf.document.as_json();
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (k, prim) in mesh.primitives.iter().enumerate() {
            let pos = prim.attributes.get(&gltf::json::validation::Checked::Valid(gltf::Semantic::Positions));
            if let Some(i) = pos.map(|i| i.value()).filter(|&i| i >= json.accessors.len()) {
                return Err(IoError::invalid(
                    path,
                    format!("mesh {m}: primitive {k}: POSITION names accessor {i}, but the file has {}", json.accessors.len()),
                ));
            }
        }
    }
    let document = gltf::Document::from_json(gltf.document.into_json()).map_err(not_valid)?;
    let gltf = gltf::Gltf { document, blob: gltf.blob };
    let buffers = read_buffers(path, &gltf.document, gltf.blob.clone())?;
    let mut l = Loader {
        path,
        buffers,
        desc: SceneDesc::default(),
        warnings: Vec::new(),
        materials: HashMap::new(),
        images: HashMap::new(),
        cameras: Vec::new(),
    };
    let doc = &gltf.document;
    let scene = doc.default_scene().or_else(|| doc.scenes().next()).ok_or_else(|| IoError::invalid(path, "the glTF file has no scene"))?;
    let roots: Vec<usize> = scene.nodes().map(|n| n.index()).collect();
    check_node_tree(path, doc, &roots)?;
    let mut stack: Vec<(gltf::Node, Mat4)> = scene.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
    stack.reverse();
    while let Some((node, parent)) = stack.pop() {
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        if !world.is_finite() {
            l.warnings.push(format!("{}: node {} has a non-finite transform; skipped", path.display(), node.index()));
            continue;
        }
        if let Some(mesh) = node.mesh() {
            l.mesh(&mesh, &world)?;
        }
        if let Some(cam) = node.camera() {
            l.camera(&cam, &world);
        }
        if let Some(light) = node.light() {
            l.light(&light, &world);
        }
        let children: Vec<_> = node.children().map(|c| (c, world)).collect();
        stack.extend(children.into_iter().rev());
    }
    let Loader { mut desc, warnings, cameras, .. } = l;
    let aspect = cameras.first().and_then(|c| c.1);
    desc.film = FilmDesc {
        width: FILM_WIDTH,
        height: aspect.map_or(480, |a| ((FILM_WIDTH as f32 / a).round() as u32).max(1)),
        ..FilmDesc::default()
    };
    let sensors: Vec<CameraDesc> = cameras.into_iter().map(|c| c.0).collect();
    desc.camera = match sensors.first() {
        Some(c) => c.clone(),
        None => crate::mesh::framing_camera(desc.bounds()),
    };
    Ok(LoadedScene { desc, warnings, sensors, notes: Vec::new() })
}

/// The JSON chunk and the optional binary chunk of a `.glb` file (its 12-byte header: magic,
/// version 2, length; then chunks of a length, a type and the data, each padded to 4 bytes),
/// every length checked against the bytes there are.
fn split_glb(bytes: &[u8]) -> Result<(&[u8], Option<&[u8]>), String> {
    let word = |at: usize| bytes.get(at..at + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize);
    let (Some(version), Some(length)) = (word(4), word(8)) else { return Err("the 12-byte header is cut short".into()) };
    if version != 2 {
        return Err(format!("version {version} (octolux reads glTF 2)"));
    }
    if length < 12 || length > bytes.len() {
        return Err(format!("the header gives a length of {length} bytes, but the file has {}", bytes.len()));
    }
    let mut chunks = Vec::new();
    let mut at = 12;
    while at < length && chunks.len() < 2 {
        let (Some(len), Some(ty)) = (word(at), bytes.get(at + 4..at + 8)) else {
            return Err(format!("chunk {} is cut short", chunks.len()));
        };
        let data = at.checked_add(8).and_then(|s| Some((s, s.checked_add(len)?))).filter(|&(_, e)| e <= length);
        let Some((start, end)) = data else { return Err(format!("chunk {} of {len} bytes passes the end of the file", chunks.len())) };
        chunks.push((ty, &bytes[start..end]));
        at = end.div_ceil(4) * 4;
    }
    match chunks.as_slice() {
        [(b"JSON", json)] => Ok((json, None)),
        [(b"JSON", json), (b"BIN\0", bin)] => Ok((json, Some(bin))),
        [(b"JSON", json), _] => Ok((json, None)),
        _ => Err("the first chunk is not JSON".into()),
    }
}

/// The data of every buffer: the GLB's binary chunk, a `data:` URI (base64), or a file named
/// by a relative URI inside the glTF file's folder ([`local_file`]), read by the rule of
/// [`crate::files`] (a regular file within the memory budget: `"uri": "/dev/zero"` is refused).
/// A buffer shorter than its `byteLength` is an error.
fn read_buffers(path: &Path, doc: &gltf::Document, mut blob: Option<Vec<u8>>) -> Result<Vec<Vec<u8>>, IoError> {
    let mut out = Vec::new();
    for b in doc.buffers() {
        let i = b.index();
        let data = match b.source() {
            gltf::buffer::Source::Bin => blob
                .take()
                .ok_or_else(|| IoError::invalid(path, format!("buffer {i} is the binary chunk of a .glb, which this file lacks")))?,
            gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                decode_data_uri(uri).ok_or_else(|| IoError::invalid(path, format!("buffer {i}: its data: URI is not base64 data")))?
            }
            gltf::buffer::Source::Uri(uri) => {
                let file = local_file(path, uri).map_err(|m| IoError::invalid(path, format!("buffer {i}: {m}")))?;
                crate::files::read(&file).map_err(|e| IoError::invalid(path, format!("buffer {i}: {e}")))?
            }
        };
        if data.len() < b.length() {
            return Err(IoError::invalid(path, format!("buffer {i} holds {} bytes, less than its byteLength {}", data.len(), b.length())));
        }
        out.push(data);
    }
    Ok(out)
}

/// The file a relative URI names beside the glTF file; absolute paths, other schemes and
/// names that leave the folder (`../`, a link pointing out) are refused unless
/// [`allow_outside_uris`].
fn local_file(gltf_path: &Path, uri: &str) -> Result<PathBuf, String> {
    let name = percent_decode(uri);
    let base = gltf_path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let file = base.join(&name);
    if ALLOW_OUTSIDE.load(Ordering::Relaxed) {
        return Ok(file);
    }
    let outside = || format!("URI \"{uri}\" names a file outside the glTF file's folder (allow it with --allow-outside-uris)");
    if Path::new(&name).is_absolute() || uri.contains("://") {
        return Err(outside());
    }
    // a missing file is reported by the reader; one that exists must resolve inside the folder
    if let (Ok(f), Ok(b)) = (file.canonicalize(), base.canonicalize()) {
        if !f.starts_with(&b) {
            return Err(outside());
        }
    } else if Path::new(&name).components().any(|c| matches!(c, std::path::Component::ParentDir)) {
        return Err(outside());
    }
    Ok(file)
}

/// The bytes of a `data:[<mime>];base64,<data>` URI.
fn decode_data_uri(uri: &str) -> Option<Vec<u8>> {
    let (head, data) = uri.split_once(',')?;
    if !head.ends_with(";base64") {
        return None;
    }
    let value = |c: u8| -> Option<u32> {
        Some(match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            _ => return None,
        } as u32)
    };
    let digits: Vec<u8> = data.bytes().filter(|&c| c != b'=' && !c.is_ascii_whitespace()).collect();
    let mut out = Vec::with_capacity(digits.len() / 4 * 3 + 3);
    for chunk in digits.chunks(4) {
        if chunk.len() == 1 {
            return None;
        }
        let mut n = 0u32;
        for (k, &c) in chunk.iter().enumerate() {
            n |= value(c)? << (18 - 6 * k);
        }
        out.extend_from_slice(&n.to_be_bytes()[1..chunk.len()]);
    }
    Some(out)
}

/// The node tree of the scene, checked before any mesh is read: a node that is its own
/// ancestor (a cycle) is an error naming the cycle; a node listed as a child several times is
/// instanced each time, so the node instances ([`MAX_NODE_INSTANCES`]) and the triangles and
/// vertices after instancing (counted from the accessors, within the memory budget) are
/// bounded before they are made.
fn check_node_tree(path: &Path, doc: &gltf::Document, roots: &[usize]) -> Result<(), IoError> {
    let nodes: Vec<gltf::Node> = doc.nodes().collect();
    let children: Vec<Vec<usize>> = nodes.iter().map(|n| n.children().map(|c| c.index()).collect()).collect();
    // (instances, vertices, triangles) below and at each node, once known
    let mut totals: Vec<Option<(u64, u64, u64)>> = vec![None; nodes.len()];
    let mut on_path = vec![false; nodes.len()];
    let mesh_size = |n: &gltf::Node| -> (u64, u64) {
        n.mesh().map_or((0, 0), |m| {
            m.primitives().fold((0, 0), |(v, t), p| {
                let verts = p.get(&gltf::Semantic::Positions).map_or(0, |a| a.count() as u64);
                let idx = p.indices().map_or(verts, |a| a.count() as u64);
                (v.saturating_add(verts), t.saturating_add(idx / 3))
            })
        })
    };
    for &root in roots {
        // iterative depth-first walk: (node, next child to visit)
        let mut stack: Vec<(usize, usize)> = Vec::new();
        if totals[root].is_none() {
            stack.push((root, 0));
            on_path[root] = true;
        }
        while let Some(&mut (n, ref mut next)) = stack.last_mut() {
            if let Some(&c) = children[n].get(*next) {
                *next += 1;
                if on_path[c] {
                    let from = stack.iter().position(|&(m, _)| m == c).unwrap_or(0);
                    let cycle: Vec<String> = stack[from..].iter().map(|&(m, _)| m.to_string()).chain([c.to_string()]).collect();
                    return Err(IoError::invalid(
                        path,
                        format!("node {c} is its own ancestor: the node tree has a cycle ({})", cycle.join(" -> ")),
                    ));
                }
                if totals[c].is_none() {
                    on_path[c] = true;
                    stack.push((c, 0));
                }
                continue;
            }
            stack.pop();
            on_path[n] = false;
            let (v, t) = mesh_size(&nodes[n]);
            let sum = children[n].iter().fold((1u64, v, t), |acc, &c| {
                let (ci, cv, ct) = totals[c].unwrap_or((0, 0, 0));
                (acc.0.saturating_add(ci), acc.1.saturating_add(cv), acc.2.saturating_add(ct))
            });
            totals[n] = Some(sum);
        }
    }
    let (instances, vertices, triangles) = roots.iter().fold((0u64, 0u64, 0u64), |acc, &r| {
        let (i, v, t) = totals[r].unwrap_or((0, 0, 0));
        (acc.0.saturating_add(i), acc.1.saturating_add(v), acc.2.saturating_add(t))
    });
    if instances > MAX_NODE_INSTANCES {
        return Err(IoError::invalid(
            path,
            format!(
                "the node tree makes {instances} node instances, more than {MAX_NODE_INSTANCES} (a node listed as a child \
                 several times is copied each time)"
            ),
        ));
    }
    octolux::budget::check_mesh(vertices, triangles).map_err(|e| IoError::invalid(path, format!("the node tree, once instanced: {e}")))
}

impl Loader<'_> {
    fn warn(&mut self, msg: String) {
        let line = format!("{}: {msg}", self.path.display());
        if !self.warnings.contains(&line) {
            self.warnings.push(line);
        }
    }

    fn mesh(&mut self, mesh: &gltf::Mesh, world: &Mat4) -> Result<(), IoError> {
        let name = mesh.name().map_or_else(|| format!("mesh {}", mesh.index()), String::from);
        for (k, prim) in mesh.primitives().enumerate() {
            if prim.mode() != gltf::mesh::Mode::Triangles {
                self.warn(format!("{name}: primitive {k} is drawn as {:?}, not triangles; skipped", prim.mode()));
                continue;
            }
            use gltf::accessor::{DataType as T, Dimensions as D};
            let Some(pos) = prim.get(&gltf::Semantic::Positions) else {
                self.warn(format!("{name}: primitive {k} has no positions; skipped"));
                continue;
            };
            // every accessor read is checked first: its type, and that it lies inside its
            // buffer (a bad one is an error naming it, never a primitive drawn another way)
            let bad = |m: String| IoError::invalid(self.path, format!("{name}: primitive {k}: {m}"));
            self.check_accessor(&pos, "POSITION", D::Vec3, &[T::F32]).map_err(bad)?;
            let normals_ok = match prim.get(&gltf::Semantic::Normals) {
                Some(a) => self.check_accessor(&a, "NORMAL", D::Vec3, &[T::F32]).map_err(bad).map(|()| true)?,
                None => false,
            };
            let uvs_ok = match prim.get(&gltf::Semantic::TexCoords(0)) {
                Some(a) => self.check_accessor(&a, "TEXCOORD_0", D::Vec2, &[T::F32, T::U8, T::U16]).map_err(bad).map(|()| true)?,
                None => false,
            };
            if let Some(a) = prim.indices() {
                self.check_accessor(&a, "index", D::Scalar, &[T::U8, T::U16, T::U32]).map_err(bad)?;
            }
            let buffers = &self.buffers;
            let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d[..]));
            let Some(positions) = reader.read_positions() else {
                return Err(bad("its positions cannot be read".into()));
            };
            let positions: Vec<Vec3> = positions.map(Vec3::from).collect();
            let n = positions.len();
            let normals: Option<Vec<Vec3>> =
                reader.read_normals().filter(|_| normals_ok).map(|it| it.map(Vec3::from).collect()).filter(|v: &Vec<Vec3>| v.len() == n);
            let uvs: Option<Vec<Vec2>> = reader
                .read_tex_coords(0)
                .filter(|_| uvs_ok)
                .map(|t| t.into_f32().map(|[u, v]| Vec2::new(u, 1.0 - v)).collect())
                .filter(|v: &Vec<Vec2>| v.len() == n);
            let flat: Vec<u32> = match (prim.indices(), reader.read_indices()) {
                (Some(_), Some(i)) => i.into_u32().collect(),
                (Some(_), None) => return Err(bad("its indices cannot be read".into())),
                (None, _) => (0..n as u32).collect(),
            };
            if !flat.len().is_multiple_of(3) || flat.iter().any(|&i| i as usize >= n) {
                return Err(IoError::invalid(
                    self.path,
                    format!("{name}: primitive {k} has indices that are not triangles of its vertices"),
                ));
            }
            let mirror = world.determinant() < 0.0;
            let indices = flat.chunks_exact(3).map(|t| if mirror { [t[0], t[2], t[1]] } else { [t[0], t[1], t[2]] }).collect();
            let mut tri = TriMesh { positions, normals, uvs, indices };
            tri.transform(world);
            let (material, emission) = self.material(&prim.material())?;
            let shape_name = if mesh.primitives().len() > 1 { format!("{name}/{k}") } else { name.clone() };
            self.desc.shapes.push(ShapeDesc { name: shape_name, geometry: Geometry::Mesh(tri), material, emission, flip_normals: false });
        }
        Ok(())
    }

    /// An accessor a primitive's data is read through: not sparse, of the expected shape and
    /// component types, with at least one value, and lying inside its buffer view and buffer
    /// (arithmetic checked, so the reader's own cannot overflow).
    fn check_accessor(
        &self,
        a: &gltf::Accessor,
        role: &str,
        dims: gltf::accessor::Dimensions,
        types: &[gltf::accessor::DataType],
    ) -> Result<(), String> {
        let i = a.index();
        if a.sparse().is_some() {
            return Err(format!("its {role} accessor {i} is sparse, which octolux does not read"));
        }
        if a.dimensions() != dims || !types.contains(&a.data_type()) {
            return Err(format!(
                "its {role} accessor {i} holds {:?} of {:?}, expected {dims:?} of {}",
                a.dimensions(),
                a.data_type(),
                types.iter().map(|t| format!("{t:?}")).collect::<Vec<_>>().join(" or ")
            ));
        }
        let count = a.count();
        if count == 0 {
            return Err(format!("its {role} accessor {i} holds no values"));
        }
        let Some(view) = a.view() else { return Err(format!("its {role} accessor {i} has no buffer view")) };
        let size = a.size();
        let stride = view.stride().unwrap_or(size);
        if stride < size {
            return Err(format!("its {role} accessor {i}: the stride {stride} is less than a value's {size} bytes"));
        }
        let end = (count - 1).checked_mul(stride).and_then(|x| x.checked_add(size)).and_then(|x| x.checked_add(a.offset()));
        let buffer = self.buffers.get(view.buffer().index()).map_or(0, Vec::len);
        let view_end = view.offset().checked_add(view.length());
        match (end, view_end) {
            (Some(e), Some(ve)) if e <= view.length() && ve <= buffer => Ok(()),
            _ => Err(format!(
                "its {role} accessor {i} ({count} values of {size} bytes from offset {}) lies outside its buffer view {} \
                 ({} bytes from offset {} of a {buffer}-byte buffer)",
                a.offset(),
                view.index(),
                view.length(),
                view.offset()
            )),
        }
    }

    fn material(&mut self, m: &gltf::Material) -> Result<(u32, Option<Color>), IoError> {
        if let Some(&v) = self.materials.get(&m.index()) {
            return Ok(v);
        }
        let name = m.name().map_or_else(|| m.index().map_or("the default material".into(), |i| format!("material {i}")), String::from);
        let pbr = m.pbr_metallic_roughness();
        let [r, g, b, _a] = pbr.base_color_factor();
        let factor = Color::new(r, g, b);
        let base = match pbr.base_color_texture() {
            Some(info) => {
                if info.tex_coord() != 0 {
                    self.warn(format!("{name}: base colour texture on uv set {}; octolux reads set 0", info.tex_coord()));
                }
                let image = self.image(&info.texture().source())?;
                if factor != Color::ONE {
                    self.warn(format!("{name}: base colour factor {factor} times a texture is rendered as the texture alone"));
                }
                Texture::bitmap(image, Vec2::ONE)
            }
            None => Texture::Const(factor),
        };
        for (what, present) in [
            ("metallic-roughness texture", pbr.metallic_roughness_texture().is_some()),
            ("normal texture", m.normal_texture().is_some()),
            ("occlusion texture", m.occlusion_texture().is_some()),
            ("emissive texture", m.emissive_texture().is_some()),
        ] {
            if present {
                self.warn(format!("{name}: the {what} is not read; its factors are used"));
            }
        }
        if m.alpha_mode() != gltf::material::AlphaMode::Opaque {
            self.warn(format!("{name}: alpha mode {:?} is rendered opaque", m.alpha_mode()));
        }
        let alpha = pbr.roughness_factor().clamp(0.0, 1.0).powi(2);
        let metallic = pbr.metallic_factor().clamp(0.0, 1.0);
        let ggx = Microfacet { kind: MicrofacetKind::Ggx, alpha_u: alpha, alpha_v: alpha };
        let dielectric = Material::RoughPlastic {
            diffuse_reflectance: base.clone(),
            specular_reflectance: Color::ONE,
            distribution: ggx,
            eta: IOR,
            nonlinear: false,
        };
        let tint = match &base {
            Texture::Const(c) => *c,
            _ if metallic > 0.0 => {
                self.warn(format!("{name}: a metal's textured base colour is rendered as its factor"));
                factor
            }
            _ => factor,
        };
        let metal =
            Material::RoughConductor { distribution: Roughness::from(ggx), eta: Color::ZERO, k: Color::ZERO, specular_reflectance: tint };
        let surface = if metallic <= 0.0 {
            dielectric
        } else if metallic >= 1.0 {
            metal
        } else {
            Material::Blend { weight: Texture::Const(Color::splat(metallic)), first: Box::new(dielectric), second: Box::new(metal) }
        };
        let material = Material::TwoSided { front: Box::new(surface.clone()), back: Box::new(surface) };
        let e = Color::from(m.emissive_factor()) * m.emissive_strength().unwrap_or(1.0);
        let emission = (e.max_element() > 0.0 && e.is_finite()).then_some(e);
        self.desc.materials.push(material);
        let v = ((self.desc.materials.len() - 1) as u32, emission);
        self.materials.insert(m.index(), v);
        Ok(v)
    }

    fn image(&mut self, img: &gltf::Image) -> Result<u32, IoError> {
        if let Some(&i) = self.images.get(&img.index()) {
            return Ok(i);
        }
        let mut decoded = match img.source() {
            gltf::image::Source::Uri { uri, .. } => {
                if uri.starts_with("data:") {
                    return Err(IoError::invalid(
                        self.path,
                        format!("image {}: data: URIs are not read; use a .glb or image files", img.index()),
                    ));
                }
                let file = local_file(self.path, uri).map_err(|m| IoError::invalid(self.path, format!("image {}: {m}", img.index())))?;
                crate::image_io::read_image(&file)?
            }
            gltf::image::Source::View { view, mime_type } => {
                let buf = self.buffers.get(view.buffer().index()).map(|b| &b[..]).unwrap_or(&[]);
                let range = view.offset().checked_add(view.length()).map(|end| view.offset()..end);
                let bytes = range.and_then(|r| buf.get(r)).ok_or_else(|| {
                    IoError::invalid(self.path, format!("image {}: its buffer view lies outside the buffer", img.index()))
                })?;
                let ext = if mime_type == "image/jpeg" { "jpg" } else { "png" };
                let named = self.path.with_file_name(format!(
                    "{}#image{}.{ext}",
                    self.path.file_name().unwrap_or_default().to_string_lossy(),
                    img.index()
                ));
                crate::image_io::decode_image(&named, bytes)?
            }
        };
        let named =
            self.path.with_file_name(format!("{}#image{}", self.path.file_name().unwrap_or_default().to_string_lossy(), img.index()));
        self.warnings.extend(crate::image_io::check_texels(&named, &mut decoded)?);
        crate::image_io::check_scene_texels(&self.desc.images, &decoded)
            .map_err(|b| IoError::invalid(self.path, format!("image {}: {b}", img.index())))?;
        self.desc.images.push(decoded);
        let i = (self.desc.images.len() - 1) as u32;
        self.images.insert(img.index(), i);
        Ok(i)
    }

    fn camera(&mut self, cam: &gltf::Camera, world: &Mat4) {
        match cam.projection() {
            gltf::camera::Projection::Perspective(p) => {
                // glTF looks down -z with +x right; octolux (Mitsuba) down +z with +x left
                let to_world = *world * Mat4::from_scale(Vec3::new(-1.0, 1.0, -1.0));
                let desc = CameraDesc { to_world, fov_deg: p.yfov().to_degrees(), fov_axis: FovAxis::Y, near_clip: p.znear().max(1e-4) };
                self.cameras.push((desc, p.aspect_ratio().filter(|a| a.is_finite() && *a > 0.0)));
            }
            gltf::camera::Projection::Orthographic(_) => {
                self.warn(format!("camera {}: orthographic cameras are not supported; skipped", cam.index()))
            }
        }
    }

    fn light(&mut self, light: &gltf::khr_lights_punctual::Light, world: &Mat4) {
        use gltf::khr_lights_punctual::Kind;
        let colour = Color::from(light.color()) * light.intensity() / LUMENS_PER_WATT;
        let position = world.transform_point3(Vec3::ZERO);
        let direction = world.transform_vector3(-Vec3::Z).normalize_or_zero();
        if light.range().is_some() {
            self.warn(format!("light {}: `range` is ignored (the falloff is physical)", light.index()));
        }
        let l = match light.kind() {
            Kind::Point => Light::Point { position, intensity: colour },
            Kind::Directional => Light::Directional { direction, irradiance: colour },
            Kind::Spot { inner_cone_angle, outer_cone_angle } => Light::Spot {
                position,
                frame: Frame::from_normal(direction),
                intensity: colour,
                cos_cutoff: outer_cone_angle.cos(),
                cos_falloff_start: inner_cone_angle.min(outer_cone_angle).cos(),
            },
        };
        match l.validate() {
            Ok(()) if direction != Vec3::ZERO => self.desc.lights.push(l),
            Ok(()) => self.warn(format!("light {}: its node's transform has no direction; skipped", light.index())),
            Err(e) => self.warn(format!("light {}: {e}; skipped", light.index())),
        }
    }
}

/// `%20` and the like in a relative URI.
fn percent_decode(uri: &str) -> String {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        if b[i] == b'%' && i + 2 < b.len() {
            if let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}
