//! Every `--help` a user can ask for (the top level, each command and
//! each nested subcommand, found by reading the help itself) fits 80
//! columns, and no option prints its value name more than once.

use std::process::Command;

fn help(path: &[String]) -> String {
    let o = Command::new(env!("CARGO_BIN_EXE_rins"))
        .args(path)
        .arg("--help")
        .output()
        .unwrap();
    assert!(o.status.success(), "rins {path:?} --help failed");
    String::from_utf8(o.stdout).unwrap()
}

/// The subcommands a help text lists under `Commands:` (`help` left out).
fn subcommands(text: &str) -> Vec<String> {
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

#[test]
fn every_help_fits_80_columns_with_one_value_name_per_option() {
    let mut todo = vec![Vec::<String>::new()];
    let mut seen = 0;
    while let Some(path) = todo.pop() {
        let text = help(&path);
        seen += 1;
        for l in text.lines() {
            assert!(
                l.chars().count() <= 80,
                "rins {} --help: a line of {} columns:\n{l}",
                path.join(" "),
                l.chars().count()
            );
            let t = l.trim_start();
            let indent = l.len() - t.len();
            if t.starts_with('-') && indent <= 6 {
                assert!(
                    t.matches('<').count() <= 1,
                    "rins {} --help repeats a value name: {l}",
                    path.join(" ")
                );
            }
        }
        for c in subcommands(&text) {
            let mut p = path.clone();
            p.push(c);
            todo.push(p);
        }
    }
    // The top level, its 15 commands and `command`'s 7 subcommands at least.
    assert!(seen >= 23, "only {seen} help texts found");
}
