//! Architecture rules, checked by reading the source (GUIDE.md, "Which direction dependencies run").
//!
//! One table, [`RULES`], has a row for every top-level module of `src/` (and for `lib.rs`,
//! `main.rs` and the binary's `cli/`): the crate modules it may name and the words its code must
//! not contain. The checks, each a test below with a self-test that plants a violation in
//! synthetic source and sees it reported:
//!
//! 1. every top-level module has a row, and every row a module;
//! 2. a module names only the crate modules its row allows (`crate::x`, `super::…` leaving the
//!    module, `use` trees, and `texatlas::x` in the binary);
//! 3. a module's code (comments removed) contains none of its row's forbidden words: the
//!    geometry core (`mesh`, `numerics`, `atlas`) does no IO and uses no tokio, axum, serde,
//!    SQL, `std::fs`, `std::net`, processes, environment or wall-clock time;
//! 4. the `serde` crate (derives: the contract types) appears only in `api`, and in the files of
//!    [`SERDE_EXCEPTIONS`], each with its reason; `serde_json` (using a contract) is not limited;
//! 5. only `storage` names rusqlite, only `http` names axum or tower-http;
//! 6. no module cycle at any level: the references between the children of every module
//!    (top-level modules, the files of one folder, inline modules) form no cycle, re-exports
//!    followed (so `super::X` re-exported by the parent from a sibling counts as naming that
//!    sibling); test code (`#[cfg(test)]` modules) is left out; a cycle is printed with the line
//!    of each of its edges;
//! 7. no production file (every file not under a `#[cfg(test)]` module) is over [`LINE_CAP`]
//!    lines, except the files of [`OVER_CAP`], a ratchet: a listed file may not grow, and must be
//!    lowered to its new count when it shrinks and removed when it is under the cap.
//!
//! The checks read the source with a small lexer (comments, strings and char literals told
//! apart) and follow `use` trees, `pub use` re-exports and glob re-exports by name; macros are
//! not expanded.
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

// ---- The table ----

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

/// SQL that must stay inside `storage`.
const SQL_WORDS: &[&str] = &[
    "rusqlite",
    "sqlx",
    "SELECT ",
    "INSERT INTO",
    "UPDATE jobs",
    "DELETE FROM",
];

/// HTTP that must stay inside `http`.
const HTTP_WORDS: &[&str] = &["axum", "tower_http", "hyper"];

/// Files, sockets, processes, environment, console and runtime: what a pure library part does
/// not touch.
const NO_IO: &[&str] = &[
    "std::fs",
    "std::net",
    "std::process",
    "std::env",
    "std::io::stdin",
    "println!",
    "eprintln!",
    "tokio",
    "tracing",
];

/// The wall clock.
const CLOCK: &[&str] = &["std::time", "Instant::now", "SystemTime"];

/// Child processes and the environment: the binary's business.
const PROCESS_ENV: &[&str] = &["std::process", "std::env", "Command::new"];

/// One row of the table.
struct Rule {
    /// A top-level module of `src/` (`atlas` is `src/atlas/`, `unwrap` is `src/unwrap.rs`); `lib`
    /// is `src/lib.rs` alone, `main` is `src/main.rs` alone, `cli` the binary's `src/cli/`.
    module: &'static str,
    /// The crate modules it may name besides itself (in the binary, `texatlas::x` names `x`).
    may_use: &'static [&'static str],
    /// Words its code (comments removed) must not contain.
    forbidden: &'static [&'static [&'static str]],
}

const RULES: &[Rule] = &[
    // The geometry core: pure computation, deterministic, no IO.
    Rule {
        module: "mesh",
        may_use: &[],
        forbidden: &[CORE_FORBIDDEN],
    },
    Rule {
        module: "numerics",
        may_use: &[],
        forbidden: &[CORE_FORBIDDEN],
    },
    Rule {
        module: "atlas",
        may_use: &["mesh", "numerics"],
        forbidden: &[CORE_FORBIDDEN],
    },
    // The glTF codec: bytes in, bytes out; external resources are handed to it.
    Rule {
        module: "gltf_io",
        may_use: &["mesh"],
        forbidden: &[NO_IO, CLOCK, HTTP_WORDS, SQL_WORDS],
    },
    // The contract types (serde): built from the domain, never from a shell.
    Rule {
        module: "api",
        may_use: &["mesh", "atlas", "gltf_io", "inspect"],
        forbidden: &[NO_IO, CLOCK, HTTP_WORDS, SQL_WORDS],
    },
    // The shells over the pipeline shared by the CLI and the service.
    Rule {
        module: "inspect",
        may_use: &["mesh", "gltf_io", "api"],
        forbidden: &[
            &["std::net", "tokio", "tracing"],
            PROCESS_ENV,
            CLOCK,
            HTTP_WORDS,
            SQL_WORDS,
        ],
    },
    Rule {
        module: "unwrap",
        may_use: &["mesh", "atlas", "gltf_io", "api"],
        // The stage timings read the clock.
        forbidden: &[
            &[
                "std::fs",
                "std::net",
                "tokio",
                "tracing",
                "println!",
                "eprintln!",
            ],
            PROCESS_ENV,
            HTTP_WORDS,
            SQL_WORDS,
        ],
    },
    Rule {
        module: "preview",
        may_use: &["mesh", "atlas"],
        forbidden: &[NO_IO, CLOCK, HTTP_WORDS, SQL_WORDS],
    },
    // The service: storage knows nothing of the crate, jobs no HTTP and no SQL, http no SQL.
    Rule {
        module: "storage",
        may_use: &[],
        forbidden: &[
            &[
                "axum",
                "tower_http",
                "hyper",
                "tokio",
                "crate::http",
                "crate::jobs",
            ],
            PROCESS_ENV,
        ],
    },
    Rule {
        module: "jobs",
        may_use: &["atlas", "gltf_io", "storage", "api", "unwrap", "preview"],
        forbidden: &[HTTP_WORDS, SQL_WORDS, PROCESS_ENV],
    },
    Rule {
        module: "http",
        may_use: &["jobs", "storage", "api"],
        forbidden: &[SQL_WORDS, PROCESS_ENV],
    },
    Rule {
        module: "service",
        may_use: &["http", "jobs", "storage"],
        forbidden: &[SQL_WORDS, PROCESS_ENV],
    },
    // The library root only declares modules.
    Rule {
        module: "lib",
        may_use: &[],
        forbidden: &[NO_IO, CLOCK, HTTP_WORDS, SQL_WORDS],
    },
    // The binary: thin, the library does the work.
    Rule {
        module: "main",
        may_use: &["cli"],
        forbidden: &[HTTP_WORDS, SQL_WORDS],
    },
    Rule {
        module: "cli",
        may_use: &[
            "api", "atlas", "gltf_io", "http", "inspect", "jobs", "mesh", "preview", "service",
            "unwrap",
        ],
        forbidden: &[HTTP_WORDS, SQL_WORDS],
    },
];

/// The files outside `api` that use the `serde` crate, and why. A listed file that no longer
/// uses it (or is gone) fails the check, so the list only shrinks.
const SERDE_EXCEPTIONS: &[(&str, &str)] = &[
    (
        "jobs/service.rs",
        "the job store's own input/result manifests, serialised into its rows (not an API)",
    ),
    (
        "http/handlers.rs",
        "query-string structs for axum's `Query` extractor (`deny_unknown_fields`)",
    ),
];

/// The most lines a production file may have.
const LINE_CAP: usize = 1000;

/// Production files over [`LINE_CAP`] today, with their line counts: they may only shrink (lower
/// the count when they do; remove the row when a file is under the cap).
const OVER_CAP: &[(&str, usize)] = &[];

// ---- The source model ----

/// A source file: its path under `src/` (`/`-separated) and its text.
struct Source {
    rel: String,
    text: String,
}

/// Every `.rs` file under `src/`.
fn read_src() -> Vec<Source> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<Source>) {
        let mut entries: Vec<_> = std::fs::read_dir(dir)
            .unwrap_or_else(|e| panic!("reading {}: {e}", dir.display()))
            .map(|e| e.expect("dir entry").path())
            .collect();
        entries.sort();
        for path in entries {
            if path.is_dir() {
                walk(root, &path, out);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let rel = path.strip_prefix(root).expect("under src");
                let rel = rel
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy().into_owned())
                    .collect::<Vec<_>>()
                    .join("/");
                let text = std::fs::read_to_string(&path).expect("read source");
                out.push(Source { rel, text });
            }
        }
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut out = Vec::new();
    walk(&root, &root, &mut out);
    assert!(!out.is_empty(), "no sources under {}", root.display());
    out
}

/// Synthetic sources for the self-tests.
fn synthetic(files: &[(&str, &str)]) -> Vec<Source> {
    files
        .iter()
        .map(|(rel, text)| Source {
            rel: rel.to_string(),
            text: text.to_string(),
        })
        .collect()
}

/// `text` with comments blanked (`code`), and also with string and char literals blanked
/// (`bare`); both keep every newline, so line numbers hold.
fn strip(text: &str) -> (String, String) {
    let c: Vec<char> = text.chars().collect();
    let (mut code, mut bare) = (String::new(), String::new());
    let blank = |ch: char| if ch == '\n' { '\n' } else { ' ' };
    let ident = |ch: char| ch.is_alphanumeric() || ch == '_';
    let mut i = 0;
    while i < c.len() {
        let prev_ident = i > 0 && ident(c[i - 1]);
        if c[i] == '/' && c.get(i + 1) == Some(&'/') {
            while i < c.len() && c[i] != '\n' {
                code.push(' ');
                bare.push(' ');
                i += 1;
            }
        } else if c[i] == '/' && c.get(i + 1) == Some(&'*') {
            let mut depth = 0;
            loop {
                if i >= c.len() {
                    break;
                }
                if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                    depth += 1;
                    code.push_str("  ");
                    bare.push_str("  ");
                    i += 2;
                } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    code.push_str("  ");
                    bare.push_str("  ");
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    code.push(blank(c[i]));
                    bare.push(blank(c[i]));
                    i += 1;
                }
            }
        } else if c[i] == 'r'
            && !prev_ident
            && matches!(c.get(i + 1), Some('"') | Some('#'))
            && c.get(i + 1 + c[i + 1..].iter().take_while(|&&x| x == '#').count()) == Some(&'"')
        {
            // A raw string r#"…"#.
            let hashes = c[i + 1..].iter().take_while(|&&x| x == '#').count();
            let open = i + 1 + hashes;
            for &ch in &c[i..=open] {
                code.push(ch);
                bare.push(ch);
            }
            i = open + 1;
            while i < c.len() {
                if c[i] == '"'
                    && c[i + 1..]
                        .iter()
                        .take(hashes)
                        .filter(|&&x| x == '#')
                        .count()
                        == hashes
                {
                    for &ch in &c[i..=i + hashes] {
                        code.push(ch);
                        bare.push(ch);
                    }
                    i += hashes + 1;
                    break;
                }
                code.push(c[i]);
                bare.push(blank(c[i]));
                i += 1;
            }
        } else if c[i] == '"' {
            code.push('"');
            bare.push('"');
            i += 1;
            while i < c.len() && c[i] != '"' {
                let n = if c[i] == '\\' { 2 } else { 1 };
                for &ch in &c[i..(i + n).min(c.len())] {
                    code.push(ch);
                    bare.push(blank(ch));
                }
                i += n;
            }
            if i < c.len() {
                code.push('"');
                bare.push('"');
                i += 1;
            }
        } else if c[i] == '\'' && (c.get(i + 1) == Some(&'\\') || c.get(i + 2) == Some(&'\'')) {
            // A char literal ('x', '\n', '\''); otherwise a lifetime.
            let mut j = i + 1;
            if c[j] == '\\' {
                j += 2;
            } else {
                j += 1;
            }
            while j < c.len() && c[j] != '\'' {
                j += 1;
            }
            for &ch in &c[i..=j.min(c.len() - 1)] {
                code.push(ch);
                bare.push(' ');
            }
            i = j + 1;
        } else {
            code.push(c[i]);
            bare.push(c[i]);
            i += 1;
        }
    }
    (code, bare)
}

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Ident(String),
    PathSep,
    Punct(char),
}

/// The tokens of comment- and literal-free code, each with its 1-based line.
fn tokens(bare: &str) -> Vec<(Tok, usize)> {
    let c: Vec<char> = bare.chars().collect();
    let mut out = Vec::new();
    let (mut i, mut line) = (0, 1);
    while i < c.len() {
        let ch = c[i];
        if ch == '\n' {
            line += 1;
            i += 1;
        } else if ch.is_whitespace() {
            i += 1;
        } else if ch.is_alphanumeric() || ch == '_' {
            let start = i;
            while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                i += 1;
            }
            let mut word: String = c[start..i].iter().collect();
            if word == "r" && c.get(i) == Some(&'#') {
                // A raw identifier r#name.
                i += 1;
                let s = i;
                while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                    i += 1;
                }
                word = c[s..i].iter().collect();
            }
            out.push((Tok::Ident(word), line));
        } else if ch == ':' && c.get(i + 1) == Some(&':') {
            out.push((Tok::PathSep, line));
            i += 2;
        } else {
            out.push((Tok::Punct(ch), line));
            i += 1;
        }
    }
    out
}

/// A path named in the code: the module it is named from and its segments, as written.
struct Named {
    file: usize,
    line: usize,
    from: Vec<String>,
    segs: Vec<String>,
}

/// One `use` leaf: the module it is in, the name it binds (`None` for a glob) and the path.
struct Import {
    module: Vec<String>,
    name: Option<String>,
    segs: Vec<String>,
}

/// A parsed file.
struct File {
    rel: String,
    /// Its module, `["crate", …]` in the library, `["main", …]` in the binary.
    module: Vec<String>,
    /// Its row in [`RULES`].
    top: String,
    lines: usize,
    /// Comment-free code, line by line (1-based).
    code: Vec<String>,
}

/// The parsed sources: files, modules, the paths they name, imports and item names.
struct Crate {
    files: Vec<File>,
    modules: BTreeSet<Vec<String>>,
    named: Vec<Named>,
    imports: Vec<Import>,
    items: BTreeMap<Vec<String>, BTreeSet<String>>,
    /// Modules declared under `#[cfg(test)]` (or any cfg naming `test`).
    test_modules: BTreeSet<Vec<String>>,
    /// The binary's top-level modules (declared in `main.rs`).
    bin_modules: BTreeSet<String>,
}

fn path_of(rel: &str, bin_modules: &BTreeSet<String>) -> Vec<String> {
    let parts: Vec<&str> = rel.trim_end_matches(".rs").split('/').collect();
    let root = if rel == "main.rs" || bin_modules.contains(parts[0]) {
        "main"
    } else {
        "crate"
    };
    let mut m = vec![root.to_string()];
    for (i, p) in parts.iter().enumerate() {
        let last = i + 1 == parts.len();
        if last && (*p == "mod" || (i == 0 && (*p == "lib" || *p == "main"))) {
            break;
        }
        m.push(p.to_string());
    }
    m
}

fn top_of(module: &[String]) -> String {
    match (module[0].as_str(), module.get(1)) {
        ("crate", None) => "lib".into(),
        (root, None) => root.into(),
        (_, Some(t)) => t.clone(),
    }
}

/// Reads a `use` tree starting at `i` (after `use` or a `,`/`{`), appending its leaves.
fn use_tree(
    toks: &[(Tok, usize)],
    mut i: usize,
    prefix: &[String],
    out: &mut Vec<(Option<String>, Vec<String>)>,
) -> usize {
    let mut segs = prefix.to_vec();
    if toks.get(i).map(|t| &t.0) == Some(&Tok::PathSep) {
        // `::std::…`: an extern path.
        segs.push("::".into());
        i += 1;
    }
    loop {
        match toks.get(i).map(|t| &t.0) {
            Some(Tok::Ident(w)) if w != "as" => {
                segs.push(w.clone());
                i += 1;
            }
            Some(Tok::Punct('*')) => {
                out.push((None, segs));
                return i + 1;
            }
            Some(Tok::Punct('{')) => {
                i += 1;
                loop {
                    match toks.get(i).map(|t| &t.0) {
                        Some(Tok::Punct('}')) => return i + 1,
                        Some(Tok::Punct(',')) => i += 1,
                        None => return i,
                        _ => i = use_tree(toks, i, &segs, out),
                    }
                }
            }
            _ => {
                if segs.last().is_some_and(|s| s == "self") {
                    segs.pop();
                }
                let mut name = segs.last().cloned();
                if let (Some(Tok::Ident(a)), Some(Tok::Ident(b))) =
                    (toks.get(i).map(|t| &t.0), toks.get(i + 1).map(|t| &t.0))
                {
                    if a == "as" {
                        name = Some(b.clone());
                        i += 2;
                    }
                }
                if !segs.is_empty() {
                    out.push((name, segs));
                }
                return i;
            }
        }
        if toks.get(i).map(|t| &t.0) == Some(&Tok::PathSep) {
            i += 1;
        }
    }
}

impl Crate {
    fn parse(sources: &[Source]) -> Crate {
        // The binary's modules: the `mod x;` of main.rs.
        let mut bin_modules = BTreeSet::new();
        if let Some(main) = sources.iter().find(|s| s.rel == "main.rs") {
            let toks = tokens(&strip(&main.text).1);
            for w in toks.windows(3) {
                if let (Tok::Ident(m), Tok::Ident(name), Tok::Punct(';')) =
                    (&w[0].0, &w[1].0, &w[2].0)
                {
                    if m == "mod" {
                        bin_modules.insert(name.clone());
                    }
                }
            }
        }
        let mut krate = Crate {
            files: Vec::new(),
            modules: BTreeSet::new(),
            named: Vec::new(),
            imports: Vec::new(),
            items: BTreeMap::new(),
            test_modules: BTreeSet::new(),
            bin_modules,
        };
        for s in sources {
            let m = path_of(&s.rel, &krate.bin_modules);
            for k in 1..=m.len() {
                krate.modules.insert(m[..k].to_vec());
            }
        }
        for (fi, s) in sources.iter().enumerate() {
            let (code, bare) = strip(&s.text);
            let module = path_of(&s.rel, &krate.bin_modules);
            krate.files.push(File {
                rel: s.rel.clone(),
                top: top_of(&module),
                module: module.clone(),
                lines: s.text.lines().count(),
                code: code.lines().map(str::to_string).collect(),
            });
            krate.scan(fi, &module, &tokens(&bare));
        }
        krate
    }

    /// One pass over a file's tokens: inline modules, `mod x;` declarations under a test cfg,
    /// `use` trees, paths from `crate`/`super`/`self`/`texatlas`, and item names.
    fn scan(&mut self, fi: usize, file_module: &[String], toks: &[(Tok, usize)]) {
        let ident = |i: usize| match toks.get(i) {
            Some((Tok::Ident(w), _)) => Some(w.as_str()),
            _ => None,
        };
        let punct = |i: usize, p: char| matches!(toks.get(i), Some((Tok::Punct(q), _)) if *q == p);
        let mut stack: Vec<(String, usize)> = Vec::new();
        let mut depth = 0usize;
        let mut cfg_test = false;
        let mut i = 0;
        while i < toks.len() {
            let current: Vec<String> = file_module
                .iter()
                .cloned()
                .chain(stack.iter().map(|(n, _)| n.clone()))
                .collect();
            let line = toks[i].1;
            match &toks[i].0 {
                Tok::Punct('#') => {
                    // An attribute: note a cfg naming `test`.
                    let mut j = i + 1;
                    if punct(j, '!') {
                        j += 1;
                    }
                    if punct(j, '[') {
                        let mut level = 0;
                        let mut words = BTreeSet::new();
                        while j < toks.len() {
                            match &toks[j].0 {
                                Tok::Punct('[') => level += 1,
                                Tok::Punct(']') => {
                                    level -= 1;
                                    if level == 0 {
                                        break;
                                    }
                                }
                                Tok::Ident(w) => {
                                    words.insert(w.clone());
                                }
                                _ => {}
                            }
                            j += 1;
                        }
                        if words.contains("cfg") && words.contains("test") && !words.contains("not")
                        {
                            cfg_test = true;
                        }
                        i = j + 1;
                        continue;
                    }
                    i += 1;
                }
                Tok::Punct('{') => {
                    depth += 1;
                    cfg_test = false;
                    i += 1;
                }
                Tok::Punct('}') => {
                    if stack.last().is_some_and(|(_, d)| *d == depth) {
                        stack.pop();
                    }
                    depth = depth.saturating_sub(1);
                    cfg_test = false;
                    i += 1;
                }
                Tok::Punct(';') => {
                    cfg_test = false;
                    i += 1;
                }
                Tok::Ident(w) if w == "mod" && ident(i + 1).is_some() => {
                    let name = ident(i + 1).expect("name").to_string();
                    let mut child = current.clone();
                    child.push(name.clone());
                    if punct(i + 2, '{') {
                        stack.push((name.clone(), depth + 1));
                        self.modules.insert(child.clone());
                    }
                    if cfg_test {
                        self.test_modules.insert(child);
                    }
                    self.items.entry(current).or_default().insert(name);
                    i += 2;
                }
                Tok::Ident(w) if w == "use" => {
                    let mut leaves = Vec::new();
                    let end = use_tree(toks, i + 1, &[], &mut leaves);
                    for (name, segs) in leaves {
                        self.named.push(Named {
                            file: fi,
                            line,
                            from: current.clone(),
                            segs: segs.clone(),
                        });
                        self.imports.push(Import {
                            module: current.clone(),
                            name,
                            segs,
                        });
                    }
                    i = end.max(i + 1);
                }
                Tok::Ident(w)
                    if matches!(w.as_str(), "crate" | "super" | "self" | "texatlas")
                        && matches!(toks.get(i + 1), Some((Tok::PathSep, _))) =>
                {
                    let mut segs = vec![w.clone()];
                    let mut j = i + 1;
                    while matches!(toks.get(j), Some((Tok::PathSep, _))) {
                        match ident(j + 1) {
                            Some(s) => {
                                segs.push(s.to_string());
                                j += 2;
                            }
                            None => break,
                        }
                    }
                    self.named.push(Named {
                        file: fi,
                        line,
                        from: current,
                        segs,
                    });
                    i = j;
                }
                Tok::Ident(w)
                    if matches!(
                        w.as_str(),
                        "struct" | "enum" | "fn" | "trait" | "type" | "const" | "static" | "union"
                    ) =>
                {
                    if let Some(name) = ident(i + 1) {
                        self.items
                            .entry(current)
                            .or_default()
                            .insert(name.to_string());
                    }
                    i += 1;
                }
                Tok::Ident(w) if w == "macro_rules" && punct(i + 1, '!') => {
                    if let Some(name) = ident(i + 2) {
                        self.items
                            .entry(current)
                            .or_default()
                            .insert(name.to_string());
                    }
                    i += 2;
                }
                _ => i += 1,
            }
        }
    }

    /// The absolute path of `segs` named from module `from`; `None` for an extern crate.
    fn absolute(&self, from: &[String], segs: &[String]) -> Option<Vec<String>> {
        let first = segs.first()?;
        let mut out: Vec<String>;
        let mut rest = &segs[1..];
        match first.as_str() {
            "crate" => out = vec![from[0].clone()],
            "self" => out = from.to_vec(),
            "super" => {
                out = from[..from.len().saturating_sub(1)].to_vec();
                while rest.first().is_some_and(|s| s == "super") {
                    out.pop();
                    rest = &rest[1..];
                }
                if out.is_empty() {
                    return None;
                }
            }
            "texatlas" if from[0] == "main" => out = vec!["crate".to_string()],
            name => {
                // A relative path to a child module (uniform paths).
                let mut child = from.to_vec();
                child.push(name.to_string());
                if !self.modules.contains(&child) {
                    return None;
                }
                out = from.to_vec();
                rest = segs;
            }
        }
        out.extend(rest.iter().cloned());
        Some(out)
    }

    /// The module that an absolute path refers to, following imports and re-exports.
    fn resolve(&self, path: &[String], budget: usize) -> Vec<String> {
        let k = (1..=path.len())
            .rev()
            .find(|&k| self.modules.contains(&path[..k]))
            .unwrap_or(1);
        let module = path[..k].to_vec();
        let Some(name) = path.get(k) else {
            return module;
        };
        if budget == 0
            || self
                .items
                .get(&module)
                .is_some_and(|items| items.contains(name))
        {
            return module;
        }
        let follow = |target: Vec<String>| {
            let mut next = target;
            next.extend(path[k + 1..].iter().cloned());
            self.resolve(&next, budget - 1)
        };
        for imp in self.imports.iter().filter(|imp| imp.module == module) {
            if imp.name.as_deref() == Some(name.as_str()) {
                if let Some(target) = self.absolute(&module, &imp.segs) {
                    return follow(target);
                }
            }
        }
        for imp in self
            .imports
            .iter()
            .filter(|imp| imp.module == module && imp.name.is_none())
        {
            let Some(glob) = self.absolute(&module, &imp.segs) else {
                continue;
            };
            let glob = self.resolve(&glob, budget - 1);
            let defines = self
                .items
                .get(&glob)
                .is_some_and(|items| items.contains(name))
                || self
                    .imports
                    .iter()
                    .any(|i| i.module == glob && i.name.as_deref() == Some(name.as_str()));
            if defines && glob != module {
                let mut target = glob;
                target.push(name.clone());
                return follow(target);
            }
        }
        module
    }

    /// The file and line of a named path, with its code.
    fn locate(&self, n: &Named) -> String {
        let f = &self.files[n.file];
        let code = f.code.get(n.line - 1).map_or("", |l| l.trim());
        format!("{}:{}: {code}", f.rel, n.line)
    }
}

// ---- The checks: each returns its violations, one line each ----

/// Check 1: Every top-level module has a row, and every row a module.
fn check_table_covers(krate: &Crate) -> Vec<String> {
    let tops: BTreeSet<String> = krate.files.iter().map(|f| f.top.clone()).collect();
    let rows: BTreeSet<String> = RULES.iter().map(|r| r.module.to_string()).collect();
    let mut found: Vec<String> = tops
        .difference(&rows)
        .map(|t| format!("module `{t}` has no row in RULES"))
        .collect();
    found.extend(
        rows.difference(&tops)
            .map(|r| format!("RULES has a row for `{r}`, which is not a module of src/")),
    );
    found
}

fn rule(module: &str) -> Option<&'static Rule> {
    RULES.iter().find(|r| r.module == module)
}

/// Check 2: Every crate module a module names is allowed by its row.
fn check_dependencies(krate: &Crate) -> Vec<String> {
    let mut found = Vec::new();
    for n in &krate.named {
        let file = &krate.files[n.file];
        let Some(rule) = rule(&file.top) else {
            continue;
        };
        let Some(path) = krate.absolute(&n.from, &n.segs) else {
            continue;
        };
        // The top-level module named: the path's first segment when it is a module, else the root.
        let named = if path.len() > 1 && krate.modules.contains(&path[..2]) {
            top_of(&path[..2])
        } else {
            top_of(&path[..1])
        };
        if named != file.top && !rule.may_use.contains(&named.as_str()) {
            found.push(format!(
                "`{}` depends on `{named}`: {}",
                file.top,
                krate.locate(n)
            ));
        }
    }
    found
}

/// Check 3: No forbidden word of a module's row in its code.
fn check_words(krate: &Crate) -> Vec<String> {
    let mut found = Vec::new();
    for file in &krate.files {
        let Some(rule) = rule(&file.top) else {
            continue;
        };
        for (i, code) in file.code.iter().enumerate() {
            for word in rule.forbidden.iter().flat_map(|group| group.iter()) {
                if code.contains(word) {
                    found.push(format!(
                        "`{}` uses `{word}`: {}:{}: {}",
                        file.top,
                        file.rel,
                        i + 1,
                        code.trim()
                    ));
                }
            }
        }
    }
    found
}

/// Whether `code` has `word` as a whole identifier (so `serde` is not `serde_json`).
fn has_ident(code: &str, word: &str) -> bool {
    let ident = |c: char| c.is_alphanumeric() || c == '_';
    code.match_indices(word).any(|(at, _)| {
        !code[..at].chars().next_back().is_some_and(ident)
            && !code[at + word.len()..].chars().next().is_some_and(ident)
    })
}

/// Check 4: The `serde` crate only in `api` and the listed exceptions, which must still need it.
fn check_serde(krate: &Crate, exceptions: &[(&str, &str)]) -> Vec<String> {
    let mut found = Vec::new();
    let mut users = BTreeSet::new();
    for file in &krate.files {
        for (i, code) in file.code.iter().enumerate() {
            if has_ident(code, "serde") {
                users.insert(file.rel.as_str());
                if file.top != "api" && !exceptions.iter().any(|(rel, _)| *rel == file.rel) {
                    found.push(format!(
                        "serde outside api: {}:{}: {}",
                        file.rel,
                        i + 1,
                        code.trim()
                    ));
                }
            }
        }
    }
    for (rel, _) in exceptions {
        if !users.contains(rel) {
            found.push(format!(
                "SERDE_EXCEPTIONS lists {rel}, which does not use serde (any more): remove it"
            ));
        }
    }
    found
}

/// Check 5: Only `storage` names rusqlite, only `http` names axum or tower-http.
fn check_sql_and_http_homes(krate: &Crate) -> Vec<String> {
    let mut found = Vec::new();
    for file in &krate.files {
        for (i, code) in file.code.iter().enumerate() {
            if file.top != "storage" && code.contains("rusqlite") {
                found.push(format!("{}:{}: rusqlite outside storage", file.rel, i + 1));
            }
            if file.top != "http" && (code.contains("axum") || code.contains("tower_http")) {
                found.push(format!("{}:{}: axum outside http", file.rel, i + 1));
            }
        }
    }
    found
}

/// Check 6: The module cycles: at every module, the references between its children (re-exports
/// followed), strongly connected components of two or more, each printed as a cycle with the
/// first reference of each edge.
fn check_cycles(krate: &Crate) -> Vec<String> {
    // parent -> (child a -> child b -> first reference)
    let mut levels: BTreeMap<Vec<String>, BTreeMap<String, BTreeMap<String, String>>> =
        BTreeMap::new();
    for n in &krate.named {
        if is_test_module(krate, &n.from) {
            // Test code is not in the module graph: tests may use fixtures of their siblings.
            continue;
        }
        let Some(path) = krate.absolute(&n.from, &n.segs) else {
            continue;
        };
        let to = krate.resolve(&path, 16);
        let from = &n.from;
        let common = from.iter().zip(&to).take_while(|(a, b)| a == b).count();
        if common == 0 || common == from.len() || common == to.len() {
            // Across crates, or between a module and its ancestor or descendant.
            continue;
        }
        levels
            .entry(from[..common].to_vec())
            .or_default()
            .entry(from[common].clone())
            .or_default()
            .entry(to[common].clone())
            .or_insert_with(|| krate.locate(n));
    }
    let mut found = Vec::new();
    for (parent, edges) in &levels {
        for cycle in cycles(edges) {
            let mut text = format!(
                "module cycle in `{}`: {}",
                parent.join("::"),
                cycle.join(" -> ")
            );
            for pair in cycle.windows(2) {
                text.push_str(&format!(
                    "\n    {} -> {}: {}",
                    pair[0], pair[1], edges[&pair[0]][&pair[1]]
                ));
            }
            found.push(text);
        }
    }
    found
}

/// One cycle (first node repeated at the end) per strongly connected component of two or more
/// nodes of `edges` (Tarjan).
fn cycles(edges: &BTreeMap<String, BTreeMap<String, String>>) -> Vec<Vec<String>> {
    struct Tarjan<'a> {
        edges: &'a BTreeMap<String, BTreeMap<String, String>>,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on_stack: BTreeSet<&'a str>,
        sccs: Vec<Vec<&'a str>>,
    }
    impl<'a> Tarjan<'a> {
        fn visit(&mut self, v: &'a str) {
            let i = self.index.len();
            self.index.insert(v, i);
            self.low.insert(v, i);
            self.stack.push(v);
            self.on_stack.insert(v);
            let edges = self.edges;
            for w in edges.get(v).into_iter().flat_map(|m| m.keys()) {
                let w = w.as_str();
                if !self.index.contains_key(w) {
                    self.visit(w);
                    let lw = self.low[w];
                    let lv = self.low.get_mut(v).expect("visited");
                    *lv = (*lv).min(lw);
                } else if self.on_stack.contains(w) {
                    let iw = self.index[w];
                    let lv = self.low.get_mut(v).expect("visited");
                    *lv = (*lv).min(iw);
                }
            }
            if self.low[v] == self.index[v] {
                let mut scc = Vec::new();
                while let Some(w) = self.stack.pop() {
                    self.on_stack.remove(w);
                    scc.push(w);
                    if w == v {
                        break;
                    }
                }
                self.sccs.push(scc);
            }
        }
    }
    let mut t = Tarjan {
        edges,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        sccs: Vec::new(),
    };
    for v in edges.keys() {
        if !t.index.contains_key(v.as_str()) {
            t.visit(v);
        }
    }
    let mut out = Vec::new();
    for scc in t.sccs.into_iter().filter(|s| s.len() > 1) {
        // Walk inside the component from its smallest node until a node repeats.
        let members: BTreeSet<&str> = scc.iter().copied().collect();
        let start = *members.iter().next().expect("non-empty");
        let mut path = vec![start];
        loop {
            let here = *path.last().expect("non-empty");
            let next = edges[here]
                .keys()
                .map(String::as_str)
                .find(|w| members.contains(w))
                .expect("a component member has an edge inside it");
            if let Some(at) = path.iter().position(|&p| p == next) {
                let mut cycle: Vec<String> = path[at..].iter().map(|s| s.to_string()).collect();
                cycle.push(next.to_string());
                out.push(cycle);
                break;
            }
            path.push(next);
        }
    }
    out
}

/// Whether `module` is test code: it or an ancestor is declared under a test cfg.
fn is_test_module(krate: &Crate, module: &[String]) -> bool {
    (1..=module.len()).any(|k| krate.test_modules.contains(&module[..k]))
}

/// Whether `file` is test code.
fn is_test_file(krate: &Crate, file: &File) -> bool {
    is_test_module(krate, &file.module)
}

/// Check 7: The line cap, with its ratchet.
fn check_line_cap(krate: &Crate, cap: usize, over_cap: &[(&str, usize)]) -> Vec<String> {
    let mut found = Vec::new();
    for file in krate.files.iter().filter(|f| !is_test_file(krate, f)) {
        match over_cap.iter().find(|(rel, _)| *rel == file.rel) {
            None if file.lines > cap => found.push(format!(
                "{} has {} lines, over the cap of {cap}: split it",
                file.rel, file.lines
            )),
            None => {}
            Some((_, _)) if file.lines <= cap => found.push(format!(
                "{} has {} lines, under the cap of {cap}: remove it from OVER_CAP",
                file.rel, file.lines
            )),
            Some((_, listed)) if file.lines > *listed => found.push(format!(
                "{} grew from {listed} to {} lines; files over the cap of {cap} may only shrink",
                file.rel, file.lines
            )),
            Some((_, listed)) if file.lines < *listed => found.push(format!(
                "{} shrank from {listed} to {} lines: lower its OVER_CAP entry to {}",
                file.rel, file.lines, file.lines
            )),
            Some(_) => {}
        }
    }
    for (rel, _) in over_cap {
        if !krate.files.iter().any(|f| f.rel == *rel) {
            found.push(format!(
                "OVER_CAP lists {rel}, which is not a file of src/ (any more): remove it"
            ));
        }
    }
    found
}

fn assert_none(what: &str, found: Vec<String>) {
    assert!(
        found.is_empty(),
        "{what}: {} violation(s):\n{}",
        found.len(),
        found.join("\n")
    );
}

// ---- The rules on src/ ----

#[test]
fn every_top_level_module_has_a_rule() {
    assert_none("RULES", check_table_covers(&Crate::parse(&read_src())));
}

#[test]
fn each_module_names_only_the_crate_modules_its_rule_allows() {
    assert_none(
        "dependencies",
        check_dependencies(&Crate::parse(&read_src())),
    );
}

#[test]
fn each_module_avoids_its_forbidden_words() {
    assert_none("forbidden words", check_words(&Crate::parse(&read_src())));
}

#[test]
fn serde_only_in_api_and_the_listed_exceptions() {
    assert_none(
        "serde",
        check_serde(&Crate::parse(&read_src()), SERDE_EXCEPTIONS),
    );
}

#[test]
fn only_storage_names_rusqlite_and_only_http_names_axum() {
    assert_none(
        "SQL and HTTP homes",
        check_sql_and_http_homes(&Crate::parse(&read_src())),
    );
}

#[test]
fn no_module_cycle_at_any_level() {
    assert_none("module cycles", check_cycles(&Crate::parse(&read_src())));
}

#[test]
fn no_production_file_over_the_line_cap() {
    assert_none(
        "line cap",
        check_line_cap(&Crate::parse(&read_src()), LINE_CAP, OVER_CAP),
    );
}

#[test]
fn the_checker_reads_the_real_tree() {
    // The checks above pass vacuously on an empty or misread tree: make sure they see it.
    let krate = Crate::parse(&read_src());
    assert!(krate.files.len() > 50, "{} files", krate.files.len());
    assert!(krate.named.len() > 500, "{} paths", krate.named.len());
    for rel in ["lib.rs", "main.rs", "atlas/pack/hole.rs", "cli/mod.rs"] {
        assert!(krate.files.iter().any(|f| f.rel == rel), "{rel} not read");
    }
    // `gltf_io` legitimately names `crate::mesh` and uses serde_json; checked against the core's
    // row it must fail, as the old per-module checker's self-test did.
    let mut as_core = Crate::parse(&read_src());
    for f in &mut as_core.files {
        if f.top == "gltf_io" {
            f.top = "mesh".into();
        }
    }
    assert!(!check_dependencies(&as_core).is_empty());
    assert!(!check_words(&as_core).is_empty());
}

// ---- Self-tests: each check fails on a planted violation ----

/// A small well-formed tree: `mesh`, `atlas` (with a `pack` folder), `api`, `http` and the binary.
fn clean_tree() -> Vec<(&'static str, &'static str)> {
    vec![
        ("lib.rs", "pub mod api;\npub mod atlas;\npub mod http;\npub mod mesh;\n"),
        ("main.rs", "mod cli;\nfn main() { cli::run(); }\n"),
        ("cli/mod.rs", "use texatlas::atlas::generate;\npub fn run() { generate(); }\n"),
        ("mesh/mod.rs", "pub struct Mesh;\n"),
        (
            "atlas/mod.rs",
            "pub mod pack;\nuse crate::mesh::Mesh;\npub use pack::Occupancy;\n\
             /// Uses std::fs in a comment only, and \"tokio\" nowhere.\npub fn generate() {}\n",
        ),
        ("atlas/pack/mod.rs", "pub mod hole;\npub mod horizon;\npub use hole::Occupancy;\n"),
        ("atlas/pack/hole.rs", "pub struct Occupancy;\n#[cfg(test)]\nmod tests {\n    use super::*;\n    use super::super::horizon::Placement;\n}\n"),
        ("atlas/pack/horizon.rs", "use super::hole::Occupancy;\npub struct Placement(Occupancy);\n"),
        (
            "api/mod.rs",
            "use serde::Serialize;\nuse crate::atlas::generate;\n#[derive(Serialize)]\npub struct Report;\n",
        ),
        ("http/mod.rs", "use axum::Router;\nuse crate::api::Report;\npub fn serve() {}\n"),
    ]
}

/// The rows of the clean tree's modules, as the real checks see them.
fn clean() -> Crate {
    Crate::parse(&synthetic(&clean_tree()))
}

/// The clean tree with `rel` replaced (or added) with `text`.
fn planted(rel: &'static str, text: &'static str) -> Crate {
    let mut files = clean_tree();
    files.retain(|(r, _)| *r != rel);
    files.push((rel, text));
    Crate::parse(&synthetic(&files))
}

#[test]
fn self_test_the_clean_tree_passes() {
    let k = clean();
    // The clean tree's modules are a subset of the table; rows without a module are expected.
    assert!(check_table_covers(&k)
        .iter()
        .all(|v| v.starts_with("RULES has a row")));
    assert_none("dependencies", check_dependencies(&k));
    assert_none("words", check_words(&k));
    assert_none("serde", check_serde(&k, &[]));
    assert_none("homes", check_sql_and_http_homes(&k));
    assert_none("cycles", check_cycles(&k));
    assert_none("cap", check_line_cap(&k, 10, &[]));
}

#[test]
fn self_test_a_module_without_a_rule_is_reported() {
    let v = check_table_covers(&planted("dashboard/mod.rs", "pub fn page() {}\n"));
    assert!(
        v.iter().any(|l| l.contains("`dashboard` has no row")),
        "{v:#?}"
    );
}

#[test]
fn self_test_a_forbidden_dependency_is_reported() {
    // The core naming the service, by `crate::`, by a `use` tree, and by `super::` leaving it.
    let v = check_dependencies(&planted(
        "mesh/mod.rs",
        "pub struct Mesh;\nfn f() { crate::http::serve(); }\n",
    ));
    assert!(
        v.iter().any(|l| l.contains("`mesh` depends on `http`")),
        "{v:#?}"
    );
    let v = check_dependencies(&planted(
        "mesh/mod.rs",
        "use crate::{api::Report, mesh};\npub struct Mesh;\n",
    ));
    assert!(
        v.iter().any(|l| l.contains("`mesh` depends on `api`")),
        "{v:#?}"
    );
    let v = check_dependencies(&planted(
        "atlas/pack/hole.rs",
        "use super::super::super::http::serve;\npub struct Occupancy;\n",
    ));
    assert!(
        v.iter().any(|l| l.contains("`atlas` depends on `http`")),
        "{v:#?}"
    );
    // A quote in a char literal or a raw string starts no string that would hide the path.
    let v = check_dependencies(&planted(
        "mesh/mod.rs",
        "pub struct Mesh;\nfn f() { let _ = ('\"', r#\"\"#); crate::http::serve(); }\n",
    ));
    assert!(
        v.iter().any(|l| l.contains("`mesh` depends on `http`")),
        "{v:#?}"
    );
    // The binary names the library through `texatlas::`.
    let v = check_dependencies(&planted(
        "main.rs",
        "mod cli;\nfn main() { texatlas::http::serve(); }\n",
    ));
    assert!(
        v.iter().any(|l| l.contains("`main` depends on `http`")),
        "{v:#?}"
    );
}

#[test]
fn self_test_a_forbidden_word_is_reported() {
    let v = check_words(&planted(
        "atlas/pack/horizon.rs",
        "use super::hole::Occupancy;\npub struct Placement(Occupancy);\n\
         fn t() { let _ = std::time::Instant::now(); }\n",
    ));
    assert!(
        v.iter().any(|l| l.contains("uses `Instant::now`")),
        "{v:#?}"
    );
    // SQL is a forbidden word of http.
    let v = check_words(&planted(
        "http/mod.rs",
        "fn q() -> &'static str { \"DELETE FROM jobs\" }\n",
    ));
    assert!(v.iter().any(|l| l.contains("uses `DELETE FROM`")), "{v:#?}");
    // A `//` inside a string starts no comment.
    let v = check_words(&planted(
        "http/mod.rs",
        "fn q() -> [&'static str; 2] { [\"http://x\", \"DELETE FROM jobs\"] }\n",
    ));
    assert!(v.iter().any(|l| l.contains("uses `DELETE FROM`")), "{v:#?}");
    // Comments do not count, block comments included.
    let v = check_words(&planted(
        "mesh/mod.rs",
        "/* std::fs /* nested */ tokio */ pub struct Mesh; // println!\n",
    ));
    assert_none("comments only", v);
}

#[test]
fn self_test_serde_outside_api_is_reported_and_stale_exceptions_too() {
    let v = check_serde(
        &planted(
            "http/mod.rs",
            "#[derive(serde::Deserialize)]\nstruct Query;\nfn f() { serde_json::json!(1); }\n",
        ),
        &[],
    );
    assert_eq!(v.len(), 1, "{v:#?}");
    assert!(v[0].contains("serde outside api: http/mod.rs:1"), "{v:#?}");
    // Listed, it passes; a listed file that does not use serde is stale.
    let k = planted("http/mod.rs", "use serde::Deserialize;\n");
    assert_none(
        "listed",
        check_serde(&k, &[("http/mod.rs", "query structs")]),
    );
    let v = check_serde(&clean(), &[("http/mod.rs", "query structs")]);
    assert!(v.iter().any(|l| l.contains("lists http/mod.rs")), "{v:#?}");
    // serde_json and names that merely contain `serde` are not the serde crate.
    let k = planted(
        "http/mod.rs",
        "fn serde_urlencoded_pairs() { serde_json::to_vec(&1); }\n",
    );
    assert_none("serde_json", check_serde(&k, &[]));
}

#[test]
fn self_test_rusqlite_or_axum_out_of_their_home_is_reported() {
    let v = check_sql_and_http_homes(&planted("api/mod.rs", "use rusqlite::Connection;\n"));
    assert!(
        v.iter().any(|l| l.contains("rusqlite outside storage")),
        "{v:#?}"
    );
    let v = check_sql_and_http_homes(&planted("mesh/mod.rs", "use axum::Json;\n"));
    assert!(v.iter().any(|l| l.contains("axum outside http")), "{v:#?}");
}

#[test]
fn self_test_a_cycle_between_sibling_files_is_reported() {
    let v = check_cycles(&planted(
        "atlas/pack/hole.rs",
        "use super::horizon::Placement;\npub struct Occupancy;\n",
    ));
    assert_eq!(v.len(), 1, "{v:#?}");
    assert!(
        v[0].starts_with("module cycle in `crate::atlas::pack`: hole -> horizon -> hole"),
        "{v:#?}"
    );
    assert!(v[0].contains("atlas/pack/hole.rs:1: use super::horizon::Placement;"));
    assert!(v[0].contains("atlas/pack/horizon.rs:1: use super::hole::Occupancy;"));
}

#[test]
fn self_test_a_cycle_through_a_re_export_is_reported() {
    // horizon names `super::Occupancy`, which pack re-exports from hole.
    let v = check_cycles(&planted(
        "atlas/pack/horizon.rs",
        "pub struct Placement(super::Occupancy);\n",
    ));
    assert_none("one-way", v);
    let mut files = clean_tree();
    files.retain(|(r, _)| !r.starts_with("atlas/pack/h"));
    files.push((
        "atlas/pack/hole.rs",
        "pub struct Occupancy(crate::atlas::pack::horizon::Placement);\n",
    ));
    files.push((
        "atlas/pack/horizon.rs",
        "pub struct Placement(Box<super::Occupancy>);\n",
    ));
    let v = check_cycles(&Crate::parse(&synthetic(&files)));
    assert!(
        v.iter().any(|l| l.contains("hole -> horizon -> hole")),
        "{v:#?}"
    );
    // Through a glob re-export too.
    let mut files = clean_tree();
    files.retain(|(r, _)| !r.starts_with("atlas/pack/"));
    files.push((
        "atlas/pack/mod.rs",
        "pub mod hole;\npub mod horizon;\npub use hole::*;\n",
    ));
    files.push((
        "atlas/pack/hole.rs",
        "pub struct Occupancy(super::horizon::Placement);\n",
    ));
    files.push((
        "atlas/pack/horizon.rs",
        "pub struct Placement(Box<super::Occupancy>);\n",
    ));
    let v = check_cycles(&Crate::parse(&synthetic(&files)));
    assert!(
        v.iter().any(|l| l.contains("hole -> horizon -> hole")),
        "{v:#?}"
    );
}

#[test]
fn self_test_a_cycle_between_top_level_modules_is_reported() {
    // api names atlas; atlas naming api closes a cycle (three modules here: mesh -> api too).
    let v = check_cycles(&planted(
        "mesh/mod.rs",
        "pub struct Mesh(crate::api::Report);\n",
    ));
    assert_eq!(v.len(), 1, "{v:#?}");
    assert!(v[0].starts_with("module cycle in `crate`: "), "{v:#?}");
    for m in ["api", "atlas", "mesh"] {
        assert!(v[0].contains(m), "{v:#?}");
    }
}

#[test]
fn self_test_a_test_module_naming_its_parent_is_no_cycle() {
    // The clean tree's hole.rs has `#[cfg(test)] mod tests` naming its sibling horizon, which
    // names hole: test code is not in the module graph, so no cycle. `self::` paths inside an
    // inline module are no edge either.
    let k = planted(
        "atlas/pack/horizon.rs",
        "use super::hole::Occupancy;\npub struct Placement(Occupancy);\nmod inner { use self::x::Y; mod x { pub struct Y; } }\n",
    );
    assert_none("cycles", check_cycles(&k));
}

#[test]
fn self_test_the_line_cap_ratchet() {
    let k = planted("mesh/mod.rs", "pub struct Mesh;\n\n\n\n\n\n\n\n\n\n\n\n");
    // A new file over the cap.
    let v = check_line_cap(&k, 10, &[]);
    assert!(
        v.iter()
            .any(|l| l.contains("mesh/mod.rs has 12 lines, over the cap")),
        "{v:#?}"
    );
    // Listed at its count: passes; listed lower: it grew; listed higher: lower the entry.
    assert_none("listed", check_line_cap(&k, 10, &[("mesh/mod.rs", 12)]));
    let v = check_line_cap(&k, 10, &[("mesh/mod.rs", 11)]);
    assert!(v.iter().any(|l| l.contains("grew from 11 to 12")), "{v:#?}");
    let v = check_line_cap(&k, 10, &[("mesh/mod.rs", 14)]);
    assert!(
        v.iter().any(|l| l.contains("shrank from 14 to 12")),
        "{v:#?}"
    );
    // Listed but under the cap, or gone: remove the row.
    let v = check_line_cap(&clean(), 10, &[("mesh/mod.rs", 12)]);
    assert!(
        v.iter()
            .any(|l| l.contains("under the cap of 10: remove it")),
        "{v:#?}"
    );
    let v = check_line_cap(&clean(), 10, &[("mesh/gone.rs", 12)]);
    assert!(v.iter().any(|l| l.contains("lists mesh/gone.rs")), "{v:#?}");
    // Test files are not production files.
    let k = planted(
        "mesh/mod.rs",
        "pub struct Mesh;\n#[cfg(test)]\nmod tests;\n",
    );
    let mut files = clean_tree();
    files.retain(|(r, _)| *r != "mesh/mod.rs");
    files.push((
        "mesh/mod.rs",
        "pub struct Mesh;\n#[cfg(test)]\nmod tests;\n",
    ));
    files.push(("mesh/tests.rs", "\n\n\n\n\n\n\n\n\n\n\n\n\n\n\n"));
    let with_tests = Crate::parse(&synthetic(&files));
    assert_none("tests.rs", check_line_cap(&with_tests, 10, &[]));
    assert!(check_line_cap(&k, 2, &[])
        .iter()
        .any(|l| l.contains("mesh/mod.rs")));
}
