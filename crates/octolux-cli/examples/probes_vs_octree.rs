//! Bytes against error: the paper's octree against adaptive SH irradiance probe grids (Unreal's
//! volumetric lightmap, Unity's Adaptive Probe Volumes; `octolux::caches::probes`) at equal
//! memory, from the same photons (issue 13, item 6; `docs/guide/baking.md`, "Bytes against error").
//!
//! ```sh
//! cargo run --release -p octolux-cli --example probes_vs_octree -- --scene cbox [--photons 1000000]
//!     [--n-max 2000,500,125] [--free 300] [--objects 10 --per-object 30] [--rays 16384] [--levels 2] [--out FILE.json] [--no-probes] [--full]
//! ```
//!
//! One photon pass (seed 0, unlimited depth with Russian roulette), its global and caustic
//! photons together (all light reflected at least once, what the truth counts), the probes'
//! input; per `n_max` a `bake --volume` of the same photon count (the `octree` integrator's
//! default settings otherwise), read back from its bytes as `render --cache` reads it, its
//! free-space tree queried, its bytes the whole cache file's; and probe grids at SH order 1 and
//! 2 whose layout (brick levels `base..base+2`, lattice scale) is searched so that their bytes
//! match the octree's. Errors
//! of the indirect irradiance (channel mean) at (a) random free points with random normals and
//! (b) points of spheres placed in free space (radius 0.08 of the free points' extent; the field
//! of the scene *without* them: the object is not in the bake and the truth is the
//! free-space field there), against `integrators::path::indirect_irradiance` (`--rays`
//! cosine-distributed paths each).

use anyhow::{Context, Result};
use glam::Vec3;
use octolux::accel::BackendKind;
use octolux::caches::octree::QueryLeaf;
use octolux::caches::probes::{BrickLayout, ProbeGrid, ProbeInputs, ProbeSettings, ShOrder};
use octolux::integrators::octree::{OctreeIntegratorSettings, ANCHOR_LIFT};
use octolux::integrators::path::{indirect_irradiance, PathSettings};
use octolux::integrators::Integrator;
use octolux::math::Ray;
use octolux::photon::trace::{map_flights, trace_photons, PhotonSettings};
use octolux::photon::Photon;
use octolux::sampling::{square_to_uniform_sphere, Sampler};
use octolux::scene::Scene;
use octolux_io::job::bake::bake;
use octolux_io::job::Collect;
use rayon::prelude::*;
use std::time::Instant;

/// Bytes against error: SH probes against the octree (see the file's docs).
#[derive(clap::Parser)]
struct Args {
    /// A scene alias of bench/scenes.json, a built-in scene or a path.
    #[arg(long, default_value = "cbox")]
    scene: String,
    #[arg(long, default_value_t = 1_000_000)]
    photons: u64,
    /// The octree's n_max values, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "2000,500,125")]
    n_max: Vec<u32>,
    #[arg(long, default_value_t = 300)]
    free: usize,
    #[arg(long, default_value_t = 10)]
    objects: usize,
    #[arg(long, default_value_t = 30)]
    per_object: usize,
    #[arg(long, default_value_t = 16384)]
    rays: u32,
    #[arg(long, default_value_t = 2)]
    levels: u32,
    #[arg(long)]
    out: Option<String>,
    /// Leave the probe grids out (their builds take most of the run).
    #[arg(long)]
    no_probes: bool,
    /// Keep the octree's leaves as full floats (what the compression costs).
    #[arg(long)]
    full: bool,
}

fn load(name: &str) -> Result<Option<Scene>> {
    // a name of the benches' alias table (bench/scenes.json), a built-in scene or a file
    let Some(spec) = octolux_io::shared::scene_spec(name)? else { return Ok(None) };
    let loaded = octolux_io::load_scene(&spec, &[])?;
    Ok(Some(Scene::prepare(loaded.desc, BackendKind::Auto)?))
}

/// `n` directions of a Fibonacci sphere.
fn fibonacci(n: usize) -> Vec<Vec3> {
    (0..n)
        .map(|i| {
            let z = 1.0 - (2.0 * i as f32 + 1.0) / n as f32;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = i as f32 * 2.399_963;
            Vec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect()
}

/// From `p`: fraction of `dirs` meeting a backface, fraction meeting anything, nearest hit.
fn look_around(scene: &Scene, p: Vec3, dirs: &[Vec3]) -> (f32, f32, f32) {
    let (mut back, mut hits, mut nearest) = (0, 0, f32::INFINITY);
    for &d in dirs {
        if let Some(h) = scene.intersect(&Ray::new(p, d)) {
            hits += 1;
            nearest = nearest.min(h.t);
            if d.dot(h.ng) > 0.0 {
                back += 1;
            }
        }
    }
    (back as f32 / dirs.len() as f32, hits as f32 / dirs.len() as f32, nearest)
}

/// Random points of the scene's free space (at most 1/16 of the directions meet a backface:
/// not inside an object or behind a wall, while a one-sided fitting may show its back; at
/// least half the directions closed; nearest surface farther than `clearance`).
fn free_points(scene: &Scene, n: usize, clearance: f32, stream: u64) -> Vec<Vec3> {
    let dirs = fibonacci(64);
    let (lo, ext) = (scene.bounds.min, scene.bounds.extent());
    let mut out = Vec::new();
    for i in 0..(n as u64 * 2000) {
        if out.len() == n {
            break;
        }
        let mut s = Sampler::new(stream, i, 0);
        let p = lo + Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * ext;
        let (back, hits, nearest) = look_around(scene, p, &dirs);
        if back <= 1.0 / 16.0 && hits >= 0.5 && nearest > clearance {
            out.push(p);
        }
    }
    out
}

/// Errors of `est` against `truth` (channel means): relative RMSE, relMSE (per point, with
/// `1e-2 · mean(truth)²` in the denominator), shares over 2x and under 0.5x the truth.
fn errors(est: &[f64], truth: &[f64]) -> [f64; 4] {
    let n = truth.len().max(1) as f64;
    let mean_t = truth.iter().sum::<f64>() / n;
    let (mut se, mut st, mut rel, mut over, mut under) = (0.0, 0.0, 0.0, 0, 0);
    for (&e, &t) in est.iter().zip(truth) {
        se += (e - t) * (e - t);
        st += t * t;
        rel += (e - t) * (e - t) / (t * t + 1e-2 * mean_t * mean_t);
        over += (e > 2.0 * t) as usize;
        under += (e < 0.5 * t) as usize;
    }
    [(se / st.max(1e-30)).sqrt(), rel / n, over as f64 / n, under as f64 / n]
}

fn mean3(c: Vec3) -> f64 {
    c.element_sum() as f64 / 3.0
}

fn main() -> Result<()> {
    let a: Args = clap::Parser::parse();
    let Some(scene) = load(&a.scene)? else { return Ok(()) };
    let extent = scene.bounds.extent().max_element();
    let t0 = Instant::now();
    let settings = PhotonSettings { photons: a.photons, ..PhotonSettings::default() };
    let maps = trace_photons(&scene, &settings)?;
    // global and caustic photons together: all the light reflected at least once, as the
    // truth counts it (a caustic through the glass sphere of cbox is part of it)
    let n_caustic = maps.caustic.len();
    let mut photons = maps.global;
    photons.extend_from_slice(&maps.caustic);
    eprintln!("{}: {} photons, {n_caustic} of them caustic ({:.1} s)", a.scene, photons.len(), t0.elapsed().as_secs_f64());
    // the flights of the reflected light, both methods' input: every flight of the same paths
    // after a bounce (those that leave the scene or end on glass too), as photons at their
    // ends (`wi` back along the flight) with their lengths (a flight leaving the scene: 2x the
    // scene's extent, past the root cube)
    let chunks = map_flights(&scene, &settings, |chunk| {
        chunk
            .iter()
            .filter(|f| f.bounces > 0)
            .map(|f| {
                let t = if f.t.is_finite() { f.t } else { 2.0 * extent };
                (Photon { p: f.o + f.d * t, wi: -f.d, power: f.power, ng: -f.d }, t)
            })
            .collect::<Vec<_>>()
    })?;
    let (flight_photons, lengths): (Vec<Photon>, Vec<f32>) = chunks.into_iter().flatten().unzip();
    eprintln!("{} flights of reflected light", flight_photons.len());

    // the points: free, and on spheres in free space
    let free = free_points(&scene, a.free, 0.01 * extent, 101);
    // the spheres' radius from the room the free points found (a scene's bounds may hold far
    // more than the room)
    let room = free.iter().fold(octolux::math::Bounds3::default(), |mut b, &p| {
        b.extend(p);
        b
    });
    let radius = 0.08 * if room.is_empty() { extent } else { room.extent().max_element() };
    let centres = free_points(&scene, a.objects, 1.3 * radius, 202);
    let mut pts: Vec<(Vec3, Vec3, bool)> =
        free.iter().enumerate().map(|(i, &p)| (p, square_to_uniform_sphere(Sampler::new(303, i as u64, 0).next_2d()), false)).collect();
    for (k, &c) in centres.iter().enumerate() {
        for j in 0..a.per_object {
            let n = square_to_uniform_sphere(Sampler::new(404, (k * a.per_object + j) as u64, 0).next_2d());
            pts.push((c + n * radius, n, true));
        }
    }
    let t1 = Instant::now();
    let path = PathSettings::default();
    let truth: Vec<(f64, f64)> = pts
        .par_iter()
        .enumerate()
        .map(|(i, &(p, n, _))| {
            let (e, se) = indirect_irradiance(&path, &scene, p, n, a.rays, 77, i as u64);
            (mean3(e), se)
        })
        .collect();
    let split = |v: &[f64], obj: bool| -> Vec<f64> { v.iter().zip(&pts).filter(|(_, q)| q.2 == obj).map(|(x, _)| *x).collect() };
    let t_vals: Vec<f64> = truth.iter().map(|t| t.0).collect();
    let floor = |obj: bool| {
        let (s2, t2) = truth.iter().zip(&pts).filter(|(_, q)| q.2 == obj).fold((0.0, 0.0), |(a, b), (t, _)| (a + t.1 * t.1, b + t.0 * t.0));
        (s2 / f64::max(t2, 1e-30)).sqrt()
    };
    eprintln!(
        "{} free points, {} sphere points; truth {} paths each ({:.1} s): its own relative RMSE {:.4} (free), {:.4} (spheres)",
        free.len(),
        pts.len() - free.len(),
        a.rays,
        t1.elapsed().as_secs_f64(),
        floor(false),
        floor(true)
    );

    let all_tris = scene.mesh_triangles_where(|_| true);
    let all_spheres: Vec<(Vec3, f32)> = scene.analytic_spheres_where(|_| true).into_iter().map(|(c, r, _)| (c, r)).collect();
    let dirs32 = fibonacci(32);
    let backface = |p: Vec3| look_around(&scene, p, &dirs32).0;
    let mut rows = Vec::new();
    let mut report = |method: String, bytes: usize, est: Vec<f64>, t_s: f64| {
        let f = errors(&split(&est, false), &split(&t_vals, false));
        let o = errors(&split(&est, true), &split(&t_vals, true));
        let line = format!(
            "| {} | {method} | {bytes} | {:.3} | {:.4} | {:.1}% / {:.1}% | {:.3} | {:.4} | {:.1}% / {:.1}% | {t_s:.1} |",
            a.scene,
            f[0],
            f[1],
            100.0 * f[2],
            100.0 * f[3],
            o[0],
            o[1],
            100.0 * o[2],
            100.0 * o[3]
        );
        println!("{line}");
        rows.push(serde_json::json!({"scene": a.scene, "method": method, "bytes": bytes, "free": f, "object": o, "build_s": t_s}));
    };
    println!("| scene | method | bytes | free rRMSE | free relMSE | free >2x / <0.5x | object rRMSE | object relMSE | object >2x / <0.5x | build s |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for &n_max in &a.n_max {
        // what `bake --volume` writes, read back as `render --cache` reads it
        let t = Instant::now();
        let mut settings = OctreeIntegratorSettings::default();
        settings.photons.photons = a.photons;
        settings.global.n_max = n_max;
        settings.global.n_min = settings.global.n_min.min(n_max);
        if a.full {
            settings.global.storage = octolux::caches::octree::Storage::Full;
        }
        let baked = bake(&scene, &a.scene, settings, true, &Collect::default())?;
        let t_bake = t.elapsed().as_secs_f64();
        let loaded = octolux_io::cache::load_bytes(&baked.bytes, true).map_err(anyhow::Error::msg)?;
        let Integrator::Octree(o) = loaded.integrator else { anyhow::bail!("the cache did not hold the octree integrator") };
        let volume = o.volume.as_ref().context("the bake made no free-space tree")?;
        let bytes = baked.bytes.len();
        let (vs, at) = (volume.stats(), baked.report.atmosphere.clone().unwrap_or_default());
        let label = format!(
            "octree n_max {n_max} ({} valid leaves, h_max {}), free-space tree ({} leaves, {} from flights, {} splits; {} B of the file)",
            o.global.stats().valid_leaves,
            o.global.stats().h_max,
            vs.leaves,
            at.flight_leaves,
            at.refine.split_leaves,
            baked.report.file_layout.atmosphere
        );
        let leak: Vec<f64> = pts
            .par_iter()
            .map(|&(p, n, _)| {
                let mut keep = |q: QueryLeaf| q.samples.iter().any(|&(s, nrm)| scene.sees(p, s + nrm * (ANCHOR_LIFT * q.cell_size), 1e-6));
                volume.irradiance_volume(p, n, Some(&mut keep)).map_or(0.0, mean3)
            })
            .collect();
        if std::env::var_os("PROBES_DEBUG").is_some() {
            let mut worst: Vec<usize> = (0..pts.len()).collect();
            worst.sort_by(|&i, &j| (leak[j] / t_vals[j]).abs().ln().abs().total_cmp(&(leak[i] / t_vals[i]).abs().ln().abs()));
            // the error where the point's own surface leaf is valid (surface photons) or atmospheric
            for valid in [true, false] {
                let idx: Vec<usize> = (0..pts.len()).filter(|&i| o.global.leaf_at(pts[i].0).is_some_and(|l| l.valid) == valid).collect();
                let e: Vec<f64> = idx.iter().map(|&i| leak[i]).collect();
                let t: Vec<f64> = idx.iter().map(|&i| t_vals[i]).collect();
                let ratio = e.iter().sum::<f64>() / t.iter().sum::<f64>().max(1e-30);
                eprintln!(
                    "  in {} surface leaves: {} points, relMSE {:.4}, mean ratio {ratio:.3}",
                    if valid { "valid" } else { "atmospheric" },
                    idx.len(),
                    errors(&e, &t)[1]
                );
            }
            for &i in worst.iter().take(12) {
                eprintln!(
                    "  worst: p {:.3} n {:.2} object {} truth {:.4} ± {:.4} octree {:.4} (free-space leaf depth {:?})",
                    pts[i].0,
                    pts[i].1,
                    pts[i].2,
                    t_vals[i],
                    truth[i].1,
                    leak[i],
                    volume.leaf_at(pts[i].0).map(|l| l.depth)
                );
            }
        }
        report(format!("{label}, leak test"), bytes, leak, t_bake);
        let plain: Vec<f64> = pts.par_iter().map(|&(p, n, _)| volume.irradiance_volume(p, n, None).map_or(0.0, mean3)).collect();
        report(format!("{label}, no rays"), bytes, plain, t_bake);
        for order in [ShOrder::L1, ShOrder::L2].into_iter().filter(|_| !a.no_probes) {
            let t = Instant::now();
            let (layout, s) = match_bytes(&scene, &all_tris, &all_spheres, order, a.levels, bytes)?;
            let grid = ProbeGrid::build(layout, ProbeInputs { photons: &flight_photons, flight_lengths: &lengths }, &s, &backface)?;
            let st = grid.stats().clone();
            let label = format!(
                "probes {order:?} (levels {}..{}, scale {:.3}, {} bricks, spacing {:.4}, {:.1}% invalid, {:.0} flights/probe)",
                s.base_level,
                s.max_level,
                s.root_scale,
                st.bricks,
                st.min_spacing / extent,
                100.0 * st.invalid_probes as f64 / st.probes as f64,
                st.mean_flights
            );
            let est: Vec<f64> = pts.par_iter().map(|&(p, n, _)| mean3(grid.irradiance(p, n))).collect();
            report(label, grid.bytes(), est, t.elapsed().as_secs_f64());
        }
    }
    if let Some(out) = &a.out {
        std::fs::write(out, serde_json::to_string_pretty(&rows)?).with_context(|| format!("cannot write {out}"))?;
    }
    eprintln!("total {:.1} s", t0.elapsed().as_secs_f64());
    Ok(())
}

/// The layout whose bytes at `order` come closest to `target`: for 1 to `levels` + 1 levels
/// of refinement and each coarsest level, the lattice scale bisected in `[1, 2]`.
fn match_bytes(
    scene: &Scene,
    tris: &[[Vec3; 3]],
    spheres: &[(Vec3, f32)],
    order: ShOrder,
    levels: u32,
    target: usize,
) -> Result<(BrickLayout, ProbeSettings)> {
    let mut best: Option<(f64, BrickLayout, ProbeSettings)> = None;
    for refine in 1..=levels + 1 {
        for base in 0..=6u32 {
            let mut s = ProbeSettings { order, base_level: base, max_level: base + refine, ..ProbeSettings::default() };
            let (mut lo, mut hi) = (1.0f32, 2.0f32);
            for _ in 0..10 {
                s.root_scale = 0.5 * (lo + hi);
                let l = BrickLayout::new(scene.bounds, tris, spheres, &s)?;
                let b = l.bytes(order);
                let score = (b as f64 / target as f64).ln().abs();
                if best.as_ref().is_none_or(|x| score < x.0) {
                    best = Some((score, l, s));
                }
                if b > target {
                    lo = s.root_scale;
                } else {
                    hi = s.root_scale;
                }
            }
            // finer bases only grow
            let l1 = BrickLayout::new(scene.bounds, tris, spheres, &ProbeSettings { root_scale: 2.0, ..s })?;
            if l1.bytes(order) > 2 * target {
                break;
            }
        }
    }
    let (_, l, s) = best.context("no layout")?;
    Ok((l, s))
}
