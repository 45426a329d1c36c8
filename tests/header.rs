//! The committed C header must equal what cbindgen generates from `src/ffi/`.
//! Set `RADDIFF_UPDATE_HEADER=1` to rewrite it.

use std::path::PathBuf;

#[test]
fn committed_header_matches_generated() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(root.join("cbindgen.toml")).expect("cbindgen.toml");
    let mut generated = Vec::new();
    cbindgen::Builder::new()
        .with_crate(&root)
        .with_config(config)
        .generate()
        .expect("cbindgen failed to generate the header")
        .write(&mut generated);
    let generated = String::from_utf8(generated).unwrap();
    let path = root.join("include/raddiff.h");
    if std::env::var_os("RADDIFF_UPDATE_HEADER").is_some() {
        std::fs::write(&path, &generated).unwrap();
        return;
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        committed == generated,
        "include/raddiff.h is stale: run `RADDIFF_UPDATE_HEADER=1 cargo test --test header` and commit it"
    );
}
