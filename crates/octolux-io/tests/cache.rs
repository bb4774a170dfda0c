//! Lighting cache files (`octolux_io::cache`, docs/guide/baking.md): the bytes round-trip to an
//! integrator that renders bit-identically, and no byte string panics: every prefix, every
//! single-byte change (checksum fixed so that the parser sees it) and random mutations are
//! refused or accepted with checked octrees.

use octolux::accel::BackendKind;
use octolux::caches::Storage;
use octolux::integrators::octree::{LeakTest, OctreeIntegrator, OctreeIntegratorSettings};
use octolux::integrators::Integrator;
use octolux::render::{render, RenderSettings};
use octolux::sampling::Sampler;
use octolux::scene::Scene;
use octolux_io::cache::{self, CacheFile, CacheInfo};

fn baked(storage: Storage) -> (Scene, OctreeIntegrator, Vec<u8>) {
    let mut desc = octolux_io::builtin::scene("cornell-spheres").expect("built-in scene");
    desc.film.width = 16;
    desc.film.height = 16;
    let scene = Scene::prepare(desc, BackendKind::Bvh).expect("scene");
    let mut s = OctreeIntegratorSettings::default();
    s.photons.photons = 20_000;
    s.global.storage = storage;
    s.caustic.storage = storage;
    // the leak test whose planes a loaded cache derives again from the scene (`prepare`)
    s.leak = octolux::integrators::octree::LeakTest::VisibleSample;
    let mut o = OctreeIntegrator::build(&scene, s).expect("octrees");
    assert!(o.caustic.is_some(), "the glass sphere makes caustics");
    // the volumetric values (format version 3) are part of every byte test below
    assert!(o.fill_atmosphere(&scene).filled_leaves > 0);
    let info = CacheInfo { octolux_version: "test".into(), scene: "cornell-spheres".into(), backend: scene.backend_name() };
    let bytes = cache::encode(&CacheFile { fingerprint: scene.lighting_fingerprint(), info, parts: o.to_parts() });
    (scene, o, bytes)
}

/// A bake of `baked(Storage::Compressed)` on a pool of `threads` workers.
fn bake_on(threads: usize) -> (OctreeIntegrator, Vec<u8>) {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("pool");
    let (_, o, bytes) = pool.install(|| baked(Storage::Compressed));
    (o, bytes)
}

#[test]
fn two_identical_bakes_give_identical_bytes() {
    // the times differ between the runs (and the thread counts); the files must not
    let (a, first) = bake_on(1);
    let (b, second) = bake_on(2);
    assert!(a.stats.t_c_s > 0.0 && b.stats.t_c_s > 0.0, "the bakes took time");
    assert_eq!(first.len(), second.len(), "two identical bakes, two file sizes");
    let diff = first.iter().zip(&second).position(|(x, y)| x != y);
    assert!(diff.is_none(), "two identical bakes differ from byte {diff:?} on");
    // every time of the statistics is one the file leaves out: a new `*_s` field would make
    // the bytes depend on the run again
    let times = |v: &serde_json::Value| -> Vec<String> {
        let mut k: Vec<String> = v.as_object().map(|m| m.keys().filter(|k| k.ends_with("_s")).cloned().collect()).unwrap_or_default();
        k.sort();
        k
    };
    let sorted = |keys: &[&str]| -> Vec<String> {
        let mut k: Vec<String> = keys.iter().map(|k| k.to_string()).collect();
        k.sort();
        k
    };
    let stats = serde_json::to_value(&a.stats).expect("stats");
    assert_eq!(times(&stats), sorted(&cache::TIMING_KEYS));
    assert_eq!(times(&stats["global"]), sorted(&cache::TREE_TIMING_KEYS));
    // read back: the times are 0, the rest is the bake's
    let c = cache::decode(&first, true).expect("decodes");
    assert_eq!((c.parts.stats.t_c_s, c.parts.stats.t_photons_s, c.parts.global.stats.t_build_s), (0.0, 0.0, 0.0));
    assert_eq!(c.parts.stats.global.valid_leaves, a.stats.global.valid_leaves);
    assert_eq!(c.parts.stats.photons_emitted, a.stats.photons_emitted);
}

fn fix_crc(b: &mut [u8]) {
    let n = b.len() - 4;
    let crc = cache::crc32(&b[..n]);
    b[n..].copy_from_slice(&crc.to_le_bytes());
}

#[test]
fn a_cache_round_trips_to_a_bit_identical_render() {
    for storage in [Storage::Compressed, Storage::Full] {
        let (scene, o, bytes) = baked(storage);
        let c = cache::decode(&bytes, true).expect("decodes");
        assert_eq!(c.fingerprint, scene.lighting_fingerprint());
        let parts = o.to_parts();
        assert_eq!(
            (&c.parts.settings, &c.parts.global.nodes, &c.parts.global.values),
            (&parts.settings, &parts.global.nodes, &parts.global.values)
        );
        // the volumetric solution too: the free-space tree, its values (a compressed free-space
        // leaf is 28 bytes on disk, its block's 8 zero bytes restored on load) and anchors
        let v = parts.volume.as_ref().expect("the free-space tree");
        assert!(v.atmosphere.as_ref().is_some_and(|a| !a.anchors.is_empty()));
        assert_eq!(c.parts.volume.as_ref().map(|t| (&t.nodes, &t.atmosphere)), Some((&v.nodes, &v.atmosphere)));
        assert_eq!(
            c.parts.caustic.as_ref().map(|t| (&t.nodes, &t.values, &t.facing)),
            parts.caustic.as_ref().map(|t| (&t.nodes, &t.values, &t.facing))
        );
        let mut loaded = cache::load_bytes(&bytes, true).expect("loads");
        loaded.integrator.prepare(&scene);
        let Integrator::Octree(back) = &loaded.integrator else { panic!("an octree integrator") };
        assert_eq!(back.stats.global.valid_leaves, o.stats.global.valid_leaves);
        assert_eq!(back.stats.bytes, o.stats.bytes);
        // the free-space tree's structure as baked is the one read back
        let shape = |t: &OctreeIntegrator| {
            t.volume.as_ref().map(|v| {
                let s = v.stats();
                (s.nodes, s.leaves, s.max_depth, s.min_leaf_size, s.depth_histogram.clone())
            })
        };
        assert!(shape(&o).is_some());
        assert_eq!(shape(back), shape(&o));
        println!(
            "{storage:?}: file {} bytes, in memory {} bytes, {} + {} valid leaves",
            bytes.len(),
            o.stats.bytes,
            o.stats.global.valid_leaves,
            o.stats.caustic.as_ref().map_or(0, |c| c.valid_leaves)
        );
        let rs = RenderSettings { spp: 2, seed: 1, ..Default::default() };
        let (a, _) = render(&scene, &Integrator::Octree(Box::new(o)), &rs, &|_, _| {});
        let (b, _) = render(&scene, &loaded.integrator, &rs, &|_, _| {});
        assert!(a.data.iter().zip(&b.data).all(|(x, y)| x.to_array().map(f32::to_bits) == y.to_array().map(f32::to_bits)));
    }
}

#[test]
fn no_bytes_make_the_reader_panic() {
    let (_, _, good) = baked(Storage::Compressed);
    // every prefix: refused by the length checks
    for n in 0..good.len() {
        assert!(cache::load_bytes(&good[..n], true).is_err(), "prefix of {n} bytes accepted");
    }
    // one changed byte: the checksum refuses it; with the checksum fixed the parser or the
    // octree checks meet it, or it is a value that any bytes make (leaf values, JSON digits)
    let step = (good.len() / 3000).max(1);
    let (mut refused, mut accepted) = (0, 0);
    for i in (0..good.len() - 4).step_by(step) {
        let mut b = good.clone();
        b[i] ^= 0x5a;
        let e = cache::load_bytes(&b, true).err().expect("checksum");
        assert!(e.contains("checksum") || i < 24, "byte {i}: {e}");
        fix_crc(&mut b);
        match cache::load_bytes(&b, true) {
            Ok(_) => accepted += 1,
            Err(_) => refused += 1,
        }
    }
    println!("one byte changed, checksum fixed: {refused} refused, {accepted} accepted");
    // most accepted changes are in leaf values (any 36 bytes are a leaf), anchors and facing
    // bits, and in the JSON's digits; node kinds and count bytes are refused (format 7: 493 of
    // 3037 refused, the nodes down from 8 bytes to about 1)
    assert!(refused > 400, "{refused} refused, {accepted} accepted");
    // random multi-byte mutations, counts included
    let mut s = Sampler::new(11, 0, 0);
    for _ in 0..2000 {
        let mut b = good.clone();
        for _ in 0..1 + (s.next_1d() * 8.0) as usize {
            let i = ((s.next_1d() * (b.len() - 4) as f32) as usize).min(b.len() - 5);
            b[i] = (s.next_1d() * 256.0) as u8;
        }
        fix_crc(&mut b);
        let _ = cache::load_bytes(&b, true);
    }
}

#[test]
fn read_names_the_file_and_says_why() {
    let dir = std::env::temp_dir().join(format!("octolux-cache-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (_, _, good) = baked(Storage::Compressed);
    let path = dir.join("l.oxc");
    std::fs::write(&path, &good).unwrap();
    assert!(cache::read(&path).is_ok());
    let mut future = good.clone();
    future[8] = 10;
    fix_crc(&mut future);
    std::fs::write(&path, &future).unwrap();
    let e = cache::read(&path).err().unwrap().to_string();
    assert!(e.contains("l.oxc") && e.contains("version 10 was written by a newer octolux"), "{e}");
    // a valid leaf without photons, checksum fixed: the octree checks refuse it
    let c = cache::decode(&good, true).unwrap();
    let mut bad = c.clone();
    let leaf = bad.parts.global.nodes.iter().position(|n| n[1] > 0 && n[0] & octolux::caches::octree::LEAF_LINK != 0).unwrap();
    bad.parts.global.nodes[leaf][1] = 0;
    let e = cache::load_bytes(&cache::encode(&bad), true).err().unwrap();
    assert!(e.contains(&format!("global octree: invalid octree data: node {leaf}: a valid leaf holds no photon")), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_cache_without_the_leak_samples_renders_as_the_bake_and_refuses_the_test_that_needs_them() {
    let (scene, mut o, with) = baked(Storage::Compressed);
    let valid = o.stats.global.valid_leaves + o.stats.caustic.as_ref().map_or(0, |c| c.valid_leaves);
    let mut parts = o.to_parts();
    parts.global = parts.global.without_leak_samples();
    parts.caustic = parts.caustic.map(|c| c.without_leak_samples());
    let info = CacheInfo { octolux_version: "test".into(), scene: "cornell-spheres".into(), backend: scene.backend_name() };
    let file = |parts| cache::encode(&CacheFile { fingerprint: scene.lighting_fingerprint(), info: info.clone(), parts });
    // the bake ran the visible_sample test: without its samples the cache is refused, by name
    let e = cache::load_bytes(&file(parts.clone()), true).err().expect("refused");
    assert!(e.contains("sampled photons") && e.contains("leak = none"), "{e}");
    // with a test that needs none, 24 bytes fewer per valid leaf, and the same render
    parts.settings.leak = LeakTest::None;
    let mut kept = o.to_parts();
    kept.settings.leak = LeakTest::None;
    assert!(with.len() > file(kept.clone()).len(), "the bake's settings name visible_sample");
    let without = file(parts);
    assert_eq!(file(kept).len() - without.len(), 24 * valid, "{} valid leaves", valid);
    let loaded = cache::load_bytes(&without, true).expect("loads");
    let Integrator::Octree(back) = &loaded.integrator else { panic!("an octree integrator") };
    assert!(!back.global.has_leak_samples() && o.global.has_leak_samples());
    let mut s = o.settings.clone();
    s.leak = LeakTest::VisibleSample;
    assert!(back.missing_leak_samples(&s, false).is_some() && o.missing_leak_samples(&s, false).is_none());
    s.leak = LeakTest::None;
    assert!(back.missing_leak_samples(&s, true).is_none());
    s.leak = LeakTest::Auto;
    // the free-space tree's leak test reads its own anchors
    assert!(back.missing_leak_samples(&s, true).is_none(), "the free-space tree needs no sampled photons");
    let mut surface_only = cache::decode(&without, true).expect("decodes").parts;
    surface_only.volume = None;
    let Integrator::Octree(bare) = cache::load_bytes(&file(surface_only), true).expect("loads").integrator else { panic!() };
    assert!(bare.missing_leak_samples(&s, true).is_some(), "without it, the global octree's volume query tests leaks with them");
    o.settings.leak = LeakTest::None;
    o.prepare(&scene);
    let rs = RenderSettings { spp: 2, seed: 1, ..Default::default() };
    let (a, _) = render(&scene, &Integrator::Octree(Box::new(o)), &rs, &|_, _| {});
    let (b, _) = render(&scene, &loaded.integrator, &rs, &|_, _| {});
    assert!(a.data.iter().zip(&b.data).all(|(x, y)| x.to_array().map(f32::to_bits) == y.to_array().map(f32::to_bits)));
}

#[test]
fn a_default_bake_keeps_at_most_64_bytes_per_valid_leaf() {
    // issue 26, item 3: the 36-byte value, the facing bits and the mean anchor per valid leaf,
    // the nodes as kinds and photon counts; no volumetric values, no leak-test samples
    let desc = octolux_io::builtin::scene("cornell-box").expect("built-in scene");
    let scene = Scene::prepare(desc, BackendKind::Bvh).expect("scene");
    let mut s = OctreeIntegratorSettings::default();
    s.photons.photons = 200_000;
    let fe = octolux_io::job::Collect::default();
    let baked = octolux_io::job::bake::bake(&scene, "cornell-box", s, false, &fe).expect("bake");
    let r = &baked.report;
    let per_leaf = r.file_bytes as f64 / r.valid_leaves as f64;
    println!("{} bytes, {} valid leaves, {per_leaf:.1} B per valid leaf, layout {:?}", r.file_bytes, r.valid_leaves, r.file_layout);
    assert!(r.valid_leaves > 500 && per_leaf <= 64.0, "{per_leaf:.1} B per valid leaf");
    assert!(!r.leak_samples && r.atmosphere.is_none());
    let l = r.file_layout;
    assert_eq!(l.header + l.nodes + l.values + l.facing + l.anchors + l.atmosphere, r.file_bytes);
    assert_eq!(l.values, 36 * r.valid_leaves + 5, "the paper's 36 bytes per valid leaf, plus storage and count");
    assert!(l.nodes * 4 < 8 * r.nodes, "{} bytes for {} nodes", l.nodes, r.nodes);
}
