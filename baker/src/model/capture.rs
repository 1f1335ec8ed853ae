//! A marker capture in memory: frames × markers of optional positions, in a length unit.

use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;

/// A length unit of marker positions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Units {
    /// Millimetres (`mm`), the usual unit of optical capture systems and C3D files.
    Millimetres,
    /// Centimetres (`cm`).
    Centimetres,
    /// Metres (`m`), the unit of the baker's meshes.
    Metres,
    /// Inches (`in`).
    Inches,
}

impl Units {
    /// How many metres one of this unit is.
    pub fn to_metres(self) -> f64 {
        match self {
            Units::Millimetres => 0.001,
            Units::Centimetres => 0.01,
            Units::Metres => 1.0,
            Units::Inches => 0.0254,
        }
    }

    /// The short symbol written to files: `mm`, `cm`, `m` or `in`.
    pub fn symbol(self) -> &'static str {
        match self {
            Units::Millimetres => "mm",
            Units::Centimetres => "cm",
            Units::Metres => "m",
            Units::Inches => "in",
        }
    }
}

impl fmt::Display for Units {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.symbol())
    }
}

/// The error of parsing a [`Units`] from text: the text was no known unit.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown units {0:?} (expected mm, cm, m or in)")]
pub struct ParseUnitsError(pub String);

impl FromStr for Units {
    type Err = ParseUnitsError;

    /// Accepts the symbols `mm`, `cm`, `m`, `in` and the long names (`millimetres`,
    /// `millimeter`, `metre`, `inches`, …), case-insensitively, surrounding blanks ignored.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let lower = s.trim().to_ascii_lowercase();
        let units = match lower.as_str() {
            "mm" | "millimetre" | "millimetres" | "millimeter" | "millimeters" => {
                Units::Millimetres
            }
            "cm" | "centimetre" | "centimetres" | "centimeter" | "centimeters" => {
                Units::Centimetres
            }
            "m" | "metre" | "metres" | "meter" | "meters" => Units::Metres,
            "in" | "inch" | "inches" => Units::Inches,
            _ => return Err(ParseUnitsError(s.trim().to_string())),
        };
        Ok(units)
    }
}

/// A marker capture: `frames[f][m]` is marker `marker_names[m]` at frame `f`, sampled at
/// `rate_hz`, in `units`.
#[derive(Debug, Clone, PartialEq)]
pub struct Capture {
    /// The file it was read from (or is about to be written to).
    pub source: PathBuf,
    /// Frames per second.
    pub rate_hz: f64,
    /// The length unit of every position.
    pub units: Units,
    /// Marker names, unique, in column order.
    pub marker_names: Vec<String>,
    /// Frames × markers; every frame has one entry per marker, `None` for a missing sample.
    pub frames: Vec<Vec<Option<[f64; 3]>>>,
}

/// The span, in metres, of a capture's markers within which its units are taken to be right
/// ([`Capture::units_warning`]): a generous band round a face's (JawMoCap's 0.17 m).
pub const FACE_SPAN_M: (f64, f64) = (0.03, 1.0);

impl Capture {
    /// The column of the marker called `name` (exact match), if any.
    pub fn marker_index(&self, name: &str) -> Option<usize> {
        self.marker_names.iter().position(|n| n == name)
    }

    /// The number of frames.
    pub fn frame_count(&self) -> usize {
        self.frames.len()
    }

    /// The number of missing samples over all frames and markers.
    pub fn missing_count(&self) -> usize {
        self.frames
            .iter()
            .map(|frame| frame.iter().filter(|s| s.is_none()).count())
            .sum()
    }

    /// A warning if the markers do not span a face in the capture's units, naming the unit
    /// that would make them one: a capture whose header gives the wrong unit (a file in
    /// millimetres labelled centimetres) bakes with every threshold in metres ten times off.
    /// The span is the diagonal of the box between the 10th and the 90th percentile of the
    /// first frame with three markers or more, per axis (so a ghost sample does not count);
    /// outside [`FACE_SPAN_M`] this says so.
    pub fn units_warning(&self) -> Option<String> {
        let frame = self
            .frames
            .iter()
            .find(|f| f.iter().flatten().count() >= 3)?;
        let points: Vec<[f64; 3]> = frame.iter().flatten().copied().collect();
        let span_here = (0..3)
            .map(|axis| {
                let mut c: Vec<f64> = points.iter().map(|p| p[axis]).collect();
                c.sort_by(f64::total_cmp);
                let at = |q: f64| c[((c.len() - 1) as f64 * q).round() as usize];
                (at(0.9) - at(0.1)).powi(2)
            })
            .sum::<f64>()
            .sqrt();
        let span = span_here * self.units.to_metres();
        if (FACE_SPAN_M.0..=FACE_SPAN_M.1).contains(&span) || !span.is_finite() || span == 0.0 {
            return None;
        }
        // JawMoCap's first frame spans 0.17 m so.
        let likely = [
            Units::Millimetres,
            Units::Centimetres,
            Units::Metres,
            Units::Inches,
        ]
        .into_iter()
        .min_by(|a, b| {
            let off = |u: Units| (span_here * u.to_metres() / 0.17).ln().abs();
            off(*a).total_cmp(&off(*b))
        })
        .unwrap_or(self.units);
        let hint = if likely == self.units {
            "are they all a face's?".to_string()
        } else {
            format!(
                "if they are a face's, it is likely in {0} (--capture-units {0})",
                likely.symbol()
            )
        };
        Some(format!(
            "{}: its markers span {span:.3} m in its first frame, read in {}, where a face's span \
             about 0.17 m: {hint}",
            self.source.display(),
            self.units.symbol(),
        ))
    }

    /// A copy with every position converted to metres (and `units` = [`Units::Metres`]).
    pub fn in_metres(&self) -> Capture {
        let k = self.units.to_metres();
        Capture {
            units: Units::Metres,
            frames: self
                .frames
                .iter()
                .map(|frame| {
                    frame
                        .iter()
                        .map(|s| s.map(|p| [p[0] * k, p[1] * k, p[2] * k]))
                        .collect()
                })
                .collect(),
            ..self.clone()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fixture(name: &str) -> PathBuf {
        PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../fixtures")).join(name)
    }

    /// JawMoCap read in its own centimetres says nothing; labelled millimetres or metres, it is
    /// said to be likely in centimetres. The C3D sample (a body, 1.06 m across in millimetres)
    /// is asked whether its markers are a face's.
    #[test]
    fn a_capture_not_face_sized_in_its_units_is_named_by_its_likely_unit() {
        let mut jaw = crate::io::capture::read_capture(&fixture("JawMoCap.trc")).unwrap();
        assert_eq!(jaw.units, Units::Centimetres);
        assert_eq!(jaw.units_warning(), None);
        for wrong in [Units::Millimetres, Units::Metres] {
            jaw.units = wrong;
            let w = jaw.units_warning().expect("a warning");
            assert!(w.contains("likely in cm (--capture-units cm)"), "{w}");
        }
        let body = crate::io::capture::read_capture(&fixture("c3d/pc_real.c3d")).unwrap();
        let w = body.units_warning().expect("a warning");
        assert!(
            w.contains("span 1.057 m") && w.contains("all a face's"),
            "{w}"
        );
    }
}
