//! The book (`docs/`, mdBook) and the README cannot rot silently: every
//! relative link resolves (its file, and its `#anchor` to a heading there),
//! every chapter is in `SUMMARY.md` and every `SUMMARY.md` entry exists,
//! and every command `rins --help` lists has its section in the Commands
//! chapter.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// mdBook's heading ids: lower case, whitespace to `-`, only
/// alphanumerics, `-` and `_` kept.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            c if c.is_whitespace() => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

fn anchors(md: &str) -> BTreeSet<String> {
    let mut fence = false;
    md.lines()
        .filter(|l| {
            if l.starts_with("```") {
                fence = !fence;
            }
            !fence && l.starts_with('#')
        })
        .map(|l| slug(l.trim_start_matches('#')))
        .collect()
}

/// `(target, line)` of every inline link `](target)` outside code.
fn links(md: &str) -> Vec<(String, usize)> {
    let mut out = vec![];
    let mut fence = false;
    for (i, l) in md.lines().enumerate() {
        if l.starts_with("```") {
            fence = !fence;
        }
        if fence {
            continue;
        }
        let mut rest = l;
        while let Some(k) = rest.find("](") {
            rest = &rest[k + 2..];
            if let Some(e) = rest.find(')') {
                out.push((rest[..e].to_string(), i + 1));
                rest = &rest[e..];
            }
        }
    }
    out
}

fn check_file(p: &Path, broken: &mut Vec<String>) {
    let md = std::fs::read_to_string(p).unwrap();
    for (t, line) in links(&md) {
        if t.starts_with("http://") || t.starts_with("https://") || t.starts_with("mailto:") {
            continue;
        }
        let (file, anchor) = t.split_once('#').unwrap_or((&t, ""));
        let target = if file.is_empty() {
            p.to_path_buf()
        } else {
            p.parent().unwrap().join(file)
        };
        if !target.exists() {
            broken.push(format!("{}:{line}: {t} (no such file)", p.display()));
            continue;
        }
        if !anchor.is_empty() {
            let text = std::fs::read_to_string(&target).unwrap_or_default();
            if !anchors(&text).contains(anchor) {
                broken.push(format!("{}:{line}: {t} (no such heading)", p.display()));
            }
        }
    }
}

#[test]
fn every_link_in_the_book_and_the_readme_resolves() {
    let src = root().join("docs/src");
    let mut broken = vec![];
    let mut chapters: Vec<PathBuf> = std::fs::read_dir(&src)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    chapters.sort();
    for p in chapters.iter().chain([&root().join("README.md")]) {
        check_file(p, &mut broken);
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
    // Every chapter is in the summary (a chapter outside it is not in
    // the book).
    let summary = std::fs::read_to_string(src.join("SUMMARY.md")).unwrap();
    let listed: BTreeSet<String> = links(&summary).into_iter().map(|(t, _)| t).collect();
    for p in &chapters {
        let name = p.file_name().unwrap().to_string_lossy().to_string();
        assert!(
            name == "SUMMARY.md" || listed.contains(&name),
            "{name} is not in SUMMARY.md"
        );
    }
}

#[test]
fn every_command_has_its_section_in_the_commands_chapter() {
    let help = Command::new(env!("CARGO_BIN_EXE_rins"))
        .arg("--help")
        .output()
        .unwrap();
    let help = String::from_utf8(help.stdout).unwrap();
    let commands: Vec<&str> = help
        .split("Commands:")
        .nth(1)
        .unwrap()
        .split("Options:")
        .next()
        .unwrap()
        .lines()
        // A command's own line; its wrapped description's lines are
        // indented further.
        .filter(|l| l.starts_with("  ") && !l.starts_with("   "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|c| *c != "help")
        .collect();
    assert!(commands.len() >= 13, "{commands:?}");
    let chapter = std::fs::read_to_string(root().join("docs/src/commands.md")).unwrap();
    for c in commands {
        assert!(
            chapter.contains(&format!("\n## rins {c}\n")),
            "docs/src/commands.md has no section for rins {c}"
        );
    }
}

/// The result tables the chapters include: every `{{#include results/X}}`
/// names a file `rins results` wrote at the book's setting (its stamp
/// says so, with a date and a commit), and every file there is included
/// somewhere (a table nobody shows would go stale unseen).
#[test]
fn every_result_table_is_generated_and_shown() {
    let src = root().join("docs/src");
    let mut included = BTreeSet::new();
    for e in std::fs::read_dir(&src).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_none_or(|x| x != "md") {
            continue;
        }
        let md = std::fs::read_to_string(&p).unwrap();
        for l in md.lines().filter(|l| l.starts_with("{{#include results/")) {
            let name = l
                .trim_start_matches("{{#include results/")
                .trim_end_matches("}}");
            included.insert(name.to_string());
        }
    }
    assert!(included.len() >= 6, "{included:?}");
    let dir = src.join("results");
    let mut files = BTreeSet::new();
    for e in std::fs::read_dir(&dir).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().to_string();
        let text = std::fs::read_to_string(&p).unwrap();
        let first = text.lines().next().unwrap_or("");
        assert!(
            first.starts_with("*Generated by `rins results` on 20")
                && first.contains(" at commit ")
                && first.contains("(the book's setting)"),
            "{name}: not stamped by `rins results` at the book's setting: {first}"
        );
        files.insert(name);
    }
    assert_eq!(
        included, files,
        "included tables against the files in docs/src/results"
    );
}
