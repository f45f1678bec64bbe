//! The firmware's house (issue 34): no file pulled in by `#[path]`, and no
//! circle among the modules of `firmware/src` (a module's dependencies are
//! the `crate::` paths in its code, doc comments and its tests left out).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).expect("firmware/src is readable") {
        let p = e.expect("an entry").path();
        if p.is_dir() {
            sources(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../firmware/src")
}

/// The code of a file: no comment lines, nothing from `#[cfg(test)]` on.
fn code(text: &str) -> String {
    let text = text.split("#[cfg(test)]").next().unwrap_or("");
    text.lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn no_file_is_pulled_in_by_path() {
    let mut files = vec![];
    sources(&src(), &mut files);
    assert!(files.len() > 20, "{files:?}");
    for f in files {
        let text = std::fs::read_to_string(&f).unwrap();
        assert!(!code(&text).contains("#[path"), "{}", f.display());
    }
}

/// The module graph: each top-level module of the library and the
/// modules its code names through `crate::`.
fn graph() -> BTreeMap<String, BTreeSet<String>> {
    let root = src();
    let mut files = vec![];
    sources(&root, &mut files);
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in files {
        let rel = f.strip_prefix(&root).unwrap();
        let first = rel
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy();
        let module = first.trim_end_matches(".rs").to_string();
        if module == "lib" || module == "bin" {
            continue;
        }
        let text = code(&std::fs::read_to_string(&f).unwrap());
        let deps = g.entry(module.clone()).or_default();
        for part in text.split("crate::").skip(1) {
            let name: String = part
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            if !name.is_empty() && name != module {
                deps.insert(name);
            }
        }
    }
    g
}

/// A circle through `start`, if any (depth-first).
fn circle(g: &BTreeMap<String, BTreeSet<String>>, start: &str) -> Option<Vec<String>> {
    fn walk(
        g: &BTreeMap<String, BTreeSet<String>>,
        at: &str,
        start: &str,
        path: &mut Vec<String>,
        seen: &mut BTreeSet<String>,
    ) -> bool {
        for d in g.get(at).into_iter().flatten() {
            if d == start {
                return true;
            }
            if g.contains_key(d) && seen.insert(d.clone()) {
                path.push(d.clone());
                if walk(g, d, start, path, seen) {
                    return true;
                }
                path.pop();
            }
        }
        false
    }
    let mut path = vec![start.to_string()];
    walk(g, start, start, &mut path, &mut BTreeSet::new()).then_some(path)
}

#[test]
fn no_circle_among_the_firmwares_modules() {
    let g = graph();
    // The graph is read: the drivers name the ports, the tasks name many.
    assert!(g["icm42688"].contains("ports"), "{g:?}");
    assert!(g["tasks"].len() > 5, "{g:?}");
    for m in g.keys() {
        assert_eq!(circle(&g, m), None, "a circle through {m}");
    }
    // And the check sees one when there is one.
    let mut bad = g.clone();
    bad.get_mut("ports").unwrap().insert("tasks".into());
    assert!(circle(&bad, "ports").is_some());
}
