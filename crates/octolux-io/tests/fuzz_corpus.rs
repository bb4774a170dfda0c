//! Replays the fuzz corpus (`fuzz/corpus/<target>/*`, seeds plus the inputs the fuzzer kept,
//! crash reproducers included) through the same entry points as the cargo-fuzz targets
//! ([`octolux_io::fuzzing`]), on stable: every file must load or fail with an error, never
//! panic. Long fuzzing runs: `fuzz/run.sh`.

use octolux_io::fuzzing;
use std::path::Path;

#[test]
fn fuzz_corpus_replays_without_panics() {
    octolux::budget::set_memory_limit(fuzzing::FUZZ_MEMORY_LIMIT);
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/corpus");
    let mut failures = Vec::new();
    for target in fuzzing::TARGETS {
        let dir = root.join(target);
        let mut files: Vec<_> = std::fs::read_dir(&dir)
            .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
            .map(|e| e.expect("readable corpus entry").path())
            .filter(|p| p.is_file())
            .collect();
        files.sort();
        assert!(!files.is_empty(), "{}: empty corpus", dir.display());
        let (mut ok, mut err) = (0, 0);
        for f in &files {
            let data = std::fs::read(f).expect("readable corpus file");
            match std::panic::catch_unwind(|| fuzzing::run_target(target, &data)) {
                Ok(Some(Ok(()))) => ok += 1,
                Ok(Some(Err(_))) => err += 1,
                Ok(None) => unreachable!("TARGETS lists known targets"),
                Err(_) => failures.push(f.display().to_string()),
            }
        }
        println!("{target}: {} files, {ok} loaded, {err} clear errors", files.len());
    }
    assert!(failures.is_empty(), "panics on: {failures:#?}");
}

/// The cache target's seeds are cache files of the format this octolux reads (a seed of an
/// older version only reaches the version check: the seeds had stayed at version 3 while the
/// format moved on to 5), except the two that must fail: a newer version and a truncated file.
/// Rebake them with `octolux bake cornell-box --photons 2000` (`--set global.storage=full --set
/// caustic.storage=full` for the full one, `cornell-spheres --volume` for the caustic one, which
/// then holds the free-space tree too); the newer version is the
/// compressed seed with the version field raised by one (checksum fixed), the truncated one its
/// first half.
#[test]
fn the_cache_seeds_are_of_the_current_format() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/corpus/cache");
    for name in ["seed-cornell-box-compressed", "seed-cornell-box-full", "seed-cornell-spheres-caustic"] {
        let bytes = std::fs::read(dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        if let Err(e) = octolux_io::cache::load_bytes(&bytes, true) {
            panic!("{name} does not load: {e} (rebake it: see this test's docs)");
        }
    }
    for (name, says) in [("seed-future-version", "newer octolux"), ("seed-truncated", "truncated")] {
        let bytes = std::fs::read(dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        match octolux_io::cache::load_bytes(&bytes, true) {
            Ok(_) => panic!("{name} loads"),
            Err(e) => assert!(e.contains(says), "{name}: {e}"),
        }
    }
}
