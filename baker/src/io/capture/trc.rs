//! TRC: the Motion Analysis marker text format (also OpenSim's).
//!
//! ```text
//! PathFileType  4  (X/Y/Z)  name.trc
//! DataRate  CameraRate  NumFrames  NumMarkers  Units  OrigDataRate  OrigDataStartFrame  OrigNumFrames
//! 60        60          1590       41          cm     60            1                   1590
//! Frame#  Time  ForeHead_M        ForeHead_L        ...
//!               X1   Y1   Z1      X2   Y2   Z2      ...
//!
//! 1       0     14.1 84.2 3.5     18.4 82.5 2.2     ...
//! ```
//!
//! Cells are tab separated; a line without tabs is split at whitespace instead. The header
//! values are found by their key on line 2 (`DataRate`, `NumFrames`, `NumMarkers` and `Units`
//! are required, the others ignored). The component line (`X1 Y1 Z1 …`) and blank lines are
//! skipped. Every data line has `Frame#`, `Time` and three cells per marker (trailing empty
//! cells past those are ignored); a blank or `NaN` cell is missing, and a marker sample with any
//! coordinate missing is a missing sample. `NumFrames` and `NumMarkers` must match the data.

use super::text::{self, Errors};
use super::{Capture, CaptureError};
use std::path::Path;

/// Splits a line into cells: at tabs if it has any (cells keep their place even when empty),
/// otherwise at runs of whitespace.
fn cells(line: &str) -> Vec<&str> {
    if line.contains('\t') {
        line.split('\t').map(str::trim).collect()
    } else {
        line.split_whitespace().collect()
    }
}

/// Parses the bytes of a TRC file; `path` is only used in errors and as the capture's source.
pub(super) fn parse(path: &Path, bytes: &[u8]) -> Result<Capture, CaptureError> {
    let e = Errors { path };
    let text = e.decode(bytes)?;
    let mut lines = text.lines().enumerate().map(|(i, l)| (i + 1, l));
    let mut header_line = |what: &str| {
        lines.next().ok_or_else(|| {
            e.whole(format!(
                "file ends before the TRC header is complete (no {what} line)"
            ))
        })
    };

    let (n, first) = header_line("PathFileType")?;
    if !first
        .trim_start()
        .to_ascii_lowercase()
        .starts_with("pathfiletype")
    {
        return Err(e.at(n, "not a TRC file: expected a PathFileType line"));
    }
    let (keys_line, keys) = header_line("header key")?;
    let (values_line, values) = header_line("header value")?;
    let keys = cells(keys);
    let values = cells(values);
    let value = |key: &str| -> Result<&str, CaptureError> {
        let i = keys
            .iter()
            .position(|k| k.eq_ignore_ascii_case(key))
            .ok_or_else(|| e.at(keys_line, format!("header has no {key} key")))?;
        values
            .get(i)
            .copied()
            .filter(|v| !v.is_empty())
            .ok_or_else(|| {
                e.at(
                    values_line,
                    format!("no value for {key} (column {})", i + 1),
                )
            })
    };
    let count = |key: &str| -> Result<usize, CaptureError> {
        let v = value(key)?;
        v.parse::<usize>()
            .map_err(|_| e.at(values_line, format!("{key} {v:?} is not a count")))
    };
    let rate_hz = e.rate(values_line, value("DataRate")?)?;
    let units = e.units(values_line, value("Units")?)?;
    let num_frames = count("NumFrames")?;
    let num_markers = count("NumMarkers")?;

    let (names_line, names) = header_line("Frame#/Time/marker names")?;
    let names = cells(names);
    if !names
        .first()
        .is_some_and(|c| c.eq_ignore_ascii_case("frame#"))
    {
        return Err(e.at(
            names_line,
            "expected the Frame#, Time and marker names line",
        ));
    }
    let marker_names: Vec<String> = names
        .iter()
        .skip(2)
        .filter(|c| !c.is_empty())
        .map(|c| c.to_string())
        .collect();
    if marker_names.len() != num_markers {
        return Err(e.at(
            names_line,
            format!(
                "NumMarkers is {num_markers} (line {values_line}) but this line names {} markers",
                marker_names.len()
            ),
        ));
    }
    e.names(names_line, &marker_names)?;

    let columns = 2 + 3 * num_markers;
    let mut frames = Vec::with_capacity(num_frames.min(1 << 20));
    for (n, line) in lines {
        let mut row = cells(line);
        let first = row.iter().find(|c| !c.is_empty());
        let is_component_line = frames.is_empty()
            && first.is_some_and(|c| {
                c.len() > 1
                    && c.starts_with(['X', 'x'])
                    && c[1..].bytes().all(|b| b.is_ascii_digit())
            });
        if first.is_none() || is_component_line {
            continue;
        }
        while row.len() > columns && row.last() == Some(&"") {
            row.pop();
        }
        if row.len() != columns {
            return Err(e.at(
                n,
                format!(
                    "wrong column count: expected {columns} (Frame#, Time and 3 for each of {num_markers} markers), found {}",
                    row.len()
                ),
            ));
        }
        if e.cell(n, 1, row[0])?.is_none() {
            return Err(e.at(n, "missing frame number in column 1"));
        }
        e.cell(n, 2, row[1])?;
        let frame = row[2..]
            .chunks(3)
            .enumerate()
            .map(|(m, xyz)| e.sample(n, 3 + 3 * m, xyz))
            .collect::<Result<Vec<_>, _>>()?;
        frames.push(frame);
    }
    if frames.len() != num_frames {
        return Err(e.at(
            values_line,
            format!(
                "NumFrames is {num_frames} but the file has {} data rows",
                frames.len()
            ),
        ));
    }
    Ok(Capture {
        source: path.to_path_buf(),
        rate_hz,
        units,
        marker_names,
        frames,
    })
}

/// Renders `capture` as tab-separated TRC text. Call [`Capture::check_writable`] first.
pub(super) fn render(path: &Path, capture: &Capture) -> Result<String, CaptureError> {
    use std::fmt::Write;
    text::check_names(path, &capture.marker_names, '\t')?;
    let file_name = path
        .file_name()
        .map(|f| f.to_string_lossy().replace(['\t', '\n', '\r'], " "))
        .unwrap_or_default();
    let (rate, n, m) = (
        capture.rate_hz,
        capture.frames.len(),
        capture.marker_names.len(),
    );
    let mut out = String::new();
    let _ = writeln!(out, "PathFileType\t4\t(X/Y/Z)\t{file_name}");
    out.push_str("DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames\n");
    let _ = writeln!(
        out,
        "{rate}\t{rate}\t{n}\t{m}\t{}\t{rate}\t1\t{n}",
        capture.units
    );
    out.push_str("Frame#\tTime");
    for name in &capture.marker_names {
        let _ = write!(out, "\t{name}\t\t");
    }
    out.push_str("\n\t");
    for i in 1..=m {
        let _ = write!(out, "\tX{i}\tY{i}\tZ{i}");
    }
    out.push_str("\n\n");
    for (f, frame) in capture.frames.iter().enumerate() {
        let _ = write!(out, "{}\t{}", f + 1, f as f64 / rate);
        for sample in frame {
            text::push_sample(&mut out, sample, '\t');
        }
        out.push('\n');
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::super::tests::JAW_TRC;
    use super::super::{read_capture, write_trc, Units};
    use super::*;

    fn jaw() -> Capture {
        read_capture(Path::new(JAW_TRC)).unwrap()
    }

    /// The first frames of a few JawMoCap markers, as TRC bytes.
    pub(crate) fn small_trc() -> Vec<u8> {
        let mut c = jaw().select(&["ForeHead_M", "NoseTop", "Chin_L2"]).unwrap();
        c.frames.truncate(4);
        c.frames[1][1] = None;
        render(Path::new("small.trc"), &c).unwrap().into_bytes()
    }

    fn err(text: &str) -> String {
        parse(Path::new("bad.trc"), text.as_bytes())
            .unwrap_err()
            .to_string()
    }

    const HEAD: &str = "PathFileType\t4\t(X/Y/Z)\tbad.trc\n\
        DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\n\
        60\t60\t2\t2\tmm\n\
        Frame#\tTime\tA\t\t\tB\t\t\n\
        \t\tX1\tY1\tZ1\tX2\tY2\tZ2\n\n";

    #[test]
    fn jaw_mocap_reads_whole() {
        let c = jaw();
        assert_eq!(c.marker_names.len(), 41);
        assert_eq!(c.frame_count(), 1590);
        assert_eq!(c.rate_hz, 60.0);
        assert_eq!(c.units, Units::Centimetres);
        assert_eq!(c.missing_count(), 0);
        assert_eq!(
            &c.marker_names[..5],
            [
                "ForeHead_M",
                "ForeHead_L",
                "ForeHead_R",
                "Leyebrow_M",
                "Leyebrow_Inside"
            ]
        );
        assert_eq!(c.marker_names[40], "Chin_L2");
        assert!(c.frames.iter().all(|f| f.len() == 41));
        // First and last cells of the file, as written there.
        assert_eq!(c.frames[0][0], Some([14.123840, 84.155664, 3.480625]));
        assert_eq!(c.frames[1589][40], Some([19.593021, 68.534467, -0.279507]));
        // Every sample lies in the range the capture's metadata records.
        let (lo, hi) = ([7.0218, 63.0423, -2.946], [21.2218, 84.8209, 8.3325]);
        for p in c.frames.iter().flatten().flatten() {
            for k in 0..3 {
                assert!(p[k] >= lo[k] - 1e-4 && p[k] <= hi[k] + 1e-4, "{p:?}");
            }
        }
    }

    #[test]
    fn round_trips_through_write_trc() {
        let dir = std::env::temp_dir().join(format!("facebake-trc-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("jaw.trc");
        let mut c = jaw();
        c.frames[3][7] = None;
        c.frames[9][0] = None;
        c.rate_hz = 59.94;
        write_trc(&path, &c).unwrap();
        let back = read_capture(&path).unwrap();
        assert_eq!(back.source, path);
        assert_eq!(back.rate_hz, c.rate_hz);
        assert_eq!(back.units, c.units);
        assert_eq!(back.marker_names, c.marker_names);
        assert_eq!(back.frames, c.frames);
        assert_eq!(back.missing_count(), 2);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn whitespace_separated_and_nan_cells() {
        let text = "PathFileType 4 (X/Y/Z) w.trc\n\
            DataRate CameraRate NumFrames NumMarkers Units\n\
            100 100 2 2 in\n\
            Frame# Time A B\n\
            X1 Y1 Z1 X2 Y2 Z2\n\
            1 0 1 2 3 4 5 6\n\
            2 0.01 NaN 2 3 4 5 6e-1\n";
        let c = parse(Path::new("w.trc"), text.as_bytes()).unwrap();
        assert_eq!((c.rate_hz, c.units), (100.0, Units::Inches));
        assert_eq!(c.marker_names, ["A", "B"]);
        assert_eq!(
            c.frames[0],
            vec![Some([1.0, 2.0, 3.0]), Some([4.0, 5.0, 6.0])]
        );
        assert_eq!(c.frames[1], vec![None, Some([4.0, 5.0, 0.6])]);
    }

    #[test]
    fn errors_name_file_line_and_problem() {
        let ok = format!("{HEAD}1\t0\t1\t2\t3\t4\t5\t6\n2\t0.1\t1\t2\t3\t\t\t\n");
        let c = parse(Path::new("bad.trc"), ok.as_bytes()).unwrap();
        assert_eq!(c.frames[1], vec![Some([1.0, 2.0, 3.0]), None]);

        let row1 = "1\t0\t1\t2\t3\t4\t5\t6\n";
        let cases: Vec<(String, &str)> = vec![
            (
                format!("{HEAD}{row1}2\t0.1\t1\t2\t3\t4\t5\n"),
                "line 8: wrong column count: expected 8",
            ),
            (
                format!("{HEAD}{row1}2\t0.1\t1\tabc\t3\t4\t5\t6\n"),
                "line 8: non-numeric cell \"abc\" in column 4",
            ),
            (
                format!("{HEAD}{row1}"),
                "line 3: NumFrames is 2 but the file has 1 data rows",
            ),
            (
                HEAD.replace("A\t\t\tB", "A\t\t\tA"),
                "line 4: duplicate marker name \"A\"",
            ),
            (
                HEAD.replace("\tB\t\t", ""),
                "line 4: NumMarkers is 2 (line 3) but this line names 1 markers",
            ),
            (
                HEAD.replace("mm", "furlongs"),
                "line 3: unknown units \"furlongs\"",
            ),
            (
                HEAD.replace("60\t60", "-5\t60"),
                "line 3: invalid rate \"-5\"",
            ),
            (
                HEAD.replace("NumFrames", "Frames"),
                "line 2: header has no NumFrames key",
            ),
            (
                HEAD[..60].to_string(),
                "file ends before the TRC header is complete",
            ),
            ("hello\n".to_string(), "line 1: not a TRC file"),
        ];
        for (text, expected) in &cases {
            let e = err(text);
            assert!(e.contains(&format!("bad.trc: {expected}")), "{e}");
        }
        let e = parse(Path::new("bad.trc"), b"PathFileType\n\xff\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("bad.trc: line 2: not UTF-8 text"), "{e}");
    }

    #[test]
    fn no_panic_on_truncation_or_corruption() {
        let bytes = small_trc();
        let full = parse(Path::new("small.trc"), &bytes).unwrap();
        assert_eq!((full.frame_count(), full.missing_count()), (4, 1));
        super::super::tests::assert_no_panics(&bytes, |b| {
            parse(Path::new("small.trc"), b).map(drop)
        });
    }
}
