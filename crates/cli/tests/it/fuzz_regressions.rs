//! Replays every input that coverage-guided fuzzing found a fault with
//! (fuzz/regressions/TARGET/, one file per finding, named after it) through
//! the same check the fuzz target runs (crates/fuzz-checks): each must now
//! end in a value that holds its invariants or a clean error.

use std::path::Path;

#[test]
fn inputs_fuzzing_found_end_cleanly() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/regressions");
    let mut replayed = 0;
    for target in std::fs::read_dir(&root).unwrap() {
        let target = target.unwrap().path();
        let name = target.file_name().unwrap().to_string_lossy().into_owned();
        for input in std::fs::read_dir(&target).unwrap() {
            let input = input.unwrap().path();
            let data = std::fs::read(&input).unwrap();
            eprintln!("replaying {}", input.display());
            assert!(
                plsr_fuzz_checks::check(&name, &data),
                "fuzz/regressions/{name}: no such fuzz target"
            );
            replayed += 1;
        }
    }
    assert!(
        replayed > 0,
        "no regression inputs under {}",
        root.display()
    );
}
