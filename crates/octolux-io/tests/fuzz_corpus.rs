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
