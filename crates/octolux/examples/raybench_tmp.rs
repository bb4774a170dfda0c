// TEMPORARY tuning harness (to be deleted): interleaved min-of-N timing of the backends.
use octolux::accel::meshes::{self, MeshData};
use octolux::accel::{Accel, BackendKind};
use octolux::glam::Vec3;
use octolux::math::{offset_origin, Frame, Ray};
use octolux::sampling::{square_to_cosine_hemisphere, square_to_uniform_triangle, Sampler};
use std::hint::black_box;
use std::time::Instant;

fn primary_rays(eye: Vec3, target: Vec3, fov_deg: f32, res: usize) -> Vec<Ray> {
    let f = Frame::from_normal((target - eye).normalize());
    let h = (fov_deg.to_radians() * 0.5).tan();
    let mut rays = Vec::with_capacity(res * res);
    for y in 0..res {
        for x in 0..res {
            let sx = ((x as f32 + 0.5) / res as f32 * 2.0 - 1.0) * h;
            let sy = (1.0 - (y as f32 + 0.5) / res as f32 * 2.0) * h;
            rays.push(Ray::new(eye, f.to_world(Vec3::new(sx, sy, 1.0)).normalize()));
        }
    }
    rays
}
fn surface_point(m: &MeshData, s: &mut Sampler) -> (Vec3, Vec3) {
    let i = (s.next_u32() as usize) % m.triangles.len();
    let [a, b, c] = m.corners(i);
    let uv = square_to_uniform_triangle(s.next_2d());
    (a * (1.0 - uv.x - uv.y) + b * uv.x + c * uv.y, (b - a).cross(c - a).normalize_or(Vec3::Z))
}
fn diffuse_rays(m: &MeshData, n: usize) -> Vec<Ray> {
    let mut s = Sampler::new(17, 0, 0);
    (0..n).map(|_| { let (p, ng) = surface_point(m, &mut s); let d = Frame::from_normal(ng).to_world(square_to_cosine_hemisphere(s.next_2d())).normalize(); Ray::new(offset_origin(p, ng, d), d) }).collect()
}
fn shadow_rays(m: &MeshData, n: usize) -> Vec<Ray> {
    let mut s = Sampler::new(23, 0, 0);
    (0..n).map(|_| { let (p, np) = surface_point(m, &mut s); let (q, nq) = surface_point(m, &mut s); let d = (q - p).normalize_or(Vec3::Z); let o = offset_origin(p, np, d); let end = offset_origin(q, nq, -d); Ray::segment(o, d, (end - o).length()) }).collect()
}

fn v<T>(a: Vec3) -> T { assert_eq!(std::mem::size_of::<T>(), 16); unsafe { std::mem::transmute_copy::<[f32; 4], T>(&[a.x, a.y, a.z, 0.0]) } }
struct Obv { bvh: obvhs::cwbvh::CwBvh, tris: Vec<obvhs::triangle::Triangle> }
impl Obv {
    fn new(m: &MeshData) -> Self {
        
        let tris: Vec<obvhs::triangle::Triangle> = (0..m.triangles.len()).map(|i| { let [a,b,c] = m.corners(i); obvhs::triangle::Triangle { v0: v(a), v1: v(b), v2: v(c) } }).collect();
        let bvh = obvhs::cwbvh::builder::build_cwbvh_from_tris(&tris, obvhs::BvhBuildParams::medium_build(), &mut std::time::Duration::default());
        let tris = bvh.primitive_indices.iter().map(|&i| tris[i as usize]).collect();
        Obv { bvh, tris }
    }
    fn ray(r: &Ray) -> obvhs::ray::Ray {  obvhs::ray::Ray::new(v(r.o), v(r.d), r.tmin, r.tmax) }
    fn intersect(&self, r: &Ray) -> u32 { let mut h = obvhs::ray::RayHit::none(); if self.bvh.ray_traverse(Self::ray(r), &mut h, |ray, id| self.tris[id].intersect(ray)) { h.primitive_id & 1 } else { 0 } }
    fn occluded(&self, r: &Ray) -> bool { !self.bvh.ray_traverse_miss(Self::ray(r), |ray, id| self.tris[id].intersect(ray)) }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let which = args.get(1).map(|s| s.as_str()).unwrap_or("both");
    let reps: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(9);
    let level: u32 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(7);
    let with_obvhs = std::env::var("OBVHS").is_ok();
    let scenes: Vec<(&str, MeshData, Vec<Ray>)> = [
        ("big", which != "cbox"),
        ("cbox", which != "big"),
    ].into_iter().filter(|x| x.1).map(|(n, _)| if n == "big" {
        let m = meshes::spheres_in_room(level);
        let p = primary_rays(Vec3::new(0.0, 1.5, 3.9), Vec3::new(0.0, 0.2, 0.0), 60.0, 128);
        (n, m, p)
    } else {
        let m = meshes::cornell_box();
        let p = primary_rays(Vec3::new(0.0, 1.0, 3.9), Vec3::new(0.0, 1.0, 0.0), 40.0, 256);
        (n, m, p)
    }).collect();
    for (name, m, primary) in &scenes {
        let n = primary.len();
        let diffuse = diffuse_rays(m, n);
        let shadow = shadow_rays(m, n);
        let mut backs: Vec<(String, Box<dyn Fn(&Ray) -> u32>, Box<dyn Fn(&Ray) -> bool>)> = Vec::new();
        let only = std::env::var("ONLY").unwrap_or_default();
        for kind in [BackendKind::Embree, BackendKind::Bvh] {
            if only == "bvh" && kind == BackendKind::Embree { continue; }
            if only == "embree" && kind == BackendKind::Bvh { continue; }
            let t0 = Instant::now();
            let a = std::sync::Arc::new(Accel::build(&m.vertices, &m.triangles, kind).unwrap());
            eprintln!("{name}: {} build {:.3}s", a.name(), t0.elapsed().as_secs_f64());
            if let Accel::Bvh(b) = &*a { eprintln!("  nodes/blocks {:?} tris {}", b.counts(), m.triangles.len());
}
            let a2 = a.clone();
            backs.push((a.name(), Box::new(move |r| a.intersect(r).map_or(0, |h| h.prim & 1)), Box::new(move |r| a2.occluded(r))));
        }
        if only != "embree" {
            let t0 = Instant::now();
            let o = std::sync::Arc::new(octolux::accel::bvh::Bvh8::build(&m.vertices, &m.triangles));
            eprintln!("{name}: bvh8 build {:.3}s counts {:?} fill {:?}", t0.elapsed().as_secs_f64(), o.counts(), o.tmp_fill());
            let o2 = o.clone();
            backs.push(("bvh8".into(), Box::new(move |r| o.intersect(r).map_or(0, |h| h.prim & 1)), Box::new(move |r| o2.occluded(r))));
        }
        if with_obvhs {
            let t0 = Instant::now();
            let o = std::sync::Arc::new(Obv::new(m));
            eprintln!("{name}: obvhs build {:.3}s", t0.elapsed().as_secs_f64());
            let o2 = o.clone();
            backs.push(("obvhs".into(), Box::new(move |r| o.intersect(r)), Box::new(move |r| o2.occluded(r))));
        }
        // Per chunk of 1024 rays, the minimum time over `reps` runs; summed over chunks.
        const CH: usize = 1024;
        let nch = n / CH;
        let mut best = vec![[[f64::INFINITY; 3]; 4096]; backs.len()];
        for _ in 0..reps {
            for (bi, (_, isect, occ)) in backs.iter().enumerate() {
                for (k, rays) in [&primary[..], &diffuse[..], &shadow[..]].into_iter().enumerate() {
                    for c in 0..nch {
                        let rays = &rays[c * CH..(c + 1) * CH];
                        let t0 = Instant::now();
                        let mut acc = 0u32;
                        if k == 2 { for r in rays { acc += occ(black_box(r)) as u32; } } else { for r in rays { acc += isect(black_box(r)); } }
                        black_box(acc);
                        best[bi][c][k] = best[bi][c][k].min(t0.elapsed().as_secs_f64());
                    }
                }
            }
        }
        let best: Vec<[f64; 3]> = best.iter().map(|b| { let mut s = [0.0; 3]; for c in 0..nch { for k in 0..3 { s[k] += b[c][k]; } } s }).collect();
        let n = nch * CH;
        for (bi, (nm, _, _)) in backs.iter().enumerate() {
            let mr: Vec<String> = best[bi].iter().map(|t| format!("{:6.2}", n as f64 / t / 1e6)).collect();
            println!("{name:5} {nm:22} Mrays/s primary/diffuse/shadow: {}", mr.join(" "));
        }
    }
}
