//! Studies split across machines: `--shard K/N` runs the runs whose index
//! `i` (from the first seed, or the study's job order) has `i mod N = K`,
//! and writes what it ran as JSON; `rins merge` puts the shards back
//! together into the same tables, bit for bit, as one run. The machines
//! are someone else's scheduler's (a Slurm job array, Kubernetes indexed
//! Jobs, GNU parallel): there is no scheduler here.

use serde::{Deserialize, Serialize};

/// Shard `k` of `n` (k from 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// This shard, from 0.
    pub k: usize,
    /// Shards in all.
    pub n: usize,
}

impl Shard {
    /// The whole study as one shard.
    pub const ALL: Shard = Shard { k: 0, n: 1 };

    /// Does this shard run the run with index `i`?
    pub fn has(&self, i: usize) -> bool {
        i % self.n == self.k
    }
}

impl std::str::FromStr for Shard {
    type Err = String;

    /// `K/N`, 0 <= K < N.
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("--shard {s:?}: K/N with 0 <= K < N (e.g. 0/4)");
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let (k, n): (usize, usize) = (
            k.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        if n == 0 || k >= n {
            return Err(bad());
        }
        Ok(Self { k, n })
    }
}

/// Checks that `shards` are 0..N of one N, each once.
///
/// # Errors
/// A shard missing, given twice, or of another N.
pub fn complete(shards: &[Shard]) -> Result<(), String> {
    let n = shards.first().map_or(0, |s| s.n);
    let mut ks: Vec<usize> = shards.iter().map(|s| s.k).collect();
    ks.sort_unstable();
    if shards.iter().any(|s| s.n != n) || ks != (0..n).collect::<Vec<_>>() {
        let got: Vec<String> = shards.iter().map(|s| format!("{}/{}", s.k, s.n)).collect();
        return Err(format!(
            "shards {} are not 0/N .. N-1/N of one N, each once",
            got.join(", ")
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_and_membership() {
        let s: Shard = "1/3".parse().unwrap();
        assert_eq!(s, Shard { k: 1, n: 3 });
        assert!(s.has(1) && s.has(4) && !s.has(0) && !s.has(2));
        for bad in ["3/3", "1", "a/2", "0/0", "-1/2"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
        let all = [Shard { k: 1, n: 2 }, Shard { k: 0, n: 2 }];
        assert!(complete(&all).is_ok());
        assert!(complete(&all[..1]).is_err());
        assert!(complete(&[Shard { k: 0, n: 2 }, Shard { k: 0, n: 2 }]).is_err());
    }
}
