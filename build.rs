//! Build script: enables the AVX-512 version of the gather Hessian's batch code
//! (`gather::hessian`'s edge batches) on compilers where the `avx512*` target features are stable
//! (Rust 1.89 and later). Older compilers (the crate's MSRV is 1.80) build the AVX2 and portable
//! versions only.

use std::process::Command;

fn main() {
    println!("cargo::rustc-check-cfg=cfg(raddiff_avx512)");
    println!("cargo::rerun-if-changed=build.rs");
    let rustc = std::env::var_os("RUSTC").unwrap_or_else(|| "rustc".into());
    let minor = Command::new(rustc)
        .arg("--version")
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .and_then(|v| {
            // "rustc 1.95.0 (…)"
            let version = v.split_whitespace().nth(1)?.to_owned();
            let mut parts = version.split('.');
            let major: u32 = parts.next()?.parse().ok()?;
            let minor: u32 = parts.next()?.parse().ok()?;
            Some((major, minor))
        });
    if minor.is_some_and(|(major, minor)| major > 1 || minor >= 89) {
        println!("cargo::rustc-cfg=raddiff_avx512");
    }
}
