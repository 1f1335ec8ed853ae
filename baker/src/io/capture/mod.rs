//! Marker-capture readers and writers: TRC, CSV and C3D files into one [`Capture`].
//!
//! A capture is a rectangular table of frames × markers, each cell an optional 3D position in the
//! file's own length unit (see [`Units`]; [`Capture::in_metres`] converts). `None` is a missing
//! sample: a blank or `NaN` cell in the text formats, a point flagged invalid (negative residual
//! word) in C3D.
//!
//! * [`trc`]: the Motion Analysis / OpenSim text format.
//! * [`csv`]: a small comma-separated format of our own, documented in that module.
//! * [`c3d`]: the binary C3D format, all three processor formats (Intel, DEC, SGI/MIPS) and both
//!   scaled-integer and float storage; a self-contained reader (that module says why not `c3dio`).
//! * [`take`]: packed takes (`.fbt`), the runtime's compressed format: [`take::pack`] writes one,
//!   and a file that starts with the take magic is read as a take whatever its extension.
//!
//! Readers never panic on any input; every error names the file and where the problem is (the
//! 1-based line for text formats, the byte offset or the parameter for C3D).

pub mod c3d;
pub mod csv;
pub mod take;
pub mod trc;

use std::path::{Path, PathBuf};

use crate::model::{Capture, Units};

/// Everything that can go wrong reading, writing or reshaping a capture. Every variant names the
/// file it is about.
#[derive(Debug, thiserror::Error)]
pub enum CaptureError {
    /// The file could not be opened, read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: std::io::Error,
    },
    /// The file name has no extension this module reads or writes.
    #[error("{}: unsupported capture format {extension:?} (expected .trc, .csv, .c3d or .fbt)", path.display())]
    UnknownFormat {
        /// The file.
        path: PathBuf,
        /// Its extension, empty if it has none.
        extension: String,
    },
    /// A problem at one line of a text file (TRC or CSV).
    #[error("{}: line {line}: {message}", path.display())]
    Line {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong there.
        message: String,
    },
    /// A problem at one place of a binary (C3D) file.
    #[error("{}: {location}: {message}", path.display())]
    Binary {
        /// The file.
        path: PathBuf,
        /// Where: `byte N` or `parameter GROUP:NAME`.
        location: String,
        /// What is wrong there.
        message: String,
    },
    /// A problem of the file as a whole, such as a CSV file without a units line.
    #[error("{}: {message}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// [`Capture::select`] asked for markers the capture does not have.
    #[error("{}: no marker named {}", path.display(), quote_list(missing))]
    MissingMarkers {
        /// The capture's source file.
        path: PathBuf,
        /// The requested names that are not in the capture, in request order.
        missing: Vec<String>,
    },
}

fn quote_list(names: &[String]) -> String {
    names
        .iter()
        .map(|n| format!("{n:?}"))
        .collect::<Vec<_>>()
        .join(", ")
}

impl Capture {
    /// A copy holding only the markers `names`, in that order. Errors naming every requested
    /// marker the capture lacks.
    pub fn select(&self, names: &[&str]) -> Result<Capture, CaptureError> {
        let mut columns = Vec::with_capacity(names.len());
        let mut missing = Vec::new();
        for name in names {
            match self.marker_index(name) {
                Some(i) => columns.push(i),
                None => missing.push(name.to_string()),
            }
        }
        if !missing.is_empty() {
            return Err(CaptureError::MissingMarkers {
                path: self.source.clone(),
                missing,
            });
        }
        Ok(Capture {
            marker_names: names.iter().map(|n| n.to_string()).collect(),
            frames: self
                .frames
                .iter()
                .map(|frame| {
                    columns
                        .iter()
                        .map(|&c| frame.get(c).copied().flatten())
                        .collect()
                })
                .collect(),
            ..self.clone()
        })
    }

    /// Checks what the writers rely on: a rate in [`RATE_RANGE_HZ`], unique marker names and one
    /// sample per marker in every frame.
    fn check_writable(&self, path: &Path) -> Result<(), CaptureError> {
        let err = |message: String| CaptureError::File {
            path: path.to_path_buf(),
            message,
        };
        if !valid_rate(self.rate_hz) {
            return Err(err(format!(
                "cannot write a rate of {} Hz (the readers take {} to {} Hz)",
                self.rate_hz,
                RATE_RANGE_HZ.start(),
                RATE_RANGE_HZ.end()
            )));
        }
        if let Some(name) = first_duplicate(&self.marker_names) {
            return Err(err(format!("duplicate marker name {name:?}")));
        }
        if let Some((f, frame)) = self
            .frames
            .iter()
            .enumerate()
            .find(|(_, frame)| frame.len() != self.marker_names.len())
        {
            return Err(err(format!(
                "frame {f} has {} samples for {} markers",
                frame.len(),
                self.marker_names.len()
            )));
        }
        Ok(())
    }
}

/// The first name that occurs twice, if any.
fn first_duplicate(names: &[String]) -> Option<&str> {
    let mut seen = std::collections::HashSet::new();
    names
        .iter()
        .find(|n| !seen.insert(n.as_str()))
        .map(String::as_str)
}

/// Reads a capture, choosing the reader by the file extension (`.trc`, `.csv`, `.c3d`, `.fbt`,
/// in any case); a file that starts with the take magic is a packed take whatever its
/// extension. A CSV file without a `# units=` line is an error: use [`read_capture_with_units`].
pub fn read_capture(path: &Path) -> Result<Capture, CaptureError> {
    read_capture_with_units(path, None)
}

/// Capture rates the readers accept and the writers write, Hz. Bounded away from zero (a
/// subnormal rate makes the written times `frame / rate` infinite, which no reader takes back)
/// and from infinity.
pub const RATE_RANGE_HZ: std::ops::RangeInclusive<f64> = 1e-3..=1e6;

/// Whether `rate_hz` is in [`RATE_RANGE_HZ`] (so neither NaN, infinite, zero nor subnormal).
pub fn valid_rate(rate_hz: f64) -> bool {
    RATE_RANGE_HZ.contains(&rate_hz)
}

/// Reads a capture like [`read_capture`]; `units`, when given, is an explicit override that
/// replaces whatever units the file states (positions are not rescaled: the override says what
/// unit the numbers are in). It is the way to read a CSV file that has no units line.
pub fn read_capture_with_units(path: &Path, units: Option<Units>) -> Result<Capture, CaptureError> {
    let format = Format::of(path)?;
    let bytes = crate::io::read_bounded(path).map_err(|source| CaptureError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let mut capture = match format {
        _ if take::is_take(&bytes) => take::parse(path, &bytes)?,
        Format::Take => take::parse(path, &bytes)?,
        Format::Trc => trc::parse(path, &bytes)?,
        Format::Csv => csv::parse(path, &bytes, units)?,
        Format::C3d => c3d::parse(path, &bytes, units)?,
    };
    if let Some(units) = units {
        capture.units = units;
    }
    Ok(capture)
}

/// Writes `capture` as CSV (see [`csv`] for the format), readable back by [`read_capture`] to
/// the same capture.
pub fn write_csv(path: &Path, capture: &Capture) -> Result<(), CaptureError> {
    capture.check_writable(path)?;
    write_file(path, csv::render(path, capture)?)
}

/// Writes `capture` as tab-separated TRC, readable back by [`read_capture`] to the same
/// capture.
pub fn write_trc(path: &Path, capture: &Capture) -> Result<(), CaptureError> {
    capture.check_writable(path)?;
    write_file(path, trc::render(path, capture)?)
}

fn write_file(path: &Path, text: String) -> Result<(), CaptureError> {
    std::fs::write(path, text).map_err(|source| CaptureError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// The capture formats, by file extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Format {
    Trc,
    Csv,
    C3d,
    Take,
}

impl Format {
    fn of(path: &Path) -> Result<Format, CaptureError> {
        let extension = path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .unwrap_or_default();
        match extension.as_str() {
            "trc" => Ok(Format::Trc),
            "csv" => Ok(Format::Csv),
            "c3d" => Ok(Format::C3d),
            "fbt" => Ok(Format::Take),
            _ => Err(CaptureError::UnknownFormat {
                path: path.to_path_buf(),
                extension,
            }),
        }
    }
}

/// Helpers shared by the two text formats.
mod text {
    use super::{first_duplicate, CaptureError, Units};
    use std::path::{Path, PathBuf};

    /// Builds [`CaptureError::Line`] errors for one file.
    pub(super) struct Errors<'a> {
        pub(super) path: &'a Path,
    }

    impl Errors<'_> {
        pub(super) fn at(&self, line: usize, message: impl Into<String>) -> CaptureError {
            CaptureError::Line {
                path: PathBuf::from(self.path),
                line,
                message: message.into(),
            }
        }

        pub(super) fn whole(&self, message: impl Into<String>) -> CaptureError {
            CaptureError::File {
                path: PathBuf::from(self.path),
                message: message.into(),
            }
        }

        /// The file as text: UTF-8, a leading byte-order mark dropped.
        pub(super) fn decode<'b>(&self, bytes: &'b [u8]) -> Result<&'b str, CaptureError> {
            match std::str::from_utf8(bytes) {
                Ok(text) => Ok(text.strip_prefix('\u{feff}').unwrap_or(text)),
                Err(e) => {
                    let line = 1 + bytes[..e.valid_up_to()]
                        .iter()
                        .filter(|&&b| b == b'\n')
                        .count();
                    Err(self.at(line, format!("not UTF-8 text (byte {})", e.valid_up_to())))
                }
            }
        }

        /// One coordinate cell: blank or NaN is missing; anything else must be a finite number.
        pub(super) fn cell(
            &self,
            line: usize,
            column: usize,
            cell: &str,
        ) -> Result<Option<f64>, CaptureError> {
            let cell = cell.trim();
            if cell.is_empty() || cell.eq_ignore_ascii_case("nan") {
                return Ok(None);
            }
            match cell.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(Some(v)),
                Ok(_) => Err(self.at(
                    line,
                    format!("non-finite value {cell:?} in column {column}"),
                )),
                Err(_) => Err(self.at(
                    line,
                    format!("non-numeric cell {cell:?} in column {column}"),
                )),
            }
        }

        /// One marker sample from its three coordinate cells (`first_column` is the 1-based column
        /// of x): missing if any coordinate is.
        pub(super) fn sample(
            &self,
            line: usize,
            first_column: usize,
            cells: &[&str],
        ) -> Result<Option<[f64; 3]>, CaptureError> {
            let mut p = [0.0; 3];
            let mut complete = true;
            for (k, cell) in cells.iter().enumerate() {
                match self.cell(line, first_column + k, cell)? {
                    Some(v) => p[k] = v,
                    None => complete = false,
                }
            }
            Ok(complete.then_some(p))
        }

        /// A sampling rate: a number of Hz in [`RATE_RANGE_HZ`](super::RATE_RANGE_HZ).
        pub(super) fn rate(&self, line: usize, text: &str) -> Result<f64, CaptureError> {
            match text.trim().parse::<f64>() {
                Ok(r) if super::valid_rate(r) => Ok(r),
                _ => Err(self.at(
                    line,
                    format!(
                        "invalid rate {:?} (expected {} to {} Hz)",
                        text.trim(),
                        super::RATE_RANGE_HZ.start(),
                        super::RATE_RANGE_HZ.end()
                    ),
                )),
            }
        }

        pub(super) fn units(&self, line: usize, text: &str) -> Result<Units, CaptureError> {
            text.parse::<Units>()
                .map_err(|e| self.at(line, e.to_string()))
        }

        /// Marker names must be non-empty and unique.
        pub(super) fn names(&self, line: usize, names: &[String]) -> Result<(), CaptureError> {
            if let Some(i) = names.iter().position(|n| n.is_empty()) {
                return Err(self.at(line, format!("marker {} has an empty name", i + 1)));
            }
            if let Some(name) = first_duplicate(names) {
                return Err(self.at(line, format!("duplicate marker name {name:?}")));
            }
            Ok(())
        }
    }

    /// Checks that every marker name survives a text file with `separator` between cells:
    /// non-empty, no surrounding blanks, no separator or line break inside.
    pub(super) fn check_names(
        path: &Path,
        names: &[String],
        separator: char,
    ) -> Result<(), CaptureError> {
        for name in names {
            if name.is_empty() || name.trim() != name || name.contains([separator, '\n', '\r']) {
                return Err(CaptureError::File {
                    path: PathBuf::from(path),
                    message: format!("marker name {name:?} cannot be written: empty, padded, or holds {separator:?} or a line break"),
                });
            }
        }
        Ok(())
    }

    /// Formats a coordinate so that parsing it gives the same `f64` back; missing is empty.
    pub(super) fn push_sample(out: &mut String, sample: &Option<[f64; 3]>, separator: char) {
        use std::fmt::Write;
        for k in 0..3 {
            out.push(separator);
            if let Some(v) = sample.map(|p| p[k]).filter(|v| v.is_finite()) {
                let _ = write!(out, "{v}");
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    pub(crate) const JAW_TRC: &str =
        concat!(env!("CARGO_MANIFEST_DIR"), "/../fixtures/JawMoCap.trc");

    /// Feeds `parse` every truncation of `bytes` and thousands of randomly corrupted copies:
    /// each must come back `Ok` or `Err` (a panic fails the test). The whole input must parse and
    /// the empty one must not, so the parser under test is the real one.
    pub(crate) fn assert_no_panics(
        bytes: &[u8],
        parse: impl Fn(&[u8]) -> Result<(), CaptureError>,
    ) {
        assert!(parse(bytes).is_ok(), "the uncorrupted input must parse");
        assert!(parse(&[]).is_err(), "an empty input must not parse");
        let truncation_errors = (0..bytes.len())
            .filter(|&n| parse(&bytes[..n]).is_err())
            .count();
        assert!(
            truncation_errors > bytes.len() / 2,
            "{truncation_errors} of {} truncations rejected",
            bytes.len()
        );
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for round in 0..3000 {
            let mut corrupt = bytes.to_vec();
            // Half the rounds hit the first 8 KiB, where the headers and C3D parameters are.
            let span = if round % 2 == 0 {
                corrupt.len()
            } else {
                corrupt.len().min(8192)
            };
            for _ in 0..1 + round % 6 {
                let i = next() as usize % span;
                corrupt[i] = next() as u8;
            }
            let _ = parse(&corrupt);
        }
    }

    fn capture() -> Capture {
        Capture {
            source: PathBuf::from("mem.trc"),
            rate_hz: 30.0,
            units: Units::Centimetres,
            marker_names: vec!["A".into(), "B".into(), "C".into()],
            frames: vec![
                vec![Some([1.0, 2.0, 3.0]), None, Some([7.0, 8.0, 9.0])],
                vec![Some([1.5, 2.5, 3.5]), Some([4.0, 5.0, 6.0]), None],
            ],
        }
    }

    #[test]
    fn units_parse_display_and_scale() {
        for (text, units) in [
            ("mm", Units::Millimetres),
            ("MM", Units::Millimetres),
            ("Millimeters", Units::Millimetres),
            (" cm ", Units::Centimetres),
            ("centimetre", Units::Centimetres),
            ("m", Units::Metres),
            ("Metres", Units::Metres),
            ("in", Units::Inches),
            ("INCHES", Units::Inches),
        ] {
            assert_eq!(text.parse::<Units>(), Ok(units), "{text}");
            assert_eq!(units.to_string().parse::<Units>(), Ok(units));
        }
        let err = "furlongs".parse::<Units>().unwrap_err().to_string();
        assert!(err.contains("\"furlongs\""), "{err}");
        assert_eq!(Units::Millimetres.to_metres(), 0.001);
        assert_eq!(Units::Centimetres.to_metres(), 0.01);
        assert_eq!(Units::Metres.to_metres(), 1.0);
        assert_eq!(Units::Inches.to_metres(), 0.0254);
    }

    #[test]
    fn capture_counts_converts_and_selects() {
        let c = capture();
        assert_eq!(c.frame_count(), 2);
        assert_eq!(c.missing_count(), 2);
        assert_eq!(c.marker_index("B"), Some(1));
        assert_eq!(c.marker_index("b"), None);

        let m = c.in_metres();
        assert_eq!(m.units, Units::Metres);
        assert_eq!(m.frames[1][1], Some([0.04, 0.05, 0.06]));
        assert_eq!(m.frames[0][1], None);

        let s = c.select(&["C", "A"]).unwrap();
        assert_eq!(s.marker_names, ["C", "A"]);
        assert_eq!(
            s.frames[0],
            vec![Some([7.0, 8.0, 9.0]), Some([1.0, 2.0, 3.0])]
        );
        assert_eq!(s.frames[1], vec![None, Some([1.5, 2.5, 3.5])]);

        let err = c.select(&["A", "Nose", "Chin"]).unwrap_err();
        match &err {
            CaptureError::MissingMarkers { missing, .. } => assert_eq!(missing, &["Nose", "Chin"]),
            other => panic!("{other:?}"),
        }
        let msg = err.to_string();
        assert!(
            msg.contains("mem.trc") && msg.contains("\"Nose\"") && msg.contains("\"Chin\""),
            "{msg}"
        );
    }

    #[test]
    fn extension_picks_the_reader_case_insensitively() {
        let dir = std::env::temp_dir().join(format!("facebake-capture-ext-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("x.TRC");
        write_trc(&path, &capture()).unwrap();
        assert_eq!(read_capture(&path).unwrap().frames, capture().frames);

        let err = read_capture(&dir.join("x.bvh")).unwrap_err();
        assert!(matches!(err, CaptureError::UnknownFormat { .. }), "{err}");
        let err = read_capture(&dir.join("absent.c3d")).unwrap_err();
        assert!(
            matches!(err, CaptureError::Io { .. }) && err.to_string().contains("absent.c3d"),
            "{err}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn units_override_replaces_the_files_units() {
        let c = read_capture_with_units(Path::new(JAW_TRC), Some(Units::Millimetres)).unwrap();
        assert_eq!(c.units, Units::Millimetres);
        assert_eq!(read_capture(Path::new(JAW_TRC)).unwrap().frames, c.frames);
    }

    #[test]
    fn writers_refuse_inconsistent_captures() {
        let dir = std::env::temp_dir();
        let mut c = capture();
        c.marker_names[2] = "A".into();
        let err = write_csv(&dir.join("dup.csv"), &c).unwrap_err().to_string();
        assert!(err.contains("duplicate marker name \"A\""), "{err}");
        let mut c = capture();
        c.frames[1].pop();
        let err = write_trc(&dir.join("short.trc"), &c)
            .unwrap_err()
            .to_string();
        assert!(err.contains("frame 1 has 2 samples for 3 markers"), "{err}");
        let mut c = capture();
        c.rate_hz = 0.0;
        assert!(write_trc(&dir.join("zero.trc"), &c).is_err());
    }
}
