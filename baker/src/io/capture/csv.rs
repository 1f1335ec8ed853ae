//! A plain comma-separated capture format, for captures exported from spreadsheets and scripts.
//!
//! ```text
//! # rate=60
//! # units=cm
//! frame,time,ForeHead_M_x,ForeHead_M_y,ForeHead_M_z,Chin_x,Chin_y,Chin_z
//! 1,0,14.12384,84.155664,3.480625,19.59,68.53,-0.27
//! 2,0.016667,14.115985,,,19.59,68.53,NaN
//! ```
//!
//! * **Comment lines** come first and start with `#`. A comment `key=value` with the key `rate`
//!   (frames per second) or `units` (`mm`, `cm`, `m`, `in` or a long name, see
//!   [`Units`]) sets that property; a key given twice is an error; any other comment
//!   is ignored.
//! * **The header row** names the columns. A column named `frame` or `time` (any case, anywhere)
//!   is bookkeeping: checked to be numeric but otherwise unused. Every other column belongs to a
//!   marker, as three consecutive columns `Name_x,Name_y,Name_z` (suffixes in any case). Marker
//!   names must be unique and cannot hold commas: there is no quoting.
//! * **Data rows** have exactly as many cells as the header. A blank or `NaN` cell is a missing
//!   coordinate, and a sample with any coordinate missing is a missing sample. Blank lines are
//!   skipped.
//! * **Rate**: the `rate` comment, or, without one, derived from a `time` column as
//!   `(frames - 1) / (last time - first time)`. With neither, the file is rejected.
//! * **Units** are never guessed: without a `units` comment the file is rejected unless the
//!   caller gives the units ([`read_capture_with_units`](super::read_capture_with_units)).

use super::text::{self, Errors};
use super::{Capture, CaptureError, Units};
use std::path::Path;

/// What a header column holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Column {
    Frame,
    Time,
    /// Coordinate `axis` (0, 1, 2) of marker number `marker`.
    Coordinate {
        marker: usize,
        axis: usize,
    },
}

/// Parses the bytes of a CSV capture; `units` is the caller's override, needed when the file has
/// no `units` comment. `path` is only used in errors and as the capture's source.
pub(super) fn parse(
    path: &Path,
    bytes: &[u8],
    units: Option<Units>,
) -> Result<Capture, CaptureError> {
    let e = Errors { path };
    let text = e.decode(bytes)?;
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty());

    let mut rate: Option<(usize, f64)> = None;
    let mut file_units: Option<Units> = None;
    let (header_line, header) = loop {
        let (n, line) = lines
            .next()
            .ok_or_else(|| e.whole("file ends before the CSV header row"))?;
        let Some(comment) = line.strip_prefix('#') else {
            break (n, line);
        };
        let Some((key, value)) = comment.split_once('=') else {
            continue;
        };
        match key.trim().to_ascii_lowercase().as_str() {
            "rate" if rate.is_some() => return Err(e.at(n, "rate given twice")),
            "rate" => rate = Some((n, e.rate(n, value)?)),
            "units" if file_units.is_some() => return Err(e.at(n, "units given twice")),
            "units" => file_units = Some(e.units(n, value)?),
            _ => {}
        }
    };

    let (columns, marker_names) = parse_header(&e, header_line, header)?;
    let mut frames = Vec::new();
    let mut times = Vec::new();
    for (n, line) in lines {
        let cells: Vec<&str> = line.split(',').collect();
        if cells.len() != columns.len() {
            return Err(e.at(
                n,
                format!(
                    "wrong column count: expected {} (as the header on line {header_line}), found {}",
                    columns.len(),
                    cells.len()
                ),
            ));
        }
        let mut coords = vec![[None; 3]; marker_names.len()];
        for (c, (column, cell)) in columns.iter().zip(&cells).enumerate() {
            let value = e.cell(n, c + 1, cell)?;
            match *column {
                Column::Frame => {}
                Column::Time => times.push(value),
                Column::Coordinate { marker, axis } => coords[marker][axis] = value,
            }
        }
        frames.push(
            coords
                .into_iter()
                .map(|[x, y, z]| Some([x?, y?, z?]))
                .collect(),
        );
    }

    let rate_hz = match rate {
        Some((_, rate)) => rate,
        None => rate_from_times(&times, frames.len()).ok_or_else(|| {
            e.whole("no '# rate=' line and no time column with distinct first and last times to derive the rate from")
        })?,
    };
    let units = units.or(file_units).ok_or_else(|| {
        e.whole("no '# units=' line: units are not guessed; add one or pass the units explicitly")
    })?;
    Ok(Capture {
        source: path.to_path_buf(),
        rate_hz,
        units,
        marker_names,
        frames,
    })
}

/// The rate implied by evenly spaced times: `(frames - 1) / (last - first)`.
fn rate_from_times(times: &[Option<f64>], frames: usize) -> Option<f64> {
    let (first, last) = (times.first().copied()??, times.last().copied()??);
    let rate = (frames as f64 - 1.0) / (last - first);
    super::valid_rate(rate).then_some(rate)
}

/// Reads the header row into what each column holds and the marker names in order.
fn parse_header(
    e: &Errors,
    n: usize,
    header: &str,
) -> Result<(Vec<Column>, Vec<String>), CaptureError> {
    let mut columns = Vec::new();
    let mut names: Vec<String> = Vec::new();
    // The marker whose columns are being read and how many of its axes have been seen.
    let mut open: Option<(String, usize)> = None;
    for (c, cell) in header.split(',').map(str::trim).enumerate() {
        let lower = cell.to_ascii_lowercase();
        if open.is_none() && (lower == "frame" || lower == "time") {
            let column = if lower == "frame" {
                Column::Frame
            } else {
                Column::Time
            };
            if columns.contains(&column) {
                return Err(e.at(n, format!("column {} is a second {lower} column", c + 1)));
            }
            columns.push(column);
            continue;
        }
        let axis = ["_x", "_y", "_z"].iter().position(|s| lower.ends_with(s));
        // `lower` is `cell` ASCII-lowercased, so an axis suffix is two ASCII bytes of `cell` too.
        let name = if axis.is_some() {
            &cell[..cell.len() - 2]
        } else {
            cell
        };
        let expected = open.as_ref().map_or(0, |(_, seen)| *seen);
        let fits =
            axis == Some(expected) && open.as_ref().is_none_or(|(open_name, _)| open_name == name);
        if !fits {
            let want = match &open {
                Some((open_name, seen)) => format!("{open_name}{}", ["_x", "_y", "_z"][*seen]),
                None => "frame, time or a Name_x column".to_string(),
            };
            return Err(e.at(n, format!("column {} is {cell:?}, expected {want}", c + 1)));
        }
        if expected == 0 {
            names.push(name.to_string());
        }
        columns.push(Column::Coordinate {
            marker: names.len() - 1,
            axis: expected,
        });
        open = (expected < 2).then(|| (name.to_string(), expected + 1));
    }
    if let Some((name, seen)) = open {
        return Err(e.at(
            n,
            format!("marker {name:?} has {seen} of its x, y, z columns"),
        ));
    }
    e.names(n, &names)?;
    Ok((columns, names))
}

/// Renders `capture` as CSV text with `frame` and `time` columns and `rate`/`units` comments.
/// Call [`Capture::check_writable`] first.
pub(super) fn render(path: &Path, capture: &Capture) -> Result<String, CaptureError> {
    use std::fmt::Write;
    text::check_names(path, &capture.marker_names, ',')?;
    if let Some(name) = capture.marker_names.iter().find(|n| n.starts_with('#')) {
        return Err(e_whole(
            path,
            format!("marker name {name:?} cannot start a CSV header row"),
        ));
    }
    let mut out = String::new();
    let _ = writeln!(out, "# rate={}\n# units={}", capture.rate_hz, capture.units);
    out.push_str("frame,time");
    for name in &capture.marker_names {
        let _ = write!(out, ",{name}_x,{name}_y,{name}_z");
    }
    out.push('\n');
    for (f, frame) in capture.frames.iter().enumerate() {
        let _ = write!(out, "{},{}", f + 1, f as f64 / capture.rate_hz);
        for sample in frame {
            text::push_sample(&mut out, sample, ',');
        }
        out.push('\n');
    }
    Ok(out)
}

fn e_whole(path: &Path, message: String) -> CaptureError {
    Errors { path }.whole(message)
}

#[cfg(test)]
mod tests {
    use super::super::tests::JAW_TRC;
    use super::super::{read_capture, read_capture_with_units, write_csv};
    use super::*;

    fn parse_str(text: &str, units: Option<Units>) -> Result<Capture, CaptureError> {
        parse(Path::new("bad.csv"), text.as_bytes(), units)
    }

    fn err(text: &str) -> String {
        parse_str(text, None).unwrap_err().to_string()
    }

    #[test]
    fn round_trips_jaw_mocap_through_write_csv() {
        let dir = std::env::temp_dir().join(format!("facebake-csv-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("jaw.csv");
        let mut c = read_capture(Path::new(JAW_TRC)).unwrap();
        c.frames[0][40] = None;
        c.frames[100][3] = None;
        write_csv(&path, &c).unwrap();
        let back = read_capture(&path).unwrap();
        assert_eq!(back.source, path);
        assert_eq!((back.rate_hz, back.units), (60.0, Units::Centimetres));
        assert_eq!(back.marker_names, c.marker_names);
        assert_eq!(back.frames, c.frames);
        assert_eq!(back.missing_count(), 2);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn reads_the_documented_example() {
        let text = "# exported by hand\n# rate = 60\n# Units=CM\n\
            frame,time,ForeHead_M_x,ForeHead_M_y,ForeHead_M_z,Chin_X,Chin_Y,Chin_Z\n\
            1,0,14.12384,84.155664,3.480625,19.59,68.53,-0.27\n\n\
            2,0.016667,14.115985,,,19.59,68.53,NaN\n";
        let c = parse_str(text, None).unwrap();
        assert_eq!((c.rate_hz, c.units), (60.0, Units::Centimetres));
        assert_eq!(c.marker_names, ["ForeHead_M", "Chin"]);
        assert_eq!(
            c.frames[0],
            vec![
                Some([14.12384, 84.155664, 3.480625]),
                Some([19.59, 68.53, -0.27])
            ]
        );
        assert_eq!(c.frames[1], vec![None, None]);
    }

    #[test]
    fn rate_from_time_column_and_units_only_when_stated() {
        let body = "time,A_x,A_y,A_z\n0,1,2,3\n0.02,1,2,3\n0.04,1,2,3\n";
        let e = err(body);
        assert!(e.contains("bad.csv: no '# units=' line"), "{e}");
        let c = parse_str(body, Some(Units::Millimetres)).unwrap();
        assert_eq!(c.units, Units::Millimetres);
        assert!((c.rate_hz - 50.0).abs() < 1e-9, "{}", c.rate_hz);
        let e = err("# units=mm\nA_x,A_y,A_z\n1,2,3\n");
        assert!(
            e.contains("bad.csv: no '# rate=' line and no time column"),
            "{e}"
        );
        // The override also wins over a stated unit, through the public entry point.
        let dir = std::env::temp_dir().join(format!("facebake-csv-units-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("u.csv");
        std::fs::write(&path, format!("# rate=50\n# units=cm\n{body}")).unwrap();
        assert_eq!(read_capture(&path).unwrap().units, Units::Centimetres);
        assert_eq!(
            read_capture_with_units(&path, Some(Units::Inches))
                .unwrap()
                .units,
            Units::Inches
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn errors_name_file_line_and_problem() {
        let head = "# rate=60\n# units=mm\nframe,A_x,A_y,A_z,B_x,B_y,B_z\n";
        let row1 = "1,1,2,3,4,5,6\n";
        let cases: Vec<(String, &str)> = vec![
            (
                format!("{head}{row1}2,1,2,3,4,5\n"),
                "line 5: wrong column count: expected 7 (as the header on line 3), found 6",
            ),
            (
                format!("{head}{row1}2,1,abc,3,4,5,6\n"),
                "line 5: non-numeric cell \"abc\" in column 3",
            ),
            (
                format!("{head}1,1,2,3,4,inf,6\n"),
                "line 4: non-finite value \"inf\" in column 6",
            ),
            (
                head.replace("B_", "A_"),
                "line 3: duplicate marker name \"A\"",
            ),
            (
                head.replace("frame,", "time,frame,Time,"),
                "line 3: column 3 is a second time column",
            ),
            (
                head.replace("B_y", "C_y"),
                "line 3: column 6 is \"C_y\", expected B_y",
            ),
            (
                head.replace("A_x,", ""),
                "line 3: column 2 is \"A_y\", expected frame, time or a Name_x column",
            ),
            (
                head.replace(",B_z", ""),
                "line 3: marker \"B\" has 2 of its x, y, z columns",
            ),
            (
                head.replace("mm", "furlongs"),
                "line 2: unknown units \"furlongs\"",
            ),
            (
                head.replace("# units=mm", "# rate=30"),
                "line 2: rate given twice",
            ),
            (
                "# rate=60\n".to_string(),
                "file ends before the CSV header row",
            ),
        ];
        for (text, expected) in &cases {
            let e = err(text);
            assert!(e.contains(&format!("bad.csv: {expected}")), "{e}");
        }
    }

    #[test]
    fn writer_refuses_names_the_format_cannot_hold() {
        let mut c = read_capture(Path::new(JAW_TRC))
            .unwrap()
            .select(&["Chin"])
            .unwrap();
        c.marker_names[0] = "Chin,L".into();
        let e = render(Path::new("out.csv"), &c).unwrap_err().to_string();
        assert!(
            e.contains("out.csv: marker name \"Chin,L\" cannot be written"),
            "{e}"
        );
        c.marker_names[0] = "#Chin".into();
        assert!(render(Path::new("out.csv"), &c).is_err());
    }

    #[test]
    fn no_panic_on_truncation_or_corruption() {
        let mut c = read_capture(Path::new(JAW_TRC))
            .unwrap()
            .select(&["ForeHead_M", "Chin"])
            .unwrap();
        c.frames.truncate(5);
        let bytes = render(Path::new("small.csv"), &c).unwrap().into_bytes();
        super::super::tests::assert_no_panics(&bytes, |b| {
            parse(Path::new("small.csv"), b, None).map(drop)
        });
    }
}
