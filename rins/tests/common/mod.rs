//! What the CLI tests share: running the binary, its help texts, and
//! scratch directories.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// `rins ARGS` run to its end (no backtrace in its errors).
pub fn rins(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_rins"))
        .args(args)
        .env("RUST_BACKTRACE", "0")
        .output()
        .unwrap()
}

/// Its stdout, asserting it succeeded.
pub fn ok(o: &Output) -> String {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Asserts it failed with each of `words` in its stderr.
pub fn refused(o: &Output, words: &[&str]) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "exit 0; stderr {err}");
    for w in words {
        assert!(err.contains(w), "{w:?} not in: {err}");
    }
}

/// A fresh scratch directory `rins-NAME-PID` (not created).
pub fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("rins-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// A path as an argument.
pub fn s(p: &Path) -> String {
    p.to_string_lossy().into_owned()
}

/// `rins PATH... --help`.
pub fn help(path: &[String]) -> String {
    let o = Command::new(env!("CARGO_BIN_EXE_rins"))
        .args(path)
        .arg("--help")
        .output()
        .unwrap();
    assert!(o.status.success(), "rins {path:?} --help failed");
    String::from_utf8(o.stdout).unwrap()
}

/// The subcommands a help text lists under `Commands:` (`help` left out).
pub fn subcommands(text: &str) -> Vec<String> {
    text.lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter(|l| l.as_bytes().get(2).is_some_and(|c| *c != b' '))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|c| *c != "help")
        .map(String::from)
        .collect()
}

/// Every help text a user can ask for: the command path and its text,
/// the top level first.
pub fn every_help() -> Vec<(Vec<String>, String)> {
    let mut todo = vec![Vec::<String>::new()];
    let mut out = vec![];
    while let Some(path) = todo.pop() {
        let text = help(&path);
        for c in subcommands(&text) {
            let mut p = path.clone();
            p.push(c);
            todo.push(p);
        }
        out.push((path, text));
    }
    out
}

/// The long options a help text lists (`--help` and `--version` left
/// out), in its order.
pub fn options(text: &str) -> Vec<String> {
    text.lines()
        .filter_map(|l| {
            let t = l.trim_start();
            let indent = l.len() - t.len();
            (t.starts_with('-') && indent <= 6).then_some(t)?;
            t.split([' ', ','])
                .find(|w| w.starts_with("--"))
                .map(String::from)
        })
        .filter(|o| o != "--help" && o != "--version")
        .collect()
}

/// A copy of the recording `from` (its directory's files) at `to`.
pub fn copy_recording(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
    }
}
