//! `board-twin REPLAY`: runs the QEMU test's replay through the board's
//! program on the host and writes the outcome into the replay's trailer,
//! for the QEMU build to compare with bit for bit.

fn main() {
    let Some(path) = std::env::args().nth(1) else {
        eprintln!("usage: board-twin REPLAY (from `rins qemu-replay`)");
        std::process::exit(2);
    };
    let mut bytes = match std::fs::read(&path) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("reading {path}: {e}");
            std::process::exit(1);
        }
    };
    let r = rins_tests::twin::run(&bytes, rins_tests::twin::TwinOptions::default());
    let t = protocol::replay::encode_outcome(&r.outcome);
    let n = bytes.len();
    bytes[n - protocol::replay::TRAILER..].copy_from_slice(&t);
    if let Err(e) = std::fs::write(&path, &bytes) {
        eprintln!("writing {path}: {e}");
        std::process::exit(1);
    }
    println!(
        "{path}: the board's program on the host: mode {} p_n {:?} m v_n {:?} m/s ({} fixes sent)",
        r.outcome.mode, r.outcome.p_n, r.outcome.v_n, r.fixes
    );
    if r.outcome.mode != 3 {
        eprintln!("the board's program did not reach navigation");
        std::process::exit(1);
    }
}
