//! The module graph of `src/`: no module imports one that imports it back (no import cycles), and
//! the layers of docs/ARCHITECTURE.md point downwards only.
//!
//! The graph is built from the source text: every `use` tree and every path that starts with
//! `crate::`, `super::`, `self::` or the name of a child module, outside `#[cfg(test)]` items, is
//! resolved to the file that defines the module it names (the longest prefix that is a module;
//! inline `mod name { ... }` blocks belong to their file). An edge `a -> b` means that `a` names
//! something of `b`. Declaring a child module (`mod b;`) is not an edge: a folder's `mod.rs` that
//! only declares its children depends on none of them, while one that calls into them does.
//!
//! On failure the test prints each cycle as the files in it and, for every edge inside it, the
//! names that tie it.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Cycles allowed to stay, each as its sorted set of files (as the failure message prints them).
/// None: the cycles that predated this check are taken apart. The test fails on any cycle not
/// listed, and on a listed one that is gone.
const KNOWN_CYCLES: &[&[&str]] = &[];

/// The layers, lowest first: a module may name modules of its own layer or of layers below it.
/// A module belongs to the first layer one of whose prefixes it starts with.
const LAYERS: &[&[&str]] = &[
    &["src/deriv.rs", "src/error.rs", "src/simd.rs", "src/lib.rs"],
    &["src/kernels/"],
    &["src/gather/", "src/scatter/"],
    &["src/cache/"],
    &["src/ffi/"],
];

#[test]
fn no_import_cycles_between_modules() {
    let graph = Graph::of_crate(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
    assert!(
        graph.files.len() > 20,
        "the module walk found only {} files",
        graph.files.len()
    );
    let cycles = graph.cycles();
    let mut report = String::new();
    for cycle in &cycles {
        let files: Vec<&str> = cycle.iter().map(String::as_str).collect();
        if KNOWN_CYCLES.contains(&files.as_slice()) {
            continue;
        }
        report += &format!("cycle of {} modules: {files:?}\n", cycle.len());
        for (from, to, names) in graph.edges_within(cycle) {
            report += &format!("  {from} -> {to}: {}\n", names.join(", "));
        }
    }
    for known in KNOWN_CYCLES {
        if !cycles
            .iter()
            .any(|c| c.iter().map(String::as_str).eq(known.iter().copied()))
        {
            report +=
                &format!("listed cycle no longer found (remove it from KNOWN_CYCLES): {known:?}\n");
        }
    }
    assert!(report.is_empty(), "import cycles in src/:\n{report}");
}

#[test]
fn layers_point_downwards() {
    let graph = Graph::of_crate(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
    let mut report = String::new();
    for ((from, to), names) in &graph.edges {
        let (Some(a), Some(b)) = (layer(from), layer(to)) else {
            report += &format!("{from} or {to} is in no layer of LAYERS\n");
            continue;
        };
        if b > a {
            report += &format!("{from} -> {to} (upwards): {}\n", names.join(", "));
        }
    }
    assert!(report.is_empty(), "imports against the layers:\n{report}");
}

/// The checker itself, on small trees: it must find what it is there to find.
#[test]
fn the_checker_finds_cycles_and_ignores_test_code() {
    let dir = std::env::temp_dir().join(format!("raddiff-module-graph-{}", std::process::id()));
    let write = |path: &str, text: &str| {
        let p = dir.join(path);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, text).unwrap();
    };
    write(
        "lib.rs",
        "mod a;\nmod b;\n#[cfg(test)]\nmod t;\n// use crate::b::Z;\nconst S: &str = \"crate::a::X\";\n",
    );
    write(
        "a/mod.rs",
        "mod c;\npub use c::Y;\npub(crate) fn f() { crate::b::g() }\n",
    );
    write(
        "a/c.rs",
        "use super::super::b::{self, G};\npub struct Y;\npub(in crate::a) struct W;\n",
    );
    write(
        "b.rs",
        "pub fn g() {}\npub struct G;\n#[cfg(test)]\nmod tests { use crate::a::f; }\nmod inner { use super::super::a::c::Y; }\n",
    );
    write("t.rs", "use crate::a::f;\n");
    let graph = Graph::of_crate(&dir);
    std::fs::remove_dir_all(&dir).unwrap();
    let edges: BTreeSet<(String, String)> = graph.edges.keys().cloned().collect();
    let expected: BTreeSet<(String, String)> = [
        ("src/a/mod.rs", "src/a/c.rs"),
        ("src/a/mod.rs", "src/b.rs"),
        ("src/a/c.rs", "src/b.rs"),
        ("src/b.rs", "src/a/c.rs"),
    ]
    .iter()
    .map(|(a, b)| (a.to_string(), b.to_string()))
    .collect();
    assert_eq!(edges, expected);
    let cycles = graph.cycles();
    assert_eq!(
        cycles,
        vec![vec!["src/a/c.rs".to_string(), "src/b.rs".to_string()]]
    );
}

fn layer(file: &str) -> Option<usize> {
    LAYERS
        .iter()
        .position(|prefixes| prefixes.iter().any(|p| file.starts_with(p)))
}

/// Files of the crate as modules, and the edges between them with the names behind each.
struct Graph {
    /// Module path (`["kernels", "form_factor"]`) to its file, relative to the crate (`src/...`).
    files: BTreeMap<Vec<String>, String>,
    /// Inline modules, to the file that holds them.
    inline: BTreeMap<Vec<String>, String>,
    edges: BTreeMap<(String, String), Vec<String>>,
}

impl Graph {
    fn of_crate(src: &Path) -> Graph {
        let mut graph = Graph {
            files: BTreeMap::new(),
            inline: BTreeMap::new(),
            edges: BTreeMap::new(),
        };
        // First every module and its file, then the references (which need every module).
        let mut parsed = Vec::new();
        graph.walk(src, &src.join("lib.rs"), Vec::new(), &mut parsed);
        for (module, tokens) in &parsed {
            graph.collect_edges(module, tokens);
        }
        graph
    }

    fn walk(
        &mut self,
        src: &Path,
        file: &Path,
        module: Vec<String>,
        parsed: &mut Vec<(Vec<String>, Vec<Token>)>,
    ) {
        let text =
            std::fs::read_to_string(file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        let tokens = tokenize(&text);
        let name = format!(
            "src/{}",
            file.strip_prefix(src)
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/")
        );
        self.files.insert(module.clone(), name.clone());
        // Child files are looked up beside `mod.rs`/`lib.rs`, or in the folder named as the file.
        let folder: PathBuf = match file.file_name().and_then(|f| f.to_str()) {
            Some("mod.rs") | Some("lib.rs") => file.parent().unwrap().to_path_buf(),
            _ => file.with_extension(""),
        };
        let mut children = Vec::new();
        for_each_item(&tokens, &module, &mut |event| match event {
            Event::FileModule { path } if path.len() == module.len() + 1 => {
                children.push(path.last().unwrap().clone())
            }
            Event::FileModule { .. } => {
                panic!("{name}: file modules declared inside inline modules are not supported")
            }
            Event::InlineModule { path } => {
                self.inline.insert(path.to_vec(), name.clone());
            }
            Event::Reference { .. } => {}
        });
        parsed.push((module.clone(), tokens));
        for child in children {
            let flat = folder.join(format!("{child}.rs"));
            let nested = folder.join(&child).join("mod.rs");
            let path = if flat.exists() { flat } else { nested };
            let mut m = module.clone();
            m.push(child);
            self.walk(src, &path, m, parsed);
        }
    }

    fn collect_edges(&mut self, module: &[String], tokens: &[Token]) {
        let from = self.files[module].clone();
        let mut references = Vec::new();
        for_each_item(tokens, module, &mut |event| {
            if let Event::Reference { scope, path } = event {
                references.push((scope.to_vec(), path.to_vec()));
            }
        });
        for (scope, path) in references {
            let Some(absolute) = self.resolve(&scope, &path) else {
                continue;
            };
            // The longest prefix that is a module names the file the reference reaches.
            let Some((file, item)) = (0..=absolute.len()).rev().find_map(|k| {
                let prefix = &absolute[..k];
                let file = self.files.get(prefix).or_else(|| self.inline.get(prefix))?;
                Some((file.clone(), absolute[k..].join("::")))
            }) else {
                continue;
            };
            if file == from {
                continue;
            }
            let names = self.edges.entry((from.clone(), file)).or_default();
            let item = if item.is_empty() {
                "(module)".to_string()
            } else {
                item
            };
            if !names.contains(&item) {
                names.push(item);
            }
        }
    }

    /// The absolute module path a reference written in `scope` names, or `None` when it does not
    /// start inside the crate.
    fn resolve(&self, scope: &[String], path: &[String]) -> Option<Vec<String>> {
        let mut base: Vec<String> = scope.to_vec();
        let mut rest = path;
        match path.first()?.as_str() {
            "crate" => {
                base.clear();
                rest = &path[1..];
            }
            "self" => rest = &path[1..],
            "super" => {
                while rest.first().map(String::as_str) == Some("super") {
                    base.pop()?;
                    rest = &rest[1..];
                }
            }
            child => {
                let mut m = scope.to_vec();
                m.push(child.to_string());
                if !self.files.contains_key(&m) && !self.inline.contains_key(&m) {
                    return None;
                }
            }
        }
        base.extend(rest.iter().cloned());
        Some(base)
    }

    /// The strongly connected components with more than one file, each sorted, in sorted order.
    fn cycles(&self) -> Vec<Vec<String>> {
        let nodes: Vec<&String> = self.files.values().collect();
        let index: BTreeMap<&String, usize> =
            nodes.iter().enumerate().map(|(i, n)| (*n, i)).collect();
        let mut next = vec![Vec::new(); nodes.len()];
        for (from, to) in self.edges.keys() {
            next[index[from]].push(index[to]);
        }
        let components = strongly_connected(&next);
        let mut cycles: Vec<Vec<String>> = components
            .into_iter()
            .filter(|c| c.len() > 1)
            .map(|c| {
                let mut files: Vec<String> = c.into_iter().map(|i| nodes[i].clone()).collect();
                files.sort();
                files
            })
            .collect();
        cycles.sort();
        cycles
    }

    fn edges_within(&self, files: &[String]) -> Vec<(String, String, Vec<String>)> {
        self.edges
            .iter()
            .filter(|((a, b), _)| files.contains(a) && files.contains(b))
            .map(|((a, b), names)| (a.clone(), b.clone(), names.clone()))
            .collect()
    }
}

/// Tarjan's algorithm (iterative).
fn strongly_connected(next: &[Vec<usize>]) -> Vec<Vec<usize>> {
    let n = next.len();
    let (mut index, mut low) = (vec![usize::MAX; n], vec![0; n]);
    let mut on_stack = vec![false; n];
    let (mut stack, mut components, mut counter) = (Vec::new(), Vec::new(), 0);
    for root in 0..n {
        if index[root] != usize::MAX {
            continue;
        }
        let mut work = vec![(root, 0usize)];
        while let Some(&mut (v, ref mut child)) = work.last_mut() {
            if *child == 0 {
                index[v] = counter;
                low[v] = counter;
                counter += 1;
                stack.push(v);
                on_stack[v] = true;
            }
            if *child < next[v].len() {
                let w = next[v][*child];
                *child += 1;
                if index[w] == usize::MAX {
                    work.push((w, 0));
                } else if on_stack[w] {
                    low[v] = low[v].min(index[w]);
                }
                continue;
            }
            work.pop();
            if let Some(&(parent, _)) = work.last() {
                low[parent] = low[parent].min(low[v]);
            }
            if low[v] == index[v] {
                let mut component = Vec::new();
                loop {
                    let w = stack.pop().unwrap();
                    on_stack[w] = false;
                    component.push(w);
                    if w == v {
                        break;
                    }
                }
                components.push(component);
            }
        }
    }
    components
}

#[derive(Debug, Clone, PartialEq)]
enum Token {
    Ident(String),
    /// `::`
    Path,
    Punct(char),
}

/// Identifiers, `::` and punctuation, without comments, string and character literals.
fn tokenize(text: &str) -> Vec<Token> {
    let c: Vec<char> = text.chars().collect();
    let mut tokens = Vec::new();
    let mut i = 0;
    while i < c.len() {
        let ch = c[i];
        if ch == '/' && c.get(i + 1) == Some(&'/') {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if ch == '/' && c.get(i + 1) == Some(&'*') {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
        } else if ch == 'r'
            && c.get(i + 1) == Some(&'#')
            && c.get(i + 2).is_some_and(|n| n.is_alphabetic() || *n == '_')
        {
            // A raw identifier, `r#type`.
            i += 2;
        } else if ch == 'r'
            && matches!(c.get(i + 1), Some('"') | Some('#'))
            && raw_string_end(&c, i).is_some()
        {
            i = raw_string_end(&c, i).unwrap();
        } else if ch == 'b' && c.get(i + 1) == Some(&'"') {
            i = string_end(&c, i + 1);
        } else if ch == '"' {
            i = string_end(&c, i);
        } else if ch == '\'' {
            // A character literal ('x', '\n', '\u{..}') or a lifetime ('a).
            if c.get(i + 1) == Some(&'\\') {
                i += 3;
                while i < c.len() && c[i] != '\'' {
                    i += 1;
                }
                i += 1;
            } else if c.get(i + 2) == Some(&'\'') {
                i += 3;
            } else {
                i += 1;
                while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                    i += 1;
                }
            }
        } else if ch.is_alphabetic() || ch == '_' {
            let start = i;
            while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                i += 1;
            }
            let word: String = c[start..i].iter().collect();
            // `r#ident`
            tokens.push(Token::Ident(word));
        } else if ch.is_ascii_digit() {
            while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_' || c[i] == '.') {
                if c[i] == '.' && c.get(i + 1) == Some(&'.') {
                    break;
                }
                i += 1;
            }
        } else if ch == ':' && c.get(i + 1) == Some(&':') {
            tokens.push(Token::Path);
            i += 2;
        } else {
            if !ch.is_whitespace() {
                tokens.push(Token::Punct(ch));
            }
            i += 1;
        }
    }
    tokens
}

fn string_end(c: &[char], open: usize) -> usize {
    let mut i = open + 1;
    while i < c.len() && c[i] != '"' {
        if c[i] == '\\' {
            i += 1;
        }
        i += 1;
    }
    i + 1
}

/// The end of a raw string starting at `start` (`r"`, `r#"`, ...), or `None` if it is not one.
fn raw_string_end(c: &[char], start: usize) -> Option<usize> {
    let mut i = start + 1;
    let mut hashes = 0;
    while c.get(i) == Some(&'#') {
        hashes += 1;
        i += 1;
    }
    if c.get(i) != Some(&'"') {
        return None;
    }
    i += 1;
    while i < c.len() {
        if c[i] == '"' && (1..=hashes).all(|k| c.get(i + k) == Some(&'#')) {
            return Some(i + 1 + hashes);
        }
        i += 1;
    }
    Some(c.len())
}

enum Event<'a> {
    /// `mod name;`
    FileModule { path: &'a [String] },
    /// `mod name { ... }`
    InlineModule { path: &'a [String] },
    /// A path written in module `scope`.
    Reference {
        scope: &'a [String],
        path: &'a [String],
    },
}

/// Walks the items of a file in module `module`, skipping `#[cfg(test)]` items, and reports module
/// declarations and references.
fn for_each_item(tokens: &[Token], module: &[String], on: &mut dyn FnMut(Event)) {
    let mut scope: Vec<String> = module.to_vec();
    // Brace depth at which each inline module opened.
    let mut inline_depths: Vec<usize> = Vec::new();
    let mut depth = 0usize;
    let mut i = 0;
    while i < tokens.len() {
        match &tokens[i] {
            Token::Punct('#') => {
                // An attribute: `#[...]` or `#![...]`.
                let mut j = i + 1;
                if tokens.get(j) == Some(&Token::Punct('!')) {
                    j += 1;
                }
                let end = matching(tokens, j);
                let test_only = is_cfg_test(&tokens[j..end]);
                i = end;
                if test_only {
                    i = item_end(tokens, i);
                }
                continue;
            }
            Token::Punct('{') => depth += 1,
            Token::Punct('}') => {
                depth = depth.saturating_sub(1);
                if inline_depths.last() == Some(&depth) {
                    inline_depths.pop();
                    scope.pop();
                }
            }
            // A visibility, `pub(in super::super)`, restricts; it imports nothing.
            Token::Ident(w) if w == "pub" && tokens.get(i + 1) == Some(&Token::Punct('(')) => {
                i = matching(tokens, i + 1);
                continue;
            }
            Token::Ident(w) if w == "mod" => {
                if let Some(Token::Ident(name)) = tokens.get(i + 1) {
                    let mut path = scope.clone();
                    path.push(name.clone());
                    match tokens.get(i + 2) {
                        Some(Token::Punct(';')) => on(Event::FileModule { path: &path }),
                        Some(Token::Punct('{')) => {
                            on(Event::InlineModule { path: &path });
                            inline_depths.push(depth);
                            depth += 1;
                            scope = path;
                            i += 3;
                            continue;
                        }
                        _ => {}
                    }
                    i += 2;
                    continue;
                }
            }
            Token::Ident(w) if w == "use" => {
                let end = (i..tokens.len())
                    .find(|&k| tokens[k] == Token::Punct(';'))
                    .unwrap_or(tokens.len());
                for path in use_paths(&tokens[i + 1..end]) {
                    on(Event::Reference {
                        scope: &scope,
                        path: &path,
                    });
                }
                i = end + 1;
                continue;
            }
            Token::Ident(first) => {
                // A path: `a::b::c` (the first segment not itself after `::`).
                let after_path = i > 0 && tokens[i - 1] == Token::Path;
                if !after_path && tokens.get(i + 1) == Some(&Token::Path) {
                    let mut path = vec![first.clone()];
                    let mut j = i + 1;
                    while tokens.get(j) == Some(&Token::Path) {
                        match tokens.get(j + 1) {
                            Some(Token::Ident(s)) => {
                                path.push(s.clone());
                                j += 2;
                            }
                            _ => break,
                        }
                    }
                    on(Event::Reference {
                        scope: &scope,
                        path: &path,
                    });
                    i = j;
                    continue;
                }
            }
            _ => {}
        }
        i += 1;
    }
}

/// Index just past the bracket group that starts at `open` (`[`, `(` or `{`).
fn matching(tokens: &[Token], open: usize) -> usize {
    let mut depth = 0i32;
    for (k, t) in tokens.iter().enumerate().skip(open) {
        match t {
            Token::Punct('[') | Token::Punct('(') | Token::Punct('{') => depth += 1,
            Token::Punct(']') | Token::Punct(')') | Token::Punct('}') => {
                depth -= 1;
                if depth == 0 {
                    return k + 1;
                }
            }
            _ => {}
        }
    }
    tokens.len()
}

/// Index just past the item that starts at `start`: its first `;` outside brackets or its first
/// brace group.
fn item_end(tokens: &[Token], start: usize) -> usize {
    let mut k = start;
    while k < tokens.len() {
        match tokens[k] {
            Token::Punct(';') => return k + 1,
            Token::Punct('{') => return matching(tokens, k),
            Token::Punct('(') | Token::Punct('[') => k = matching(tokens, k),
            Token::Punct('#') => {
                // Further attributes of the same item.
                let j = if tokens.get(k + 1) == Some(&Token::Punct('!')) {
                    k + 2
                } else {
                    k + 1
                };
                k = matching(tokens, j);
            }
            _ => k += 1,
        }
    }
    tokens.len()
}

/// `[cfg(test)]`
fn is_cfg_test(attribute: &[Token]) -> bool {
    attribute
        == [
            Token::Punct('['),
            Token::Ident("cfg".into()),
            Token::Punct('('),
            Token::Ident("test".into()),
            Token::Punct(')'),
            Token::Punct(']'),
        ]
}

/// The paths of a `use` tree (`a::{b, c::{self, d}}` gives `a::b`, `a::c`, `a::c::d`); `as`
/// renames and globs end a path.
fn use_paths(tokens: &[Token]) -> Vec<Vec<String>> {
    fn tree(tokens: &[Token], i: &mut usize, prefix: &[String], out: &mut Vec<Vec<String>>) {
        let mut path = prefix.to_vec();
        while *i < tokens.len() {
            match &tokens[*i] {
                Token::Ident(w) if w == "as" => *i += 2,
                Token::Ident(w)
                    if w == "self" && path.len() == prefix.len() && !prefix.is_empty() =>
                {
                    *i += 1
                }
                Token::Ident(w) => {
                    path.push(w.clone());
                    *i += 1;
                }
                Token::Path => *i += 1,
                Token::Punct('*') => *i += 1,
                Token::Punct('{') => {
                    *i += 1;
                    loop {
                        tree(tokens, i, &path, out);
                        match tokens.get(*i) {
                            Some(Token::Punct(',')) => *i += 1,
                            Some(Token::Punct('}')) => {
                                *i += 1;
                                break;
                            }
                            _ => break,
                        }
                    }
                    return;
                }
                Token::Punct(',') | Token::Punct('}') => break,
                _ => *i += 1,
            }
        }
        if !path.is_empty() {
            out.push(path);
        }
    }
    let mut out = Vec::new();
    let mut i = 0;
    // `pub use`, `pub(crate) use`: the visibility came before `use`.
    tree(tokens, &mut i, &[], &mut out);
    out
}
