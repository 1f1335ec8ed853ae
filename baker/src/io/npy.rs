//! NumPy `.npy` files of `float32`, for handing arrays to Python tooling.
//!
//! [`write_npy_f32`] writes format version 1.0: the magic `\x93NUMPY`, version bytes `1 0`,
//! a little-endian `u16` header length, then a Python dict literal
//! `{'descr': '<f4', 'fortran_order': False, 'shape': (..), }` padded with spaces and ended
//! by `\n` so the data starts at a multiple of 64 bytes, then the values, little-endian, in
//! C (row-major) order. `numpy.load` reads it as is.
//!
//! [`read_npy_f32`] reads back such files (versions 1.0, 2.0 and 3.0, `<f4`, C order only).

use std::path::{Path, PathBuf};

use thiserror::Error;

const MAGIC: &[u8; 6] = b"\x93NUMPY";

/// Writes `data` as a little-endian `float32` array of `shape` in NumPy format 1.0.
///
/// Fails with `InvalidInput` if `data.len()` is not the product of `shape` (1 for an empty
/// shape, i.e. a scalar).
pub fn write_npy_f32(path: &Path, shape: &[usize], data: &[f32]) -> std::io::Result<()> {
    let count = shape.iter().try_fold(1usize, |acc, &d| acc.checked_mul(d));
    if count != Some(data.len()) {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!(
                "{}: shape {shape:?} does not hold {} values",
                path.display(),
                data.len()
            ),
        ));
    }
    let dims = match shape {
        [d] => format!("({d},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(usize::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    let mut header = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': {dims}, }}");
    // magic (6) + version (2) + length (2) + header + '\n' must be a multiple of 64.
    let unpadded = MAGIC.len() + 4 + header.len() + 1;
    header.extend(std::iter::repeat_n(
        ' ',
        unpadded.next_multiple_of(64) - unpadded,
    ));
    header.push('\n');
    let header_len = u16::try_from(header.len()).map_err(|_| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!(
                "{}: shape {shape:?} makes the header too long",
                path.display()
            ),
        )
    })?;
    let mut bytes = Vec::with_capacity(10 + header.len() + 4 * data.len());
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&[1, 0]);
    bytes.extend_from_slice(&header_len.to_le_bytes());
    bytes.extend_from_slice(header.as_bytes());
    for x in data {
        bytes.extend_from_slice(&x.to_le_bytes());
    }
    std::fs::write(path, bytes)
}

/// Failure to read a `.npy` file: the file and the problem.
#[derive(Debug, Error)]
pub enum NpyError {
    /// The file could not be read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file is not a `.npy` this reader supports.
    #[error("{}: {problem}", path.display())]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
}

/// Reads a little-endian `float32`, C-order `.npy` file: returns `(shape, data)`.
pub fn read_npy_f32(path: &Path) -> Result<(Vec<usize>, Vec<f32>), NpyError> {
    let bytes = crate::io::read_bounded(path).map_err(|source| NpyError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse(&bytes).map_err(|problem| NpyError::Format {
        path: path.to_path_buf(),
        problem,
    })
}

fn parse(bytes: &[u8]) -> Result<(Vec<usize>, Vec<f32>), String> {
    if bytes.len() < 10 || &bytes[..6] != MAGIC {
        return Err("not a NumPy .npy file (bad magic)".into());
    }
    let (header_len, header_start) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
        2 | 3 if bytes.len() >= 12 => (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        ),
        v => return Err(format!("unsupported .npy format version {v}.{}", bytes[7])),
    };
    let data_start = header_start + header_len;
    let header = bytes
        .get(header_start..data_start)
        .and_then(|h| std::str::from_utf8(h).ok())
        .ok_or("truncated or non-text header")?;
    let descr = dict_value(header, "descr")?;
    if !matches!(descr, "'<f4'" | "\"<f4\"") {
        return Err(format!(
            "dtype {descr} is not little-endian float32 ('<f4')"
        ));
    }
    if dict_value(header, "fortran_order")? != "False" {
        return Err("Fortran-order arrays are not supported".into());
    }
    let shape_text = dict_value(header, "shape")?;
    let inner = shape_text
        .strip_prefix('(')
        .and_then(|s| s.strip_suffix(')'))
        .ok_or_else(|| format!("shape {shape_text} is not a tuple"))?;
    let shape = inner
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.parse::<usize>())
        .collect::<Result<Vec<_>, _>>()
        .map_err(|_| format!("shape {shape_text} is not a tuple of sizes"))?;
    let count = shape
        .iter()
        .try_fold(1usize, |acc, &d| acc.checked_mul(d))
        .ok_or("shape overflows")?;
    let data = &bytes[data_start..];
    if Some(data.len()) != count.checked_mul(4) {
        return Err(format!(
            "shape {shape:?} needs {count} values but the file holds {} bytes of data",
            data.len()
        ));
    }
    let values = data
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    Ok((shape, values))
}

/// The text of `key`'s value in a NumPy header dict: a quoted string, a tuple, or a word.
fn dict_value<'a>(header: &'a str, key: &str) -> Result<&'a str, String> {
    let missing = || format!("header has no '{key}': {}", header.trim_end());
    let at = header
        .find(&format!("'{key}'"))
        .or_else(|| header.find(&format!("\"{key}\"")))
        .ok_or_else(missing)?;
    let rest = header[at + key.len() + 2..]
        .trim_start()
        .strip_prefix(':')
        .ok_or_else(missing)?
        .trim_start();
    let end = match rest.chars().next() {
        Some('(') => rest.find(')').map(|i| i + 1),
        Some(q @ ('\'' | '"')) => rest[1..].find(q).map(|i| i + 2),
        Some(_) => rest.find([',', '}']),
        None => None,
    }
    .ok_or_else(missing)?;
    Ok(rest[..end].trim_end())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::gltf_mesh::tests::{head, scratch};

    #[test]
    fn round_trips_facecap_positions() {
        let m = head();
        let data: Vec<f32> = m.positions.iter().flatten().map(|&x| x as f32).collect();
        let path = scratch("head.npy");
        write_npy_f32(&path, &[2694, 3], &data).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let header_len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
        assert_eq!((10 + header_len) % 64, 0);
        assert_eq!(bytes.len(), 10 + header_len + 4 * 2694 * 3);
        assert_eq!(bytes[10 + header_len - 1], b'\n');
        let header = std::str::from_utf8(&bytes[10..10 + header_len]).unwrap();
        assert!(
            header.starts_with("{'descr': '<f4', 'fortran_order': False, 'shape': (2694, 3), }"),
            "{header}"
        );
        let (shape, back) = read_npy_f32(&path).unwrap();
        assert_eq!(shape, [2694, 3]);
        assert_eq!(back, data);
        // Little-endian, C order: the first value is vertex 0's x.
        let first = f32::from_le_bytes(bytes[10 + header_len..][..4].try_into().unwrap());
        assert_eq!(first, m.positions[0][0] as f32);
    }

    #[test]
    fn shapes_of_other_ranks() {
        let path = scratch("ranks.npy");
        write_npy_f32(&path, &[5], &[1.0, 2.0, 3.0, 4.0, 5.0]).unwrap();
        assert_eq!(
            read_npy_f32(&path).unwrap(),
            (vec![5], vec![1.0, 2.0, 3.0, 4.0, 5.0])
        );
        let bytes = std::fs::read(&path).unwrap();
        assert!(std::str::from_utf8(&bytes[10..80])
            .unwrap()
            .contains("'shape': (5,)"));
        write_npy_f32(&path, &[], &[7.5]).unwrap();
        assert_eq!(read_npy_f32(&path).unwrap(), (vec![], vec![7.5]));
        write_npy_f32(&path, &[2, 0, 3], &[]).unwrap();
        assert_eq!(read_npy_f32(&path).unwrap(), (vec![2, 0, 3], vec![]));
    }

    #[test]
    fn errors() {
        let path = scratch("bad.npy");
        let e = write_npy_f32(&path, &[2, 3], &[0.0; 5]).unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::InvalidInput);
        assert!(e.to_string().contains("bad.npy"), "{e}");

        std::fs::write(&path, b"not numpy at all").unwrap();
        let e = read_npy_f32(&path).unwrap_err().to_string();
        assert!(e.contains("bad.npy") && e.contains("bad magic"), "{e}");

        write_npy_f32(&path, &[4], &[1.0; 4]).unwrap();
        let mut bytes = std::fs::read(&path).unwrap();
        bytes.truncate(bytes.len() - 4);
        std::fs::write(&path, &bytes).unwrap();
        let e = read_npy_f32(&path).unwrap_err().to_string();
        assert!(e.contains("needs 4 values"), "{e}");

        let at = bytes.windows(3).position(|w| w == b"<f4").unwrap();
        bytes[at + 2] = b'8';
        std::fs::write(&path, &bytes).unwrap();
        let e = read_npy_f32(&path).unwrap_err().to_string();
        assert!(e.contains("'<f8'"), "{e}");

        let e = read_npy_f32(&scratch("missing.npy")).unwrap_err();
        assert!(matches!(e, NpyError::Io { .. }), "{e}");
    }
}
