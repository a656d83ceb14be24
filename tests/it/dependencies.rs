//! Which crate and module may import which (the architecture issue).
//!
//! - Every layer below the binary is a crate (`crates/`): `base` (error,
//!   units, random numbers), `geom`, `io`, `template`, `mech` (the
//!   mechanics library), `pipeline` (which knows no stage) and one crate
//!   per stage (`phantom`, `segment`, `surface`, `landmarks`, `valve`,
//!   `leaflet`, `close`, `report`), then the stage list (`stages`) and the
//!   benchmarks (`bench`). The compiler keeps each from importing
//!   anything its manifest does not name, and [`CRATES`] says which of
//!   each other it may name: no stage crate names another, but for the
//!   test inputs in [`TEST_ONLY`].
//! - In the root package (the binary's library), read from the production
//!   source (test code, `#[cfg(test)]` items and the files they declare,
//!   may reach anywhere): nothing but the CLI (and `main.rs`) imports
//!   `bench` or the stage list (`stages`), so `design` and `inspect` run
//!   stages they are handed; nothing imports `cli`. A new wrong-way import
//!   fails this test unless it is named in [`DEBT`] (empty).
//! - Test code included, nothing in the root package but the CLI imports
//!   `bench`.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The crates under `crates/` and the ones of them each may depend on.
const CRATES: [(&str, &[&str]); 16] = [
    ("base", &[]),
    ("geom", &["base"]),
    ("io", &["base", "geom"]),
    ("template", &["base", "io"]),
    ("mech", &["base", "geom", "io"]),
    ("pipeline", &["base", "io", "template", "mech"]),
    ("phantom", &["base", "geom", "io", "pipeline"]),
    ("segment", &["base", "geom", "io", "pipeline"]),
    ("surface", &["base", "geom", "io", "pipeline"]),
    ("landmarks", &["base", "geom", "io", "pipeline"]),
    ("valve", &["base", "geom", "io", "template", "pipeline"]),
    ("leaflet", &["base", "geom", "io", "template", "pipeline"]),
    ("close", &["base", "geom", "io", "mech", "pipeline"]),
    (
        "report",
        &["base", "geom", "io", "template", "mech", "pipeline"],
    ),
    (
        "stages",
        &[
            "pipeline",
            "phantom",
            "segment",
            "surface",
            "landmarks",
            "valve",
            "leaflet",
            "close",
            "report",
        ],
    ),
    (
        "bench",
        &[
            "base", "geom", "io", "template", "mech", "pipeline", "phantom", "segment", "surface",
            "valve", "leaflet", "report", "stages",
        ],
    ),
];

/// A stage crate's tests that take their input from an earlier stage
/// (`[dev-dependencies]` only; the earlier stage never depends back).
const TEST_ONLY: [(&str, &str); 2] = [
    ("segment", "phantom"), // phantoms to segment
    ("leaflet", "valve"),   // suture paths on an ideal cylinder
];

/// The names under which the root package re-exports those crates
/// (`src/lib.rs`): below everything in `src/`.
const FROM_CRATES: [&str; 18] = [
    "error",
    "rng",
    "units",
    "geom",
    "io",
    "template",
    "mech",
    "pipeline",
    "phantom",
    "segment",
    "surface",
    "landmarks",
    "valve",
    "leaflet",
    "close",
    "report",
    "stages",
    "bench",
];

/// The modules every layer may use: the crate root's error type.
const ROOT: [&str; 2] = ["error", "lib"];

/// Wrong-way imports between the root package's modules that exist today
/// (module → module): none. The list stays so that a circle that has to be
/// let in for a while is named here, not hidden.
const DEBT: [(&str, &str); 0] = [];

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

/// The module path of a file under `src/` ("a/b.rs" → [a, b],
/// "a/mod.rs" → [a], "lib.rs" → []).
fn module_path(rel: &Path) -> Vec<String> {
    let mut parts: Vec<String> = rel
        .iter()
        .map(|c| c.to_string_lossy().trim_end_matches(".rs").to_string())
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        parts.pop();
    }
    parts
}

/// The production lines of `text`, and the modules it declares for tests
/// only (`#[cfg(test)] mod name;`; "path:f" for one given a `#[path]`).
fn production(text: &str) -> (String, Vec<String>) {
    let (mut out, mut test_mods) = (String::new(), Vec::new());
    let mut lines = text.lines();
    while let Some(l) = lines.next() {
        if l.trim() != "#[cfg(test)]" {
            out.push_str(l);
            out.push('\n');
            continue;
        }
        // Skip the item the attribute gates: further attributes, then
        // lines until its braces balance or it ends with `;`.
        let (mut depth, mut opened, mut file) = (0i64, false, None);
        for n in lines.by_ref() {
            let t = n.trim();
            if !opened && t.starts_with("#[") {
                // `#[path = "x_tests.rs"]`: the module's file, beside this one.
                file = t
                    .strip_prefix("#[path = \"")
                    .and_then(|r| r.split('"').next())
                    .map(|f| format!("path:{f}"));
                continue;
            }
            if !opened && t.ends_with(';') && !t.contains('{') {
                let words: Vec<&str> = t.trim_end_matches(';').split_whitespace().collect();
                if let Some(i) = words.iter().position(|w| *w == "mod") {
                    if let Some(name) = file.take().or(words.get(i + 1).map(|w| w.to_string())) {
                        test_mods.push(name);
                    }
                }
                break;
            }
            depth += n.matches('{').count() as i64 - n.matches('}').count() as i64;
            opened |= n.contains('{');
            if opened && depth <= 0 {
                break;
            }
        }
    }
    (out, test_mods)
}

/// The top-level module a path starts with.
fn stage_or_module(path: &str) -> String {
    path.chars()
        .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
        .collect()
}

/// Top-level modules `code` (in the module at `path`) refers to through
/// `crate::x` or `super::…::x` that climbs to the crate root.
fn references(code: &str, path: &[String]) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let ident = |s: &str| -> String {
        s.chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect()
    };
    for (i, _) in code.match_indices("crate::") {
        if i > 0 && code[..i].ends_with(|c: char| c.is_ascii_alphanumeric() || c == '_' || c == '$')
        {
            continue;
        }
        let rest = &code[i + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            for item in group.split('}').next().unwrap_or("").split(',') {
                out.insert(ident(item.trim()));
            }
        } else {
            out.insert(stage_or_module(rest));
        }
    }
    for (i, _) in code.match_indices("super::") {
        if i > 0 && code[..i].ends_with("super::") {
            continue;
        }
        let mut rest = &code[i..];
        let mut up = 0;
        while let Some(r) = rest.strip_prefix("super::") {
            rest = r;
            up += 1;
        }
        if up >= path.len() {
            out.insert(stage_or_module(rest));
        }
    }
    out.retain(|m| !m.is_empty() && m.chars().next().is_some_and(|c| c.is_ascii_lowercase()));
    out
}

/// module → modules it imports.
fn graph() -> BTreeMap<String, BTreeSet<String>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut test_only: BTreeSet<PathBuf> = BTreeSet::new();
    let mut code = BTreeMap::new();
    for f in &files {
        let rel = f.strip_prefix(&src).unwrap().to_path_buf();
        let (prod, mods) = production(&std::fs::read_to_string(f).unwrap());
        let dir = match rel.file_name().and_then(|n| n.to_str()) {
            Some("mod.rs" | "lib.rs" | "main.rs") => rel.parent().unwrap().to_path_buf(),
            _ => rel.with_extension(""),
        };
        for m in mods {
            if let Some(f) = m.strip_prefix("path:") {
                test_only.insert(rel.parent().unwrap().join(f));
            } else {
                test_only.insert(dir.join(format!("{m}.rs")));
                test_only.insert(dir.join(&m).join("mod.rs"));
            }
        }
        code.insert(rel, prod);
    }
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (rel, prod) in &code {
        if test_only
            .iter()
            .any(|t| rel.starts_with(t.with_extension("")) || rel == t)
        {
            continue;
        }
        let path = module_path(rel);
        let Some(top) = path.first() else { continue };
        let refs = references(prod, &path);
        let e = g.entry(top.clone()).or_default();
        e.extend(refs.into_iter().filter(|r| r != top));
    }
    g
}

#[test]
fn modules_import_only_downwards_and_the_known_circles() {
    let g = graph();
    let show = || {
        g.iter()
            .map(|(m, to)| {
                format!(
                    "{m} -> {}",
                    to.iter().cloned().collect::<Vec<_>>().join(", ")
                )
            })
            .collect::<Vec<_>>()
            .join("\n")
    };
    // The graph is read at all: the root's modules are there.
    for m in ["cli", "design", "inspect"] {
        assert!(g.contains_key(m), "{m} missing from\n{}", show());
    }
    let mut wrong = Vec::new();
    let mut debt_seen = BTreeSet::new();
    for (m, to) in &g {
        for t in to {
            if ROOT.contains(&t.as_str()) {
                continue;
            }
            if t == "cli" {
                wrong.push(format!("{m} -> cli"));
            } else if t == "bench" && m != "cli" {
                wrong.push(format!("{m} -> bench"));
            } else if t == "stages" && m != "cli" {
                // Only the CLI hands the stage list on: `design` and
                // `inspect` run the stages they are handed.
                wrong.push(format!("{m} -> stages"));
            } else if FROM_CRATES.contains(&t.as_str()) || m == "cli" {
                // Anything in the root may use the crates (the stages
                // among them); the CLI sits on top.
            } else if DEBT.contains(&(m.as_str(), t.as_str())) {
                debt_seen.insert((m.clone(), t.clone()));
            } else {
                wrong.push(format!("{m} -> {t}"));
            }
        }
    }
    assert!(wrong.is_empty(), "wrong-way imports: {wrong:?}\n{}", show());
    let gone: Vec<_> = DEBT
        .iter()
        .filter(|(m, t)| !debt_seen.contains(&(m.to_string(), t.to_string())))
        .collect();
    assert!(
        gone.is_empty(),
        "listed in DEBT but no longer imported (strike them): {gone:?}\n{}",
        show()
    );
}

#[test]
fn test_code_is_left_out_and_super_paths_climb_to_the_root() {
    let (prod, mods) = production(
        "use crate::geom::X;\n#[cfg(test)]\nmod tests {\n    use crate::bench::close;\n    fn f() { if true { } }\n}\n#[cfg(test)]\nmod fixtures;\n#[cfg(test)]\n#[path = \"w_tests.rs\"]\nmod tests;\n#[cfg(test)]\npub(crate) fn grid(\n    r: &mut crate::rng::R,\n) -> u32 {\n    1\n}\nfn g() {}\n",
    );
    assert_eq!(prod, "use crate::geom::X;\nfn g() {}\n");
    assert_eq!(
        mods,
        vec!["fixtures".to_string(), "path:w_tests.rs".to_string()]
    );
    let path = vec!["leaflet".to_string(), "crossings".to_string()];
    let refs = references(
        "use super::super::geom::bvh;\nuse super::place;\nuse crate::{io, Error};",
        &path,
    );
    assert_eq!(refs, ["geom", "io"].map(String::from).into_iter().collect());
}

/// The `coapt-*` packages a manifest depends on: in `[dev-dependencies]`
/// if `dev`, else in the tables that build the crate itself.
fn coapt_dependencies(manifest: &str, dev: bool) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut in_deps = false;
    for line in manifest.lines() {
        let t = line.trim();
        if t.starts_with('[') {
            let table = t.trim_matches(|c| c == '[' || c == ']');
            in_deps = table.ends_with("dependencies") && (table == "dev-dependencies") == dev;
            continue;
        }
        if in_deps {
            if let Some(name) = t
                .split(['=', ' '])
                .next()
                .filter(|n| n.starts_with("coapt"))
            {
                out.insert(name.trim_start_matches("coapt-").to_string());
            }
        }
    }
    out
}

#[test]
fn crates_depend_only_on_the_layers_below() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut on_disk: Vec<String> = std::fs::read_dir(root.join("crates"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    on_disk.sort();
    let mut listed: Vec<String> = CRATES.iter().map(|(c, _)| c.to_string()).collect();
    listed.sort();
    assert_eq!(
        on_disk, listed,
        "every crate under crates/ is listed in CRATES"
    );
    for (c, allowed) in CRATES {
        let manifest =
            std::fs::read_to_string(root.join("crates").join(c).join("Cargo.toml")).unwrap();
        for d in coapt_dependencies(&manifest, false) {
            assert!(
                allowed.contains(&d.as_str()),
                "crates/{c} depends on {d}: not a layer below it"
            );
        }
        for d in coapt_dependencies(&manifest, true) {
            assert!(
                allowed.contains(&d.as_str()) || TEST_ONLY.contains(&(c, d.as_str())),
                "crates/{c}'s tests depend on {d}: neither a layer below it nor in TEST_ONLY"
            );
        }
    }
    // A test-only input never depends back on the crate whose tests take it.
    for (c, input) in TEST_ONLY {
        let (_, below) = CRATES.iter().find(|(n, _)| *n == input).unwrap();
        assert!(!below.contains(&c), "{input} depends on {c}: a circle");
    }
    // The root package depends on each crate, and the workspace lists each
    // as a default member too: `cargo test --release` (the README's
    // command, CI's) runs only the default members' tests.
    let manifest = std::fs::read_to_string(root.join("Cargo.toml")).unwrap();
    for key in ["members", "default-members"] {
        let line = manifest
            .lines()
            .find(|l| l.starts_with(&format!("{key} = [")))
            .unwrap_or_else(|| panic!("Cargo.toml has no {key} line"));
        for c in &listed {
            assert!(
                line.contains(&format!("\"crates/{c}\"")),
                "crates/{c} is not in the workspace's {key}"
            );
        }
    }
    assert_eq!(
        coapt_dependencies(&manifest, false),
        listed.into_iter().collect::<BTreeSet<_>>()
    );
    // The parser reads the tables it is shown.
    let shown = "[package]\nname = \"coapt-x\"\n[dependencies]\ncoapt-geom = { path = \"../geom\" }\nserde = \"1\"\n[build-dependencies]\ncoapt-base = { path = \"../base\" }\n[dev-dependencies]\ncoapt-io = { path = \"../io\" }\n";
    assert_eq!(
        coapt_dependencies(shown, false),
        ["base", "geom"].map(String::from).into_iter().collect()
    );
    assert_eq!(
        coapt_dependencies(shown, true),
        ["io"].map(String::from).into_iter().collect()
    );
}

/// Test code included: a stage's tests take their fixtures from the
/// layers below (the mechanics keeps the peer leaflet in
/// `crates/mech/tests/data/`), not from the benchmarks, so a benchmark can
/// change without moving what a stage's test asserts.
#[test]
fn stage_tests_take_no_fixtures_from_the_benchmarks() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut wrong = Vec::new();
    for f in &files {
        let rel = f.strip_prefix(&src).unwrap();
        let path = module_path(rel);
        let top = path.first().map(String::as_str).unwrap_or("");
        if matches!(top, "" | "bench" | "cli") {
            continue;
        }
        let code = std::fs::read_to_string(f).unwrap();
        if references(&code, &path).contains("bench") {
            wrong.push(rel.display().to_string());
        }
    }
    assert!(wrong.is_empty(), "import from bench: {wrong:?}");
    // The check sees an import in test code.
    let path = vec!["report".to_string(), "tests".to_string()];
    assert!(references("use crate::bench::close as peer;", &path).contains("bench"));
}
