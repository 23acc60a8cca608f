//! The committed C header `include/plsr.h` is what cbindgen (pinned in
//! the workspace's Cargo.toml) generates from this crate now: a stale header fails here.
//! Regenerate it with `make header`.

#[test]
fn committed_header_is_up_to_date() {
    let krate = env!("CARGO_MANIFEST_DIR");
    let root = super::root().display().to_string();
    let config = cbindgen::Config::from_file(format!("{krate}/cbindgen.toml")).unwrap();
    let mut generated = Vec::new();
    cbindgen::Builder::new()
        .with_crate(krate)
        .with_config(config)
        .generate()
        .expect("cbindgen")
        .write(&mut generated);
    let path = format!("{root}/include/plsr.h");
    if std::env::var_os("PLSR_WRITE_HEADER").is_some() {
        std::fs::write(&path, &generated).unwrap();
    }
    let committed = std::fs::read(&path).unwrap_or_default();
    assert!(
        committed == generated,
        "include/plsr.h is stale: run `make header` (PLSR_WRITE_HEADER=1 cargo test -p plsr-capi header)"
    );
}
