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
