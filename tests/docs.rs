//! Every link in the README and the guides in `docs/` points somewhere: local files exist, and an
//! anchor (`#section`) names a heading of its target (GitHub's slugs). The guides' Rust blocks are
//! doc-tests (`src/lib.rs`), the README's C example is `ffi-tests/readme_example.c`.

use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The markdown files checked: the README, the changelog and every guide.
fn documents() -> Vec<PathBuf> {
    let mut files = vec![root().join("README.md"), root().join("CHANGELOG.md")];
    let mut docs: Vec<PathBuf> = std::fs::read_dir(root().join("docs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    docs.sort();
    files.extend(docs);
    files
}

/// The text outside fenced code blocks (links in code are code, not links).
fn prose(text: &str) -> String {
    let mut out = String::new();
    let mut fenced = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if !fenced {
            out.push_str(line);
            out.push('\n');
        }
    }
    out
}

/// GitHub's anchor of a heading: lower case, punctuation other than `-` and `_` dropped, spaces
/// to `-`.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter(|c| c.is_alphanumeric() || *c == ' ' || *c == '-' || *c == '_')
        .map(|c| if c == ' ' { '-' } else { c })
        .collect()
}

fn anchors(path: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap();
    prose(&text)
        .lines()
        .filter_map(|l| {
            let t = l.trim_start_matches('#');
            (l.starts_with('#') && t.starts_with(' ')).then(|| slug(t))
        })
        .collect()
}

/// `(target)` of every `[text](target)` in `text`.
fn links(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(i) = rest.find("](") {
        rest = &rest[i + 2..];
        if let Some(j) = rest.find(')') {
            out.push(rest[..j].to_string());
            rest = &rest[j..];
        }
    }
    out
}

#[test]
fn every_local_link_and_anchor_resolves() {
    let mut broken = Vec::new();
    let mut checked = 0;
    for doc in documents() {
        let text = prose(&std::fs::read_to_string(&doc).unwrap());
        for link in links(&text) {
            if link.starts_with("http://") || link.starts_with("https://") {
                continue;
            }
            checked += 1;
            let (file, anchor) = match link.split_once('#') {
                Some((f, a)) => (f, Some(a)),
                None => (link.as_str(), None),
            };
            let target = if file.is_empty() {
                doc.clone()
            } else {
                doc.parent().unwrap().join(file)
            };
            if !target.exists() {
                broken.push(format!("{}: {link} (no such file)", doc.display()));
                continue;
            }
            if let Some(anchor) = anchor {
                if target.extension().is_some_and(|e| e == "md")
                    && !anchors(&target).iter().any(|a| a == anchor)
                {
                    broken.push(format!("{}: {link} (no such heading)", doc.display()));
                }
            }
        }
    }
    assert!(
        checked > 20,
        "only {checked} links found: is the parser broken?"
    );
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn slugs_follow_github() {
    assert_eq!(slug("C++ integration (Embree)"), "c-integration-embree");
    assert_eq!(slug("Set-up: two commands"), "set-up-two-commands");
    assert_eq!(links("see [a](b.md#c) and [d](e)"), vec!["b.md#c", "e"]);
}

/// docs/ARCHITECTURE.md names the code as it is: every path it writes in backticks exists.
///
/// A path starting with a top-level folder of the repository (`src/`, `tests/`, ...) is taken from
/// the repository's root; a bare file or folder name (`marched.rs`, `lambert/`) from the folder of
/// the last such path on the same line, as the table writes them
/// (`src/kernels/transmittance.rs`, `marched.rs`).
#[test]
fn architecture_names_only_existing_paths() {
    const ROOTS: &[&str] = &[
        "src/",
        "tests/",
        "benches/",
        "include/",
        "ffi-tests/",
        "examples/",
        "fuzz/",
        "docs/",
        "scripts/",
        ".ci/",
    ];
    let text = std::fs::read_to_string(root().join("docs/ARCHITECTURE.md")).unwrap();
    let mut missing = Vec::new();
    let mut named = 0;
    for line in prose(&text).lines() {
        let mut folder: Option<String> = None;
        for (i, token) in line.split('`').enumerate() {
            if i % 2 == 0 || token.contains(' ') {
                continue;
            }
            let path = if ROOTS.iter().any(|r| token.starts_with(r)) {
                folder = Some(match token.rfind('/') {
                    Some(j) => token[..=j].to_string(),
                    None => String::new(),
                });
                token.to_string()
            } else if token.ends_with(".rs") || (token.ends_with('/') && !token.contains("::")) {
                match &folder {
                    Some(f) => format!("{f}{token}"),
                    None => continue,
                }
            } else {
                continue;
            };
            named += 1;
            if !root().join(&path).exists() {
                missing.push(path);
            }
        }
    }
    assert!(
        named > 40,
        "only {named} paths found in docs/ARCHITECTURE.md"
    );
    assert!(
        missing.is_empty(),
        "docs/ARCHITECTURE.md names paths that do not exist: {missing:?}"
    );
}

/// docs/ARCHITECTURE.md names every folder of `src/` (each module folder is a concept with a map),
/// but for folders that hold only a module's sibling `tests.rs`.
#[test]
fn architecture_names_every_source_folder() {
    let text = std::fs::read_to_string(root().join("docs/ARCHITECTURE.md")).unwrap();
    let mut folders = Vec::new();
    let mut stack = vec![root().join("src")];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if !path.is_dir() {
                continue;
            }
            stack.push(path.clone());
            // A folder that holds only a module's `tests.rs` is that module's tests, not a concept.
            let only_tests = std::fs::read_dir(&path)
                .unwrap()
                .all(|e| e.unwrap().file_name() == "tests.rs");
            if !only_tests {
                let rel = path.strip_prefix(root()).unwrap().to_string_lossy();
                folders.push(format!("{}/", rel.replace('\\', "/")));
            }
        }
    }
    folders.sort();
    let unnamed: Vec<&String> = folders
        .iter()
        .filter(|f| {
            // Named whole, or as `name/` after its parent (`src/kernels/form_factor/` (`lambert/`)).
            let last = f.trim_end_matches('/').rsplit('/').next().unwrap();
            !text.contains(f.as_str()) && !text.contains(&format!("`{last}/`"))
        })
        .collect();
    assert!(
        unnamed.is_empty(),
        "folders of src/ docs/ARCHITECTURE.md does not name: {unnamed:?}"
    );
}
