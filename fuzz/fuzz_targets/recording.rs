//! Fuzzes the recording readers: the input is `meta.toml`, `imu.csv` and
//! `table.csv` separated by NUL bytes. Any input must give Ok or an error
//! naming the file, never a panic.
#![no_main]

use recording::{parse_imu, parse_meta, parse_table};
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let mut parts = data.split(|b| *b == 0);
    let text = |p: Option<&[u8]>| String::from_utf8_lossy(p.unwrap_or(&[])).into_owned();
    let (meta, imu, table) = (text(parts.next()), text(parts.next()), text(parts.next()));
    if let Err(e) = parse_meta(&meta, Path::new("meta.toml")) {
        assert!(e.to_string().starts_with("meta.toml"));
    }
    if let Err(e) = parse_imu(&imu, Path::new("imu.csv")) {
        assert!(e.to_string().starts_with("imu.csv"));
    }
    if let Err(e) = parse_table(&table, Path::new("table.csv")) {
        assert!(e.to_string().starts_with("table.csv"));
    }
});
