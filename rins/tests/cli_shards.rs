//! Studies split into shards (`--shard K/N --json`) and put back together
//! (`rins merge`) give the tables and the JSON of one run, bit for bit:
//! the outage Monte Carlo, the paper's experiment and the blind study.

use std::path::{Path, PathBuf};
use std::process::Command;

fn rins(args: &[&str]) {
    let o = Command::new(env!("CARGO_BIN_EXE_rins"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "rins {args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("rins-shards-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> String {
    p.to_string_lossy().to_string()
}

/// Runs `command` whole and as 2 shards in reverse order (3 for the
/// study: more shards than some cells have runs), merges, and compares.
fn whole_equals_merged(name: &str, command: &[&str], shards: usize, markdown: bool) {
    let d = tmp(name);
    let (one_j, one_m) = (d.join("one.json"), d.join("one.md"));
    let mut whole: Vec<String> = command.iter().map(|x| x.to_string()).collect();
    whole.extend(["--json".into(), s(&one_j)]);
    if markdown {
        whole.extend(["--markdown".into(), s(&one_m)]);
    }
    rins(&whole.iter().map(String::as_str).collect::<Vec<_>>());
    let mut parts = vec![];
    for k in (0..shards).rev() {
        let p = d.join(format!("shard{k}.json"));
        let mut a: Vec<String> = command.iter().map(|x| x.to_string()).collect();
        a.extend([
            "--shard".into(),
            format!("{k}/{shards}"),
            "--json".into(),
            s(&p),
        ]);
        rins(&a.iter().map(String::as_str).collect::<Vec<_>>());
        parts.push(s(&p));
    }
    let (m_j, m_m) = (d.join("merged.json"), d.join("merged.md"));
    let mut m: Vec<String> = vec!["merge".into()];
    m.extend(parts.iter().cloned());
    m.extend(["--json".into(), s(&m_j), "--markdown".into(), s(&m_m)]);
    rins(&m.iter().map(String::as_str).collect::<Vec<_>>());
    let read = |p: &Path| std::fs::read_to_string(p).unwrap();
    assert_eq!(read(&one_j), read(&m_j), "{name}: the JSON differs");
    if markdown {
        assert_eq!(read(&one_m), read(&m_m), "{name}: the table differs");
    }
    // A shard missing is refused, not merged into a smaller table.
    let o = Command::new(env!("CARGO_BIN_EXE_rins"))
        .args(["merge", &parts[0]])
        .output()
        .unwrap();
    assert!(!o.status.success(), "{name}: one shard of {shards} merged");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn outages_in_shards_merge_to_one_run() {
    whole_equals_merged(
        "outages",
        &[
            "outages", "--drive", "city", "--sensor", "nav440", "--drives", "3", "--seed", "4",
        ],
        2,
        true,
    );
}

#[test]
fn reproduce_in_shards_merges_to_one_run() {
    whole_equals_merged(
        "reproduce",
        &[
            "reproduce",
            "--sensor",
            "nav440",
            "--runs",
            "3",
            "--seed",
            "2",
        ],
        2,
        true,
    );
}

#[test]
fn the_study_in_shards_merges_to_one_run() {
    whole_equals_merged(
        "study",
        &["study", "--sensor", "nav440", "--runs", "1", "--nulls", "2"],
        3,
        true,
    );
}
