//! NumPy `.npy` arrays (format versions 1-3): little-endian `f8` only, one
//! or two dimensions, C or Fortran order, read into row-major `f64`s. The
//! format: the magic `\x93NUMPY`, a version, a header length, a Python
//! dict literal (`descr`, `fortran_order`, `shape`), the data.

use anyhow::{anyhow, bail, Result};
use std::path::Path;

/// A 2-D array (a 1-D one is `n x 1`), row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct Array {
    /// Rows.
    pub rows: usize,
    /// Columns.
    pub cols: usize,
    /// `rows * cols` values, row by row.
    pub data: Vec<f64>,
}

impl Array {
    /// Row `i` (empty past the end).
    pub fn row(&self, i: usize) -> &[f64] {
        self.data
            .get(i * self.cols..(i + 1) * self.cols)
            .unwrap_or(&[])
    }

    /// Column 0 as a vector.
    pub fn column0(&self) -> Vec<f64> {
        (0..self.rows)
            .filter_map(|i| self.row(i).first().copied())
            .collect()
    }
}

/// Reads `path`.
///
/// # Errors
/// Not an `.npy` file, another dtype than `<f8`, more than two dimensions,
/// a short file; each naming the file.
pub fn read(path: &Path) -> Result<Array> {
    let b = std::fs::read(path).map_err(|e| anyhow!("{}: {e}", path.display()))?;
    parse(&b).map_err(|e| anyhow!("{}: {e}", path.display()))
}

/// Parses the bytes of an `.npy` file.
///
/// # Errors
/// As [`read`].
pub fn parse(b: &[u8]) -> Result<Array> {
    if b.get(..6) != Some(b"\x93NUMPY") {
        bail!("not a NumPy .npy array (no \\x93NUMPY magic)");
    }
    let major = *b.get(6).ok_or_else(|| anyhow!("short file"))?;
    let (len, start) = match major {
        1 => {
            let w = b.get(8..10).ok_or_else(|| anyhow!("short file"))?;
            (usize::from(u16::from_le_bytes([w[0], w[1]])), 10)
        }
        2 | 3 => {
            let w = b.get(8..12).ok_or_else(|| anyhow!("short file"))?;
            (u32::from_le_bytes([w[0], w[1], w[2], w[3]]) as usize, 12)
        }
        v => bail!("npy format version {v} (1 to 3 are read)"),
    };
    let header = std::str::from_utf8(
        b.get(start..start + len)
            .ok_or_else(|| anyhow!("short header"))?,
    )?;
    let field = |k: &str| -> Result<&str> {
        let at = header
            .find(&format!("'{k}':"))
            .ok_or_else(|| anyhow!("header has no '{k}'"))?;
        Ok(header[at + k.len() + 3..].trim_start())
    };
    if !field("descr")?.starts_with("'<f8'") {
        bail!(
            "dtype {}: only little-endian float64 ('<f8') is read",
            field("descr")?.split(',').next().unwrap_or("")
        );
    }
    let fortran = field("fortran_order")?.starts_with("True");
    let shape_text = field("shape")?;
    let inner = shape_text
        .strip_prefix('(')
        .and_then(|s| s.split(')').next())
        .ok_or_else(|| anyhow!("unreadable shape {shape_text}"))?;
    let dims: Vec<usize> = inner
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse::<usize>()
                .map_err(|_| anyhow!("unreadable shape ({inner})"))
        })
        .collect::<Result<_>>()?;
    let (rows, cols) = match dims[..] {
        [n] => (n, 1),
        [r, c] => (r, c),
        _ => bail!("shape ({inner}): one or two dimensions are read"),
    };
    let body = b.get(start + len..).unwrap_or(&[]);
    let n = rows * cols;
    if body.len() < 8 * n {
        bail!(
            "{} bytes of data for shape ({inner}): {} expected",
            body.len(),
            8 * n
        );
    }
    let v: Vec<f64> = body
        .chunks_exact(8)
        .take(n)
        .map(|c| f64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]]))
        .collect();
    let data = if fortran {
        (0..n).map(|k| v[(k % cols) * rows + k / cols]).collect()
    } else {
        v
    };
    Ok(Array { rows, cols, data })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn npy(header: &str, vals: &[f64]) -> Vec<u8> {
        let mut h = header.to_string();
        while !(10 + h.len() + 1).is_multiple_of(64) {
            h.push(' ');
        }
        h.push('\n');
        let mut b = b"\x93NUMPY\x01\x00".to_vec();
        b.extend_from_slice(&(h.len() as u16).to_le_bytes());
        b.extend_from_slice(h.as_bytes());
        for v in vals {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b
    }

    #[test]
    fn c_and_fortran_order_read_the_same_rows() {
        let c = npy(
            "{'descr': '<f8', 'fortran_order': False, 'shape': (2, 3), }",
            &[1., 2., 3., 4., 5., 6.],
        );
        let f = npy(
            "{'descr': '<f8', 'fortran_order': True, 'shape': (2, 3), }",
            &[1., 4., 2., 5., 3., 6.],
        );
        let (a, b) = (parse(&c).unwrap(), parse(&f).unwrap());
        assert_eq!(a, b);
        assert_eq!(a.row(1), &[4., 5., 6.]);
        let one = parse(&npy(
            "{'descr': '<f8', 'fortran_order': False, 'shape': (3,), }",
            &[7., 8., 9.],
        ))
        .unwrap();
        assert_eq!(one.column0(), vec![7., 8., 9.]);
        let e = parse(&npy(
            "{'descr': '<i4', 'fortran_order': False, 'shape': (1,), }",
            &[0.],
        ))
        .unwrap_err();
        assert!(e.to_string().contains("float64"), "{e}");
        let e = parse(&npy(
            "{'descr': '<f8', 'fortran_order': False, 'shape': (4,), }",
            &[0.],
        ))
        .unwrap_err();
        assert!(e.to_string().contains("expected"), "{e}");
        assert!(parse(b"PK\x03\x04").is_err());
    }
}
