//! Compiles every C99 and C++17 program in `ffi-tests/` against `include/raddiff.h` and the static
//! library cargo built for this test run, runs it, and requires exit status 0.
//!
//! `RADDIFF_FFI_SANITIZE=1` adds AddressSanitizer and UndefinedBehaviorSanitizer (used by `.ci/run`).
//! `CC` / `CXX` choose the compilers (default `cc` / `c++`).

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The static library cargo built for this test run. `cargo test` writes it to `target/<profile>/deps/`
/// and does not copy it up to `target/<profile>/` (only `cargo build` does), so take the fresh one.
fn static_library() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    exe.parent().unwrap().join("libraddiff.a")
}

fn sanitize() -> bool {
    std::env::var_os("RADDIFF_FFI_SANITIZE").is_some_and(|v| v != "0")
}

fn compile(source: &Path, out: &Path, cpp: bool, link: bool) {
    let compiler = if cpp {
        std::env::var("CXX").unwrap_or_else(|_| "c++".into())
    } else {
        std::env::var("CC").unwrap_or_else(|_| "cc".into())
    };
    let mut cmd = Command::new(&compiler);
    cmd.arg(if cpp { "-std=c++17" } else { "-std=c99" })
        .args(["-Wall", "-Wextra", "-Werror", "-pedantic", "-g", "-O1"])
        .arg("-I")
        .arg(root().join("include"))
        .arg("-I")
        .arg(root().join("ffi-tests"));
    if sanitize() {
        cmd.args([
            "-fsanitize=address,undefined",
            "-fno-sanitize-recover=all",
            "-fno-omit-frame-pointer",
        ]);
    }
    if link {
        cmd.arg(source).arg("-o").arg(out);
        cmd.arg(static_library());
        cmd.args(["-lpthread", "-ldl", "-lm", "-lrt"]);
    } else {
        cmd.arg("-c").arg(source).arg("-o").arg(out);
    }
    let result = cmd
        .output()
        .unwrap_or_else(|e| panic!("cannot run {compiler}: {e}"));
    assert!(
        result.status.success(),
        "{compiler} failed on {}:\n{}",
        source.display(),
        String::from_utf8_lossy(&result.stderr)
    );
}

fn sources(ext: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(root().join("ffi-tests"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    v.sort();
    v
}

fn out_dir() -> PathBuf {
    let dir =
        PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(if sanitize() { "ffi-san" } else { "ffi" });
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn header_compiles_warning_free_as_c99_and_cpp17() {
    let dir = out_dir();
    let c = dir.join("header_only.c");
    std::fs::write(
        &c,
        "#include \"raddiff.h\"\nint raddiff_header_only_check(void) { return RADDIFF_OK; }\n",
    )
    .unwrap();
    compile(&c, &dir.join("header_only_c.o"), false, false);
    let cpp = dir.join("header_only.cpp");
    std::fs::write(
        &cpp,
        "#include \"raddiff.h\"\nint raddiff_header_only_check() { return RADDIFF_OK; }\n",
    )
    .unwrap();
    compile(&cpp, &dir.join("header_only_cpp.o"), true, false);
}

/// The README's C example is `ffi-tests/readme_example.c`, so it is compiled and run below.
#[test]
fn readme_c_example_is_tested() {
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    let start = readme.find("```c\n").expect("README has a C example") + 5;
    let end = start + readme[start..].find("```").unwrap();
    let example = std::fs::read_to_string(root().join("ffi-tests/readme_example.c")).unwrap();
    assert_eq!(
        &readme[start..end],
        example,
        "README C example and ffi-tests/readme_example.c differ"
    );
}

/// The README's C++ example (section "Using it from C++") is `ffi-tests/hpp_readme_example.cpp`,
/// so it is compiled and run below.
#[test]
fn readme_cpp_example_is_tested() {
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    let section = readme
        .find("## Using it from C++")
        .expect("README has a C++ section");
    let start = section + readme[section..].find("```cpp\n").expect("C++ example") + 7;
    let end = start + readme[start..].find("```").unwrap();
    let example = std::fs::read_to_string(root().join("ffi-tests/hpp_readme_example.cpp")).unwrap();
    assert_eq!(
        &readme[start..end],
        example,
        "README C++ example and ffi-tests/hpp_readme_example.cpp differ"
    );
}

/// The C and C++ programs of `docs/integrate.md` are the `ffi-tests/` files named in the comment
/// above each block, byte for byte, so they are compiled and run below.
#[test]
fn integration_guide_programs_are_tested() {
    let guide = std::fs::read_to_string(root().join("docs/integrate.md")).unwrap();
    let mut shown = Vec::new();
    for (at, _) in guide.match_indices("<!-- ffi-tests/") {
        let name_start = at + "<!-- ".len();
        let name_end = name_start + guide[name_start..].find(" -->").unwrap();
        let name = &guide[name_start..name_end];
        let fence = name_end + guide[name_end..].find("```").unwrap();
        let start = fence + guide[fence..].find('\n').unwrap() + 1;
        let end = start + guide[start..].find("```").unwrap();
        let program = std::fs::read_to_string(root().join(name)).unwrap();
        assert_eq!(
            &guide[start..end],
            program,
            "docs/integrate.md shows another {name}"
        );
        shown.push(name.to_string());
    }
    let expected = [
        "integrate_high.c",
        "integrate_high.cpp",
        "integrate_low.c",
        "integrate_low.cpp",
    ];
    for file in expected {
        assert!(
            shown.iter().any(|s| s.ends_with(file)),
            "docs/integrate.md does not show ffi-tests/{file}"
        );
    }
}

#[test]
fn ffi_programs_pass() {
    let lib = static_library();
    assert!(
        lib.exists(),
        "static library not found at {}",
        lib.display()
    );
    let dir = out_dir();
    let mut programs = Vec::new();
    for (ext, cpp) in [("c", false), ("cpp", true)] {
        for src in sources(ext) {
            let stem = src.file_stem().unwrap().to_string_lossy().to_string();
            let exe = dir.join(format!("{stem}_{ext}"));
            compile(&src, &exe, cpp, true);
            programs.push(exe);
        }
    }
    assert!(!programs.is_empty(), "no programs in ffi-tests/");
    for exe in programs {
        // in the build's scratch directory: programs may write files where they run
        let out = Command::new(&exe).current_dir(&dir).output().unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            out.status.success(),
            "{} failed ({}):\n{stdout}\n{stderr}",
            exe.display(),
            out.status
        );
        print!("{stdout}");
    }
}
