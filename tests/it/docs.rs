//! The documentation's links resolve inside the repository: every relative
//! link of the Markdown pages names a file that is there (and a heading of
//! it, when it has an anchor), and nothing cites the design notes that live
//! outside the repository.

use std::path::{Path, PathBuf};

use crate::common::repo;

/// The Markdown pages a reader opens: the top-level ones and `docs/`.
fn pages() -> Vec<PathBuf> {
    let mut out = Vec::new();
    for dir in [repo(), repo().join("docs")] {
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "md") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// GitHub's anchor of a heading: lower case, punctuation but `-` and `_`
/// dropped, spaces to `-`.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter(|c| c.is_alphanumeric() || matches!(c, ' ' | '-' | '_'))
        .map(|c| if c == ' ' { '-' } else { c })
        .collect()
}

fn anchors(page: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(page).unwrap();
    let mut in_code = false;
    let mut out = Vec::new();
    for line in text.lines() {
        if line.starts_with("```") {
            in_code = !in_code;
        } else if !in_code && line.starts_with('#') {
            out.push(slug(line.trim_start_matches('#')));
        }
    }
    out
}

/// `(target, anchor)` of every `](…)` link that is not a URL.
fn links(text: &str) -> Vec<(String, Option<String>)> {
    let mut out = Vec::new();
    for (i, _) in text.match_indices("](") {
        let rest = &text[i + 2..];
        let Some(end) = rest.find(')') else { continue };
        let link = &rest[..end];
        if link.contains("://") || link.starts_with("mailto:") || link.contains(' ') {
            continue;
        }
        let (file, anchor) = match link.split_once('#') {
            Some((f, a)) => (f.to_string(), Some(a.to_string())),
            None => (link.to_string(), None),
        };
        out.push((file, anchor));
    }
    out
}

#[test]
fn every_relative_link_and_anchor_resolves() {
    let mut broken = Vec::new();
    let mut checked = 0;
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        for (file, anchor) in links(&text) {
            let target = if file.is_empty() {
                page.clone()
            } else {
                page.parent().unwrap().join(&file)
            };
            if !target.exists() {
                broken.push(format!("{}: {file} is not there", page.display()));
                continue;
            }
            if let Some(a) = anchor
                && target.extension().is_some_and(|x| x == "md")
                && !anchors(&target).contains(&a)
            {
                broken.push(format!("{}: {file}#{a}: no such heading", page.display()));
            }
            checked += 1;
        }
    }
    assert!(checked > 50, "only {checked} links found");
    assert!(broken.is_empty(), "{}", broken.join("\n"));
}

/// The design notes shared outside the repository are not cited: what the
/// code needs from them is in `docs/` (references.md, verification.md).
#[test]
fn nothing_cites_the_notes_outside_the_repository() {
    let mut found = Vec::new();
    let mut stack: Vec<PathBuf> = [
        "src",
        "crates",
        "docs",
        "schemas",
        "pipelines",
        "tests",
        "benches",
        "fuzz",
        "tools",
    ]
    .iter()
    .map(|d| repo().join(d))
    .chain(pages().into_iter().filter(|p| p.parent() == Some(&repo())))
    .collect();
    while let Some(p) = stack.pop() {
        if p.is_dir() {
            if p.file_name()
                .is_some_and(|n| n == "target" || n == "node_modules" || n == ".venv")
            {
                continue;
            }
            for e in std::fs::read_dir(&p).unwrap() {
                stack.push(e.unwrap().path());
            }
        } else if p != repo().join("tests/it/docs.rs")
            && let Ok(text) = std::fs::read_to_string(&p)
        {
            for name in ["DESIGN.md", "ALGORITHMS.md", "VERIFICATION.md"] {
                if text.contains(name) {
                    found.push(format!("{} cites {name}", p.display()));
                }
            }
        }
    }
    assert!(found.is_empty(), "{}", found.join("\n"));
}
