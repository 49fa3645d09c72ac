//! Architecture invariants, checked by reading the source (GUIDE.md, "Which direction dependencies run").
//!
//! - `mesh` and `numerics` depend on nothing else in the crate.
//! - `atlas` depends only on `mesh` and `numerics`.
//! - The geometry core (`mesh`, `numerics`, `atlas`) does no IO and uses no tokio, axum, serde, SQL,
//!   `std::fs`, `std::net`, processes, environment or wall-clock time.
use std::path::{Path, PathBuf};

/// Words that must not appear in code (comments excluded) of the geometry core.
const CORE_FORBIDDEN: &[&str] = &[
    "std::fs",
    "std::net",
    "std::process",
    "std::env",
    "std::time",
    "std::io::stdin",
    "println!",
    "eprintln!",
    "tokio",
    "axum",
    "serde",
    "rusqlite",
    "sqlx",
    "reqwest",
    "gltf",
    "tracing",
    "Instant::now",
    "SystemTime",
];

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("reading {}: {e}", dir.display()))
        .map(|e| e.expect("dir entry").path())
        .collect();
    entries.sort();
    for path in entries {
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The code of a file with `//` comments removed (doc comments included), line by line.
fn code_lines(path: &Path) -> Vec<(usize, String)> {
    let text = std::fs::read_to_string(path).expect("read source");
    text.lines()
        .enumerate()
        .map(|(i, line)| {
            let code = match line.find("//") {
                Some(pos) => &line[..pos],
                None => line,
            };
            (i + 1, code.to_string())
        })
        .filter(|(_, code)| !code.trim().is_empty())
        .collect()
}

/// Every `crate::<module>` path named in the code of `module`'s files.
fn violations(module: &str, allowed_crate_modules: &[&str]) -> Vec<String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let dir = root.join(module);
    let mut files = Vec::new();
    if dir.is_dir() {
        rust_files(&dir, &mut files);
    } else {
        files.push(root.join(format!("{module}.rs")));
    }
    assert!(!files.is_empty(), "no sources found for module {module}");
    let mut found = Vec::new();
    for file in &files {
        for (line_no, code) in code_lines(file) {
            for word in CORE_FORBIDDEN {
                if code.contains(word) {
                    found.push(format!(
                        "{}:{line_no}: uses `{word}`: {}",
                        file.display(),
                        code.trim()
                    ));
                }
            }
            let mut rest = code.as_str();
            while let Some(pos) = rest.find("crate::") {
                let after = &rest[pos + "crate::".len()..];
                let name: String = after
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                let own = name == module;
                if !own && !allowed_crate_modules.contains(&name.as_str()) && !name.is_empty() {
                    found.push(format!(
                        "{}:{line_no}: `{module}` depends on `crate::{name}`: {}",
                        file.display(),
                        code.trim()
                    ));
                }
                rest = after;
            }
        }
    }
    found
}

#[test]
fn mesh_depends_on_nothing_and_does_no_io() {
    let v = violations("mesh", &[]);
    assert!(v.is_empty(), "architecture violations:\n{}", v.join("\n"));
}

#[test]
fn numerics_depends_on_nothing_and_does_no_io() {
    let v = violations("numerics", &[]);
    assert!(v.is_empty(), "architecture violations:\n{}", v.join("\n"));
}

#[test]
fn atlas_depends_only_on_mesh_and_numerics_and_does_no_io() {
    let v = violations("atlas", &["mesh", "numerics"]);
    assert!(v.is_empty(), "architecture violations:\n{}", v.join("\n"));
}

#[test]
fn the_checker_catches_a_violation() {
    // The checker must be able to fail: `gltf_io` legitimately uses serde and names `crate::mesh`,
    // so checking it as if it were core must report something.
    let v = violations("gltf_io", &[]);
    assert!(
        !v.is_empty(),
        "the architecture checker found nothing in gltf_io; is it reading files?"
    );
}

// ---- The service modules (GUIDE.md; issue 6) ----
//
// - `storage` depends on nothing else in the crate and knows no HTTP or async runtime;
// - `jobs` depends on `atlas`, `gltf_io`, `storage`, `api` and the shared shells `unwrap` and
//   `preview`, and knows no HTTP and no SQL;
// - `http` depends on `jobs`, `storage` (its types) and `api`, and knows no SQL;
// - only `storage` names rusqlite, only `http` names axum or tower-http.

/// Every code line (comments removed) of `module` (a folder or a `.rs` file under src/).
fn module_lines(module: &str) -> Vec<(PathBuf, usize, String)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let dir = root.join(module);
    let mut files = Vec::new();
    if dir.is_dir() {
        rust_files(&dir, &mut files);
    } else {
        files.push(root.join(format!("{module}.rs")));
    }
    assert!(!files.is_empty(), "no sources found for module {module}");
    files
        .into_iter()
        .flat_map(|f| {
            code_lines(&f)
                .into_iter()
                .map(move |(n, code)| (f.clone(), n, code))
        })
        .collect()
}

/// Lines of `module` that name a crate module outside `allowed` or use a `forbidden` word.
fn service_violations(module: &str, allowed: &[&str], forbidden: &[&str]) -> Vec<String> {
    let mut found = Vec::new();
    for (file, line_no, code) in module_lines(module) {
        for word in forbidden {
            if code.contains(word) {
                found.push(format!(
                    "{}:{line_no}: uses `{word}`: {}",
                    file.display(),
                    code.trim()
                ));
            }
        }
        let mut rest = code.as_str();
        while let Some(pos) = rest.find("crate::") {
            let after = &rest[pos + "crate::".len()..];
            let name: String = after
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            if !name.is_empty() && name != module && !allowed.contains(&name.as_str()) {
                found.push(format!(
                    "{}:{line_no}: `{module}` depends on `crate::{name}`: {}",
                    file.display(),
                    code.trim()
                ));
            }
            rest = after;
        }
    }
    found
}

/// SQL that must stay inside `storage`.
const SQL_WORDS: &[&str] = &[
    "rusqlite",
    "sqlx",
    "SELECT ",
    "INSERT INTO",
    "UPDATE jobs",
    "DELETE FROM",
];

#[test]
fn storage_depends_on_nothing_and_knows_no_http() {
    let v = service_violations(
        "storage",
        &[],
        &[
            "axum",
            "tower_http",
            "hyper",
            "tokio",
            "crate::http",
            "crate::jobs",
        ],
    );
    assert!(v.is_empty(), "architecture violations:\n{}", v.join("\n"));
}

#[test]
fn jobs_knows_no_http_and_no_sql() {
    let mut forbidden = vec!["axum", "tower_http", "hyper"];
    forbidden.extend_from_slice(SQL_WORDS);
    let v = service_violations(
        "jobs",
        &["atlas", "gltf_io", "storage", "api", "unwrap", "preview"],
        &forbidden,
    );
    assert!(v.is_empty(), "architecture violations:\n{}", v.join("\n"));
}

#[test]
fn http_knows_no_sql() {
    let v = service_violations("http", &["jobs", "storage", "api"], SQL_WORDS);
    assert!(v.is_empty(), "architecture violations:\n{}", v.join("\n"));
}

#[test]
fn only_storage_names_rusqlite_and_only_http_names_axum() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&root, &mut files);
    let mut found = Vec::new();
    for file in &files {
        let rel = file.strip_prefix(&root).expect("under src");
        let in_storage = rel.starts_with("storage");
        let in_http = rel.starts_with("http");
        for (line_no, code) in code_lines(file) {
            if !in_storage && code.contains("rusqlite") {
                found.push(format!(
                    "{}:{line_no}: rusqlite outside storage",
                    rel.display()
                ));
            }
            if !in_http && (code.contains("axum") || code.contains("tower_http")) {
                found.push(format!("{}:{line_no}: axum outside http", rel.display()));
            }
        }
    }
    assert!(
        found.is_empty(),
        "architecture violations:\n{}",
        found.join("\n")
    );
}

#[test]
fn the_service_checker_catches_a_violation() {
    // `http` names axum on nearly every line; checked as if it were `storage` it must fail.
    let v = service_violations("http", &[], &["axum"]);
    assert!(!v.is_empty(), "the service checker found nothing in http");
}
