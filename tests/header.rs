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

/// Every macro, type and function the header declares is in the raddiff namespace (C has no
/// namespaces: a bare `NONE` or `MAX_CHANNELS` would collide with a renderer's own names).
#[test]
fn every_declared_name_is_prefixed() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let header = std::fs::read_to_string(root.join("include/raddiff.h")).unwrap();
    let mut bad = Vec::new();
    for line in header.lines() {
        let line = line.trim();
        if let Some(rest) = line.strip_prefix("#define ") {
            let name = rest.split_whitespace().next().unwrap_or("");
            if !name.starts_with("RADDIFF_") {
                bad.push(name.to_string());
            }
        }
        if let Some(rest) = line.strip_prefix("typedef struct ") {
            let name = rest.split_whitespace().next().unwrap_or("");
            if !name.starts_with("raddiff_") {
                bad.push(name.to_string());
            }
        }
        if line.contains('(') && !line.starts_with("//") && !line.starts_with('#') {
            // a declaration line: `type name(args` or `type *name(args`
            if let Some(open) = line.find('(') {
                let before = &line[..open];
                if let Some(name) = before.split([' ', '*']).next_back() {
                    if !name.is_empty()
                        && !name.starts_with("raddiff_")
                        && before.contains(' ')
                        && line.ends_with([';', ',', '('])
                    {
                        bad.push(name.to_string());
                    }
                }
            }
        }
    }
    assert!(
        bad.is_empty(),
        "unprefixed names in include/raddiff.h: {bad:?}"
    );
}

/// The C functions `include/raddiff.h` declares (names before `(` on non-comment lines).
fn declared_functions(header: &str) -> Vec<String> {
    let mut names = Vec::new();
    for line in header.lines() {
        let line = line.trim();
        if line.starts_with("//") || line.starts_with('#') || line.starts_with('*') {
            continue;
        }
        let Some(open) = line.find('(') else {
            continue;
        };
        let before = &line[..open];
        if let Some(name) = before.split([' ', '*']).next_back() {
            if name.starts_with("raddiff_")
                && before.contains(' ')
                && !names.iter().any(|n| n == name)
            {
                names.push(name.to_string());
            }
        }
    }
    names
}

/// Every function of the C header is called in the C++ wrapper `include/raddiff.hpp` (outside
/// comments), so the wrapper cannot fall behind the header.
#[test]
fn cpp_wrapper_calls_every_c_function() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let header = std::fs::read_to_string(root.join("include/raddiff.h")).unwrap();
    let wrapper = std::fs::read_to_string(root.join("include/raddiff.hpp")).unwrap();
    // the wrapper's code without its comments (`//` to the end of the line, `/* ... */`)
    let mut code = String::new();
    let mut rest = wrapper.as_str();
    while let Some(start) = rest.find("/*") {
        code.push_str(&rest[..start]);
        rest = rest[start..]
            .find("*/")
            .map_or("", |end| &rest[start + end + 2..]);
    }
    code.push_str(rest);
    let code: String = code
        .lines()
        .map(|l| l.find("//").map_or(l, |i| &l[..i]))
        .collect::<Vec<_>>()
        .join("\n");
    let functions = declared_functions(&header);
    assert!(
        functions.len() >= 30,
        "found only {} functions in include/raddiff.h: {functions:?}",
        functions.len()
    );
    let missing: Vec<&String> = functions
        .iter()
        .filter(|name| {
            !code.match_indices(name.as_str()).any(|(i, _)| {
                let before = code[..i].chars().next_back();
                let after = code[i + name.len()..].trim_start().chars().next();
                !before.is_some_and(|c| c.is_alphanumeric() || c == '_') && after == Some('(')
            })
        })
        .collect();
    assert!(
        missing.is_empty(),
        "include/raddiff.hpp does not call these functions of include/raddiff.h: {missing:?}"
    );
}
