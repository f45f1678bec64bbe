//! Writes the Hardware chapter's generated parts (the pin map, the wiring
//! diagram, the table's section: `rins_tests::hardware`) into
//! `docs/src/generated/`; `--check` fails when a committed copy differs.

fn main() {
    let check = std::env::args().any(|a| a == "--check");
    let mut stale = 0;
    for (path, text) in rins_tests::hardware::generated() {
        let file = rins_tests::hardware::root().join(path);
        if check {
            if std::fs::read_to_string(&file).ok().as_deref() != Some(text.as_str()) {
                eprintln!("hardware-docs: {path} is stale: run cargo run -p rins-tests --bin hardware-docs");
                stale += 1;
            }
        } else if let Err(e) = std::fs::write(&file, text) {
            eprintln!("hardware-docs: cannot write {path}: {e}");
            std::process::exit(1);
        } else {
            println!("wrote {path}");
        }
    }
    if stale > 0 {
        std::process::exit(1);
    }
}
