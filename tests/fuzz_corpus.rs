//! Replays every committed fuzz corpus file (`fuzz/corpus/<target>/*`) through the same checks
//! the fuzz targets run (`tests/fuzz_checks/mod.rs`), so that `cargo test` keeps every input the
//! fuzzers ever needed, and every crash once fixed, passing.

mod fuzz_checks;

use std::path::PathBuf;

/// The files of `fuzz/corpus/<target>`, sorted; fails when there are none (a corpus that went
/// missing would otherwise pass silently).
fn corpus(target: &str) -> Vec<(PathBuf, Vec<u8>)> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("fuzz/corpus")
        .join(target);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|entry| entry.expect("list the corpus").path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    assert!(!files.is_empty(), "{}: empty corpus", dir.display());
    files
        .into_iter()
        .map(|p| {
            let bytes = std::fs::read(&p).expect("read a corpus file");
            (p, bytes)
        })
        .collect()
}

#[test]
fn obj_loader_corpus_passes() {
    for (path, bytes) in corpus("obj_loader") {
        eprintln!("{}", path.display());
        fuzz_checks::obj_loader(&bytes);
    }
}

#[test]
fn trace_packets_corpus_passes() {
    for (path, bytes) in corpus("trace_packets") {
        eprintln!("{}", path.display());
        fuzz_checks::trace_packets(&bytes);
    }
}

#[test]
fn culling_corpus_passes() {
    for (path, bytes) in corpus("culling") {
        eprintln!("{}", path.display());
        fuzz_checks::culling(&bytes);
    }
}
