//! Every `--help` a user can ask for (the top level, each command and
//! each nested subcommand, found by reading the help itself) fits 80
//! columns, and no option prints its value name more than once.

mod common;
use common::every_help;

#[test]
fn every_help_fits_80_columns_with_one_value_name_per_option() {
    let all = every_help();
    for (path, text) in &all {
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
    }
    // The top level, its 15 commands and `command`'s 7 subcommands at least.
    assert!(all.len() >= 23, "only {} help texts found", all.len());
}
