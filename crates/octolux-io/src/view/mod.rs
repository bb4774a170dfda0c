//! `octolux view` (issue 28): the scene drawn in a browser and lit by the octree evaluated on
//! the GPU, the octree streamed coarse to fine. docs/guide/viewer.md says how to use it.
//!
//! The job loads the scene, reads the lighting cache (or traces the photons and builds the
//! octrees as a bake would), and serves on one address (127.0.0.1 by default, `http.rs`):
//!
//! | path | what |
//! |---|---|
//! | `/`, `/viewer.js` | the page (`page.html`, `viewer.js`: WebGL2) |
//! | `/meta.json` | the camera, the canvas size, each octree's root cube, node count and chunks (bytes, the smallest leaf's edge after each) |
//! | `/scene.bin` | per vertex position, normal, albedo, emitted radiance: 12 little-endian f32 ([`Scene::display_mesh`]) |
//! | `/octree/K.bin` | chunk `K` of the global octree's stream (`octolux::caches::octree` `stream.rs`): chunk 0 the root, then splits, each the parent's index in the stream (u32) and its 8 children; a node is its kind (u8: 0 internal, 1 valid, 2 atmospheric), its facing bits (u8), and unless atmospheric its 36 bytes. A chunk ends with the last split within the next of [`CHUNK_SHARES`] of the bytes |
//! | `/direct/K.bin` | the same for the direct-light octree (`OctreeIntegrator::direct_octree`, built by the job from the photon pass of the lighting's settings) |
//! | `/cpu.bin` | with `--compare-cpu`: the CPU query's irradiance at every pixel centre and the distance to the surface there, 4 f32 per pixel, top row first |
//! | `/done?...` | the page's report once it drew the whole octree (logged; `--exit-when-done` stops the server) |
//! | `/mark?begin`, `/mark?end&frames=N` | the page's marks around N frames: the server times them (a headless browser's clock may be virtual) |
//!
//! The page draws the direct light of the emitters from a direct-light octree baked beside the
//! global one (not shadow maps: its shadows are as sharp as its leaves), plus the global
//! octree's indirect irradiance, times the albedo over π, plus the area emitters' radiance on
//! their emitting side; or either irradiance, or the leaves.
//! Its indirect irradiance is what the CPU's `--view irradiance` computes, with the same camera
//! (test `the_gpu_query_matches_the_cpu_and_the_stream_converges`), except on bump- and
//! normal-mapped surfaces: the page draws no maps, and the CPU side of `--compare-cpu` reads the
//! mesh's interpolated normals as the page does.

pub mod http;

use crate::job::{self, bail, Context, Frontend, Result};
use http::Resource;
use octolux::accel::BackendKind;
use octolux::caches::octree::{Octree, StreamKind, StreamNode};
use octolux::integrators::octree::OctreeIntegrator;
use octolux::integrators::Integrator;
use octolux::math::Ray;
use octolux::scene::Scene;
use serde_json::json;
use std::collections::HashMap;
use std::net::{SocketAddr, TcpListener};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

/// The page and its script, served as they are.
const PAGE: &str = include_str!("page.html");
const SCRIPT: &str = include_str!("viewer.js");

/// Where the octree's stream is cut into files after the root (shares of its bytes): the page
/// redraws after each, and measures its error there.
pub const CHUNK_SHARES: [f64; 10] = [0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.35, 0.5, 0.75, 1.0];

/// Widest canvas (pixels); the scene's film is scaled down to it, keeping its aspect.
pub const MAX_CANVAS_WIDTH: u32 = 640;

/// `octolux view`.
#[derive(Clone, Debug)]
pub struct ViewJob {
    pub scene: job::SceneSpec,
    /// The `octree` settings when no cache is given (resolved as a bake resolves them).
    pub settings: job::IntegratorRequest,
    pub cache: Option<PathBuf>,
    pub allow_stale_cache: bool,
    pub backend: BackendKind,
    /// Where to listen (port 0: any free port).
    pub bind: SocketAddr,
    /// Also serve the CPU query's irradiance image for the page to compare with.
    pub compare_cpu: bool,
    /// Stop once the page reported (`/done`), after the whole octree.
    pub exit_when_done: bool,
    /// Canvas width (default: the film's, at most [`MAX_CANVAS_WIDTH`]).
    pub width: Option<u32>,
}

/// The served data of a scene and its octree (module docs).
pub fn resources(
    scene: &Scene,
    tree: &Octree,
    direct: &Octree,
    width: u32,
    compare_cpu: bool,
) -> (HashMap<String, Resource>, serde_json::Value) {
    let height = ((width as f64 * scene.film.height as f64 / scene.film.width as f64).round() as u32).max(1);
    let mut routes = HashMap::new();
    let mut put = |path: &str, content_type: &'static str, body: Vec<u8>| {
        routes.insert(path.to_string(), Resource { content_type, body: Arc::new(body) });
    };
    put("/", "text/html; charset=utf-8", PAGE.as_bytes().to_vec());
    put("/index.html", "text/html; charset=utf-8", PAGE.as_bytes().to_vec());
    put("/viewer.js", "text/javascript; charset=utf-8", SCRIPT.as_bytes().to_vec());
    let mesh = scene.display_mesh();
    let mut bin = Vec::with_capacity(mesh.positions.len() * 48);
    for (((p, n), a), e) in mesh.positions.iter().zip(&mesh.normals).zip(&mesh.albedo).zip(&mesh.emission) {
        for x in p.to_array().into_iter().chain(n.to_array()).chain(a.to_array()).chain(e.to_array()) {
            bin.extend_from_slice(&x.to_le_bytes());
        }
    }
    put("/scene.bin", "application/octet-stream", bin);
    let hits = centre_hits(scene, width, height);
    let seen: Vec<glam::Vec3> = hits.iter().filter_map(|(_, _, h)| h.map(|(p, _)| p)).collect();
    let mut tree_meta = |t: &Octree, prefix: &str| {
        let stream = t.stream_seen(&seen);
        let record = |b: &mut Vec<u8>, n: &StreamNode| {
            b.push(n.kind as u8);
            b.push(n.facing);
            if n.kind != StreamKind::Atmospheric {
                b.extend_from_slice(&n.value);
            }
        };
        let total: usize =
            stream.root.bytes() + stream.splits.iter().map(|s| 4 + s.children.iter().map(StreamNode::bytes).sum::<usize>()).sum::<usize>();
        // chunk 0: the root; then chunks ending at these shares of the bytes
        let mut chunk = Vec::new();
        record(&mut chunk, &stream.root);
        let (mut chunks, mut sent, mut depth, mut splits) = (Vec::new(), chunk.len(), 0u32, 0usize);
        let mut close = |chunk: &mut Vec<u8>, splits: usize, depth: u32, chunks: &mut Vec<serde_json::Value>| {
            let i = chunks.len();
            chunks.push(json!({ "bytes": chunk.len(), "splits": splits, "edge": t.cell_edge(depth) }));
            put(&format!("{prefix}/{i}.bin"), "application/octet-stream", std::mem::take(chunk));
        };
        close(&mut chunk, 0, 0, &mut chunks);
        let mut marks = CHUNK_SHARES.iter().map(|f| (f * total as f64) as usize).peekable();
        for s in &stream.splits {
            // a chunk ends with the last split within its share of the bytes
            let b = 4 + s.children.iter().map(StreamNode::bytes).sum::<usize>();
            if splits > 0 && marks.peek().is_some_and(|&m| sent + b > m) {
                while marks.peek().is_some_and(|&m| sent + b > m) {
                    marks.next();
                }
                close(&mut chunk, splits, depth, &mut chunks);
                splits = 0;
            }
            chunk.extend_from_slice(&s.parent.to_le_bytes());
            s.children.iter().for_each(|c| record(&mut chunk, c));
            sent += b;
            depth = depth.max(s.depth);
            splits += 1;
        }
        if !chunk.is_empty() {
            close(&mut chunk, splits, depth, &mut chunks);
        }
        json!({ "origin": t.origin(), "size": t.cell_edge(0), "alpha": t.alpha(), "nodes": 1 + 8 * stream.splits.len(), "chunks": chunks })
    };
    let (indirect, direct) = (tree_meta(tree, "/octree"), tree_meta(direct, "/direct"));
    if compare_cpu {
        put("/cpu.bin", "application/octet-stream", cpu_irradiance(tree, &hits));
    }
    let cam = scene.camera.frame();
    let meta = json!({
        "camera": cam,
        "width": width,
        "height": height,
        "vertices": mesh.positions.len(),
        "grey_materials": mesh.grey_materials.len(),
        "bounds": { "min": scene.bounds.min, "max": scene.bounds.max },
        "tree": indirect,
        "direct": direct,
        "compare_cpu": compare_cpu,
    });
    put("/meta.json", "application/json", serde_json::to_vec(&meta).unwrap_or_default());
    (routes, meta)
}

/// A pixel centre's ray (origin, direction) and the surface point it meets with its shading
/// normal ([`centre_hits`]).
type CentreHit = (glam::Vec3, glam::Vec3, Option<(glam::Vec3, glam::Vec3)>);

/// The ray of the scene's camera through the centre of each pixel of a `width` x `height`
/// image, top row first (origin, direction), and the surface point it meets with its shading
/// normal: the points a first view sees (the stream's order) and where the CPU query is read
/// ([`cpu_irradiance`]). The normal is the one the page shades with, the mesh's interpolated
/// normal (`SurfaceHit::base_n`), not the one a bump or normal map makes of it: the page draws
/// no such maps.
fn centre_hits(scene: &Scene, width: u32, height: u32) -> Vec<CentreHit> {
    let (sx, sy) = (scene.film.width as f32 / width as f32, scene.film.height as f32 / height as f32);
    (0..height)
        .flat_map(|y| (0..width).map(move |x| (x, y)))
        .map(|(x, y)| {
            let (o, d, tmin) = scene.camera.generate_ray(glam::Vec2::new((x as f32 + 0.5) * sx, (y as f32 + 0.5) * sy));
            (o, d, scene.intersect(&Ray { tmin, ..Ray::new(o, d) }).map(|h| (h.p, h.base_n)))
        })
        .collect()
}

/// The CPU query's irradiance (W/m², RGB) at each pixel centre's hit ([`centre_hits`]), and the
/// distance to the surface there: its shading normal turned to the camera,
/// [`Octree::irradiance`] (0 where no valid leaf answers or nothing is hit; distance 0 where
/// nothing is hit). The page compares its own where it drew the same surface point (its
/// tessellated spheres' silhouettes differ).
fn cpu_irradiance(tree: &Octree, hits: &[CentreHit]) -> Vec<u8> {
    let mut out = Vec::with_capacity(hits.len() * 16);
    for (o, d, hit) in hits {
        let (e, t) = match hit {
            Some((p, n)) => {
                let n = if n.dot(*d) > 0.0 { -*n } else { *n };
                (tree.irradiance(*p, n).unwrap_or(glam::Vec3::ZERO), (*p - *o).length())
            }
            None => (glam::Vec3::ZERO, 0.0),
        };
        for c in e.extend(t).to_array() {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    out
}

/// Run `octolux view` (module docs): returns the page's report, if it sent one.
pub fn run_view(job: &ViewJob, fe: &dyn Frontend, on_listen: &dyn Fn(SocketAddr)) -> Result<Option<String>> {
    let cache = job.cache.as_deref().map(|p| job::read_cache(p, job.allow_stale_cache)).transpose()?;
    let loaded = job::load(&job.scene, fe)?;
    let mut warnings = loaded.warnings.clone();
    let settings = match &cache {
        None => Some(job::bake::bake_settings(&job.settings, &loaded.desc.hints, fe, &mut warnings)?),
        Some(_) => None,
    };
    let scene = job::prepare(loaded.desc, job.backend, &job.scene.scene, fe, &mut warnings)?;
    let integrator = match (cache, settings) {
        (Some(c), _) => {
            let stale =
                crate::cache::check_fingerprint(&c.path, &c.cache, &scene.lighting_fingerprint(), &job.scene.scene, job.allow_stale_cache)
                    .map_err(job::JobError)?;
            if let Some(w) = stale {
                fe.warning(&w);
            }
            match c.cache.integrator {
                Integrator::Octree(o) => *o,
                _ => bail!("lighting cache {}: not the octree integrator's", c.path.display()),
            }
        }
        (None, Some(s)) => {
            fe.info(&format!("octree: tracing {} photons and building the octrees ...", s.photons.photons));
            OctreeIntegrator::build(&scene, s).context("cannot build the octrees")?
        }
        (None, None) => bail!("no lighting cache and no octree settings"),
    };
    let width = job.width.unwrap_or(scene.film.width.min(MAX_CANVAS_WIDTH)).clamp(1, 4096);
    fe.info("view: the direct-light octree (the photon pass's first hits) ...");
    let direct = integrator.direct_octree(&scene).context("cannot build the direct-light octree")?;
    let (routes, meta) = resources(&scene, &integrator.global, &direct, width, job.compare_cpu);
    let bytes: u64 = meta["tree"]["chunks"].as_array().map_or(0, |l| l.iter().filter_map(|x| x["bytes"].as_u64()).sum());
    let listener = TcpListener::bind(job.bind).with_context(|| format!("cannot listen on {}", job.bind))?;
    let addr = listener.local_addr().context("the address listened on")?;
    fe.info(&format!(
        "view: http://{addr}/ ({} triangles, {} octree nodes in {bytes} bytes); Ctrl-C stops",
        meta["vertices"].as_u64().unwrap_or(0) / 3,
        meta["tree"]["nodes"],
    ));
    on_listen(addr);
    let stop = Arc::new(AtomicBool::new(false));
    let state: Arc<Mutex<PageState>> = Arc::default();
    let (stop2, state2, exit) = (stop.clone(), state.clone(), job.exit_when_done);
    let on_request = Arc::new(move |target: &str| {
        let Ok(mut st) = state2.lock() else { return };
        if target == "/mark?begin" {
            st.begin = Some(std::time::Instant::now());
        } else if let Some(n) = target.strip_prefix("/mark?end&frames=") {
            let frames = n.parse::<u32>().unwrap_or(1).max(1);
            st.frame_ms = st.begin.map(|b| b.elapsed().as_secs_f64() * 1e3 / frames as f64);
        } else if let Some(q) = target.strip_prefix("/done?") {
            st.report = Some(q.to_string());
            if exit {
                stop2.store(true, Ordering::SeqCst);
            }
        }
    });
    let mut routes = routes;
    for path in ["/done", "/mark"] {
        routes.insert(path.into(), Resource { content_type: "text/plain", body: Arc::new(b"ok".to_vec()) });
    }
    http::serve(listener, routes, stop, on_request).context("the viewer's server")?;
    let st = state.lock().map(|s| s.clone()).unwrap_or_default();
    if let Some(ms) = st.frame_ms {
        fe.info(&format!("view: {ms:.2} ms per frame (full shading, {width}x{}, wall time between the page's marks)", meta["height"]));
    }
    let r = st.report.map(|r| match st.frame_ms {
        Some(ms) => format!("{r}&frame_ms_wall={ms:.3}"),
        None => r,
    });
    if let Some(r) = &r {
        fe.info(&format!("view: the page reported {r}"));
    }
    Ok(r)
}

/// What the page sent: its frame-time marks and its report.
#[derive(Clone, Debug, Default)]
struct PageState {
    begin: Option<std::time::Instant>,
    frame_ms: Option<f64>,
    report: Option<String>,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On the test scene whose objects carry bump and normal maps, the CPU query reads each
    /// pixel centre's hit with the interpolated normal the page shades with, not the one the
    /// maps bend (which differs at many pixels).
    #[test]
    fn the_cpu_reference_reads_the_normals_the_page_shades_with() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/scenes/wrappers/scene.xml");
        let loaded = crate::mitsuba::load(&path, &[]).expect("the wrappers test scene loads");
        let scene = Scene::prepare(loaded.desc, BackendKind::Bvh).expect("it prepares");
        let (w, h) = (48, 36);
        let hits = centre_hits(&scene, w, h);
        let sx = scene.film.width as f32 / w as f32;
        let sy = scene.film.height as f32 / h as f32;
        let (mut bent, mut seen) = (0, 0);
        for (k, (o, d, hit)) in hits.iter().enumerate() {
            let Some((p, n)) = hit else { continue };
            let (x, y) = ((k as u32 % w) as f32, (k as u32 / w) as f32);
            let (o2, d2, tmin) = scene.camera.generate_ray(glam::Vec2::new((x + 0.5) * sx, (y + 0.5) * sy));
            assert_eq!((*o, *d), (o2, d2));
            let full = scene.intersect(&Ray { tmin, ..Ray::new(o2, d2) }).expect("the same ray hits");
            assert_eq!(*p, full.p);
            assert!((n.length() - 1.0).abs() < 1e-4, "a unit normal: {n}");
            assert!(n.dot(full.ng).abs() > 0.0, "a normal of the surface hit");
            seen += 1;
            if n.dot(full.frame.n) < 0.999 {
                bent += 1;
            }
        }
        assert!(seen > (w * h / 2) as usize, "the camera sees the scene: {seen} hits");
        assert!(bent > 20, "the maps bend the normals of some pixels ({bent}), which the CPU query does not read");
    }
}
