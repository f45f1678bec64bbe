//! The last test binary `cargo test` runs: one line saying which external
//! datasets were missing (their tests skipped) and how to get them, or that
//! every data test ran. With `RINS_DATA_REQUIRED=1` a missing dataset fails.

use rins_tests::data::{present, required, root, EXTERNAL};

fn main() {
    let missing: Vec<_> = EXTERNAL.iter().filter(|d| !present(d)).collect();
    if missing.is_empty() {
        println!(
            "external data: all {} datasets found under {}; every data test ran",
            EXTERNAL.len(),
            root().display()
        );
        return;
    }
    let tests: Vec<&str> = missing
        .iter()
        .flat_map(|d| d.used_by.iter().copied())
        .collect();
    let names: Vec<&str> = missing.iter().map(|d| d.dir).collect();
    println!(
        "SKIPPED {} data tests ({}): datasets {} not found under {}; get them by placing the shared data directory there or setting RINS_DATA=/path/to/shared/data",
        tests.len(),
        tests.join(", "),
        names.join(", "),
        root().display()
    );
    if required() {
        eprintln!("RINS_DATA_REQUIRED is set: missing external data is a failure");
        std::process::exit(1);
    }
}
