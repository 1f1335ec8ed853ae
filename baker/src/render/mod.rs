//! Pictures of a face and what a rig does to it: PNG contact sheets drawn by a small z-buffer
//! rasteriser with flat (per-face Lambert) shading, in orthographic front and side views framed
//! on the rest mesh's bounding box.
//!
//! Everything here works on plain data: rest positions and triangles (any consistent vertex
//! indexing, glTF order in the CLI), per frame the deformed positions, optionally the true ones
//! and the markers. Units are metres; labels are millimetres.
//!
//! * [`Sheet`]: chosen frames as rows. With a truth for every frame, each row shows truth,
//!   result and the per-vertex error (front, then side); otherwise the result and its
//!   displacement from rest. One colour scale for the whole sheet, with a bar labelled in mm:
//!   up to the largest displacement, or for errors up to their
//!   [`ERROR_SCALE_PERCENTILE`]th percentile, larger errors drawn in the top colour (a few
//!   badly placed mouth-interior vertices would otherwise paint the whole skin dark).
//!   A sheet may frame a few vertices close up instead of the whole head ([`Sheet::focus`]):
//!   the lips' rims, say, wherever its frames take them, where the faults people see live and
//!   the whole head gives them a few pixels.
//! * [`MarkerSheet`]: the rest mesh with the markers as numbered dots and a legend of names, so
//!   a misplaced marker is seen.

pub mod colour;
pub mod font;
pub mod image;

use std::path::{Path, PathBuf};

use colour::{colour_bar, nice_ceiling, viridis, BAR_WIDTH};
use font::{text_width, GLYPH_HEIGHT};
pub use image::{DepthBuffer, Image, Rgb};

use crate::mesh::distance;

/// Background of the sheets.
const PAPER: Rgb = [236, 236, 232];
/// Text colour.
const INK: Rgb = [20, 20, 20];
/// Albedo of the deformed (result) mesh.
const RESULT_ALBEDO: Rgb = [226, 204, 186];
/// Albedo of the true mesh, a cooler tint so the two read apart.
const TRUTH_ALBEDO: Rgb = [192, 206, 228];
/// Marker dot colour.
const MARKER: Rgb = [225, 30, 40];
/// Fraction of a panel left empty on each side of the framed box.
const MARGIN: f64 = 0.05;
/// Height of a text strip (label at scale 2 and padding), pixels.
const STRIP: usize = 2 * GLYPH_HEIGHT + 10;
/// Largest growth of a sheet's framed box beyond the rest box, per side, as a fraction of the
/// rest box's largest extent.
pub const GROWTH: f64 = 0.05;
/// Default panel size, pixels.
pub const PANEL: usize = 320;
/// A close-up's framed box (see [`Sheet::focus`]) is widened on each side by this fraction of
/// its largest extent, so that the skin round the framed rims shows: round FaceCap's mouth about
/// 16 mm each side of the jaw open's 44 × 53 mm box, the corners' folds and the chin's top.
pub const FOCUS_MARGIN: f64 = 0.3;
/// A close-up's panel is at most this many times as wide as it is tall. The demo's close-up of
/// FaceCap's eyes (blink and surprise; a box 149 mm across with the margin) draws them at 3.9
/// pixels a millimetre in 640 × 320 front panels, where square panels drew 1.9 (the whole head
/// 1.2): the lids' slit in the blink was a few pixels.
pub const FOCUS_ASPECT_MAX: f64 = 2.0;

/// A PNG could not be written.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// Encoding or writing failed.
    #[error("{}: {message}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// What failed.
        message: String,
    },
}

/// Write `image` as a PNG at `path`.
pub fn write_png(path: &Path, image: &Image) -> Result<(), RenderError> {
    let fail = |message: String| RenderError::Write {
        path: path.to_path_buf(),
        message,
    };
    let bytes = image.to_png().map_err(|e| fail(e.to_string()))?;
    std::fs::write(path, bytes).map_err(|e| fail(e.to_string()))
}

/// A viewing direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum View {
    /// From the front (+z), the subject's left (+x) on the right of the picture.
    Front,
    /// From the subject's right (−x), the face (+z) on the right of the picture.
    Side,
}

impl View {
    /// A point in view coordinates: right, up, towards the viewer.
    pub fn project(self, p: &[f64; 3]) -> [f64; 3] {
        match self {
            Self::Front => *p,
            Self::Side => [p[2], p[1], -p[0]],
        }
    }

    /// Direction to the light in view coordinates: above and in front, from the side the face
    /// is on (upper left from the front, upper right from the side), unit length.
    pub fn light(self) -> [f64; 3] {
        let x = match self {
            Self::Front => -0.40,
            Self::Side => 0.40,
        };
        let l = [x, 0.50, 0.77];
        let n = crate::mesh::norm(&l);
        l.map(|c| c / n)
    }

    /// Its name on the sheets.
    pub fn name(self) -> &'static str {
        match self {
            Self::Front => "FRONT",
            Self::Side => "SIDE",
        }
    }
}

/// How a box of the world maps onto a panel: the same scale in both views. Panels are square
/// unless a close-up's box is wider than it is tall ([`Framing::focused`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Framing {
    centre: [f64; 3],
    /// Pixels per metre.
    pub scale: f64,
    /// Panel height, pixels (and width, unless [`Framing::widths`] says otherwise).
    pub size: usize,
    /// Panel widths in the front and the side view, pixels.
    pub widths: [usize; 2],
}

impl Framing {
    /// Frame the bounding box of `points` in a `size`-pixel panel.
    pub fn new(points: &[[f64; 3]], size: usize) -> Self {
        let (lo, hi) = crate::model::bounds(
            points
                .iter()
                .copied()
                .filter(|p| p.iter().all(|x| x.is_finite())),
        );
        let extent = (0..3).map(|c| hi[c] - lo[c]).fold(0.0, f64::max);
        let scale = if extent > 0.0 && extent.is_finite() {
            size as f64 * (1.0 - 2.0 * MARGIN) / extent
        } else {
            1.0
        };
        let centre = if lo[0].is_finite() && hi[0].is_finite() {
            [0, 1, 2].map(|c| 0.5 * (lo[c] + hi[c]))
        } else {
            [0.0; 3]
        };
        Self {
            centre,
            scale,
            size,
            widths: [size; 2],
        }
    }

    /// The width of `view`'s panel, pixels.
    pub fn width(&self, view: View) -> usize {
        match view {
            View::Front => self.widths[0],
            View::Side => self.widths[1],
        }
    }

    /// Frame the rest box grown to hold the `drawn` points, but by no more than
    /// [`GROWTH`] of its largest extent on each side (so a chin pulled down stays in the panel
    /// without one stray vertex shrinking the face).
    pub fn around<'a>(
        rest: &[[f64; 3]],
        drawn: impl IntoIterator<Item = &'a [f64; 3]>,
        size: usize,
    ) -> Self {
        let finite = |p: &&[f64; 3]| p.iter().all(|x| x.is_finite());
        let (lo, hi) = crate::model::bounds(rest.iter().filter(finite).copied());
        let grow = GROWTH * (0..3).map(|c| hi[c] - lo[c]).fold(0.0, f64::max);
        let (dlo, dhi) = crate::model::bounds(drawn.into_iter().filter(finite).copied());
        let corner = |d: [f64; 3], r: [f64; 3], sign: f64| {
            [0, 1, 2].map(|c| {
                let outward = (sign * (d[c] - r[c])).clamp(0.0, grow);
                if outward.is_finite() {
                    r[c] + sign * outward
                } else {
                    r[c]
                }
            })
        };
        Self::new(&[corner(dlo, lo, -1.0), corner(dhi, hi, 1.0)], size)
    }

    /// Frame `focus` (vertex ids) close up: the box of their `rest` positions and of their
    /// positions in each of `drawn` (lists over every vertex; ids a list lacks are left out),
    /// widened by [`FOCUS_MARGIN`] of its largest extent on each side. A view whose box is
    /// wider than tall gets a panel that much wider than `size` (up to [`FOCUS_ASPECT_MAX`]), so
    /// a wide box (both eyes) is framed by its height rather than shrunk to a strip. With no
    /// focus vertex, the whole rest box ([`Framing::new`]).
    pub fn focused(rest: &[[f64; 3]], drawn: &[&[[f64; 3]]], focus: &[u32], size: usize) -> Self {
        let points: Vec<[f64; 3]> = std::iter::once(rest)
            .chain(drawn.iter().copied())
            .flat_map(|frame| focus.iter().filter_map(|&v| frame.get(v as usize).copied()))
            .filter(|p| p.iter().all(|x| x.is_finite()))
            .collect();
        if points.is_empty() {
            return Self::new(rest, size);
        }
        let (lo, hi) = crate::model::bounds(points.iter().copied());
        let widen = FOCUS_MARGIN * (0..3).map(|c| hi[c] - lo[c]).fold(0.0, f64::max);
        let (lo, hi) = (lo.map(|x| x - widen), hi.map(|x| x + widen));
        let square = Self::new(&[lo, hi], size);
        let [across, tall, deep] = [0, 1, 2].map(|c| hi[c] - lo[c]);
        if !(tall > 0.0 && tall.is_finite()) || across.max(deep) <= tall {
            return square;
        }
        // Each view as wide as its box needs at the height's scale, then one scale that fits
        // every side of both panels.
        let widths = [across, deep]
            .map(|w| (size as f64 * (w / tall).clamp(1.0, FOCUS_ASPECT_MAX)).round() as usize);
        let fill = 1.0 - 2.0 * MARGIN;
        let scale = [(size, tall), (widths[0], across), (widths[1], deep)]
            .iter()
            .map(|&(pixels, extent)| pixels as f64 * fill / extent)
            .fold(f64::INFINITY, f64::min);
        Self {
            scale,
            widths,
            ..square
        }
    }

    /// A world point in pixel space of `view`: x right, y down, depth larger nearer.
    pub fn to_pixel(&self, view: View, p: &[f64; 3]) -> [f64; 3] {
        let q = view.project(p);
        let c = view.project(&self.centre);
        let half_width = self.width(view) as f64 / 2.0;
        let half_height = self.size as f64 / 2.0;
        [
            half_width + (q[0] - c[0]) * self.scale,
            half_height - (q[1] - c[1]) * self.scale,
            q[2] - c[2],
        ]
    }
}

/// How a mesh is coloured.
#[derive(Clone, Copy, Debug)]
pub enum Paint<'a> {
    /// One albedo, shaded.
    Flat(Rgb),
    /// A per-vertex value (mm) through the colour map, 0 to `max_mm`, shaded lightly.
    Heat {
        /// One value per vertex, millimetres.
        values_mm: &'a [f64],
        /// The top of the scale.
        max_mm: f64,
    },
}

/// Draw `triangles` over `positions` seen from `view` into a fresh panel. Triangles naming
/// missing vertices, and non-finite positions, are skipped.
pub fn draw_mesh(
    view: View,
    framing: &Framing,
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
    paint: Paint<'_>,
) -> (Image, DepthBuffer) {
    let mut image = Image::new(framing.width(view), framing.size, PAPER);
    let mut depth = DepthBuffer::for_image(&image);
    let light = view.light();
    for t in triangles {
        let Some(corners) = t
            .iter()
            .map(|&v| positions.get(v as usize).copied())
            .collect::<Option<Vec<_>>>()
        else {
            continue;
        };
        let q: Vec<[f64; 3]> = corners.iter().map(|p| view.project(p)).collect();
        let n = crate::mesh::cross(
            &crate::mesh::sub(&q[1], &q[0]),
            &crate::mesh::sub(&q[2], &q[0]),
        );
        let len = crate::mesh::norm(&n);
        let lambert = if len > 0.0 {
            (crate::mesh::dot(&n, &light) / len).abs()
        } else {
            0.0
        };
        let screen = [0, 1, 2].map(|i| framing.to_pixel(view, &corners[i]));
        match paint {
            Paint::Flat(albedo) => {
                let c = albedo.map(|a| (f64::from(a) * (0.28 + 0.72 * lambert)).round() as u8);
                image::fill_triangle(&mut image, &mut depth, screen, |_| c);
            }
            Paint::Heat { values_mm, max_mm } => {
                let v = t.map(|i| values_mm.get(i as usize).copied().unwrap_or(0.0));
                let shade = 0.55 + 0.45 * lambert;
                image::fill_triangle(&mut image, &mut depth, screen, |w| {
                    let value = w[0] * v[0] + w[1] * v[1] + w[2] * v[2];
                    viridis(value / max_mm).map(|c| (f64::from(c) * shade).round() as u8)
                });
            }
        }
    }
    (image, depth)
}

/// Draw dots at `points` where they are not hidden behind the surface in `depth`.
fn draw_markers(
    image: &mut Image,
    depth: &DepthBuffer,
    view: View,
    framing: &Framing,
    points: &[[f64; 3]],
    radius: f64,
) -> Vec<Option<[f64; 2]>> {
    // A marker on the skin is at the depth of the surface under it, within a sliver.
    let tolerance = 0.01 * framing.size as f64 / framing.scale;
    points
        .iter()
        .map(|p| {
            let s = framing.to_pixel(view, p);
            let visible = (-1..=1).any(|dy| {
                (-1..=1).any(|dx| s[2] + tolerance >= depth.at(s[0] as i64 + dx, s[1] as i64 + dy))
            });
            (visible && s.iter().all(|x| x.is_finite())).then(|| {
                image.dot(s[0], s[1], radius, MARKER, [40, 0, 0]);
                [s[0], s[1]]
            })
        })
        .collect()
}

/// One frame of a take on a [`Sheet`].
#[derive(Clone, Debug, Default)]
pub struct SheetFrame {
    /// Its label (e.g. "jaw open", "frame 388").
    pub label: String,
    /// The deformed positions, one per rest vertex.
    pub positions: Vec<[f64; 3]>,
    /// The true positions, if known.
    pub truth: Option<Vec<[f64; 3]>>,
    /// Marker positions to dot on the result (empty: none).
    pub markers: Vec<[f64; 3]>,
}

/// A contact sheet of chosen frames. See the module docs.
#[derive(Clone, Debug)]
pub struct Sheet {
    /// Title line.
    pub title: String,
    /// Rest positions, metres.
    pub rest: Vec<[f64; 3]>,
    /// Triangles over them.
    pub triangles: Vec<[u32; 3]>,
    /// The frames, one row each.
    pub frames: Vec<SheetFrame>,
    /// Panel size, pixels.
    pub panel: usize,
    /// Vertices to frame close up ([`Framing::focused`]: the lips' or the lids' rims, say);
    /// empty frames the whole head.
    pub focus: Vec<u32>,
    /// The top of the colour scale, mm, to share one with another sheet (a close-up with its
    /// whole-head sheet); `None`: the drawn frames' own ([`Sheet::scale`]).
    pub scale_mm: Option<f64>,
}

/// Per-vertex distances between two position lists, millimetres (from metres).
pub fn distances_mm(a: &[[f64; 3]], b: &[[f64; 3]]) -> Vec<f64> {
    a.iter()
        .zip(b)
        .map(|(p, q)| 1000.0 * distance(p, q))
        .collect()
}

impl Sheet {
    /// Whether the sheet compares against a truth: every frame has one (of the right length).
    pub fn has_truth(&self) -> bool {
        !self.frames.is_empty()
            && self.frames.iter().all(|f| {
                f.truth
                    .as_ref()
                    .is_some_and(|t| t.len() == f.positions.len())
            })
    }

    /// The per-vertex heat values of a frame, mm: error against the truth, or displacement.
    fn heat(&self, frame: &SheetFrame) -> Vec<f64> {
        match (&frame.truth, self.has_truth()) {
            (Some(t), true) => distances_mm(&frame.positions, t),
            _ => distances_mm(&frame.positions, &self.rest),
        }
    }

    /// The top of the sheet's colour scale, mm, and whether some drawn value lies above it:
    /// [`Sheet::scale_mm`] if given, else [`heat_scale`] of the drawn frames.
    pub fn scale(&self) -> (f64, bool) {
        let heats: Vec<Vec<f64>> = self.frames.iter().map(|f| self.heat(f)).collect();
        self.scale_of(&heats)
    }

    /// [`Sheet::scale`] of the frames' `heats`.
    fn scale_of(&self, heats: &[Vec<f64>]) -> (f64, bool) {
        match self.scale_mm {
            Some(top) => (top, heats.iter().flatten().any(|&x| x > top)),
            None => heat_scale(heats, self.has_truth()),
        }
    }

    /// Draw the sheet.
    pub fn render(&self) -> Image {
        let truth = self.has_truth();
        let heats: Vec<Vec<f64>> = self.frames.iter().map(|f| self.heat(f)).collect();
        let (max_mm, clipped) = self.scale_of(&heats);
        let heat_name = if truth { "ERROR" } else { "DISPLACEMENT" };
        let mut columns: Vec<(View, &str)> = Vec::new();
        for view in [View::Front, View::Side] {
            if truth {
                columns.push((view, "TRUTH"));
            }
            columns.push((view, "RESULT"));
            columns.push((view, heat_name));
        }
        let panel = self.panel.max(64);
        // Every drawn position list: each frame's result and its truth.
        let drawn: Vec<&[[f64; 3]]> = self
            .frames
            .iter()
            .flat_map(|f| std::iter::once(f.positions.as_slice()).chain(f.truth.as_deref()))
            .collect();
        let framing = if self.focus.is_empty() {
            Framing::around(&self.rest, drawn.iter().copied().flatten(), panel)
        } else {
            Framing::focused(&self.rest, &drawn, &self.focus, panel)
        };
        // Each column's left edge, and the panels' right edge.
        let lefts: Vec<usize> = columns
            .iter()
            .scan(0, |x, (view, _)| {
                let left = *x;
                *x += framing.width(*view);
                Some(left)
            })
            .collect();
        let panels_width: usize = columns.iter().map(|(v, _)| framing.width(*v)).sum();
        let bar_space = BAR_WIDTH + 30;
        let width = panels_width + bar_space;
        let top = STRIP + STRIP;
        let row_height = STRIP + panel;
        let height = top + self.frames.len().max(1) * row_height + 6;
        let mut sheet = Image::new(width, height, PAPER);
        sheet.text(8, 6, &self.title, 2, INK);
        for ((view, what), &left) in columns.iter().zip(&lefts) {
            let text = format!("{what} {}", view.name());
            sheet.text((left + 8) as i64, (STRIP + 6) as i64, &text, 2, INK);
        }
        for (r, frame) in self.frames.iter().enumerate() {
            let y0 = top + r * row_height;
            let worst = heats[r].iter().copied().fold(0.0, f64::max);
            let label = format!(
                "{}   MAX {} {} MM",
                frame.label,
                heat_name,
                mm_text_precise(worst)
            );
            sheet.fill_rect(0, y0 as i64, panels_width, 1, [180; 3]);
            sheet.text(8, (y0 + 6) as i64, &label, 2, INK);
            for ((view, what), &left) in columns.iter().zip(&lefts) {
                let (positions, paint) = match *what {
                    "TRUTH" => (
                        frame.truth.as_deref().unwrap_or(&frame.positions),
                        Paint::Flat(TRUTH_ALBEDO),
                    ),
                    "RESULT" => (frame.positions.as_slice(), Paint::Flat(RESULT_ALBEDO)),
                    _ => (
                        frame.positions.as_slice(),
                        Paint::Heat {
                            values_mm: &heats[r],
                            max_mm,
                        },
                    ),
                };
                let (mut img, depth) =
                    draw_mesh(*view, &framing, positions, &self.triangles, paint);
                if *what == "RESULT" && !frame.markers.is_empty() {
                    draw_markers(&mut img, &depth, *view, &framing, &frame.markers, 2.0);
                }
                sheet.blit(&img, left, y0 + STRIP);
                sheet.fill_rect(left as i64, (y0 + STRIP) as i64, 1, panel, [180; 3]);
            }
        }
        let bar_height = (panel * self.frames.len().clamp(1, 2)).saturating_sub(60);
        colour_bar(
            &mut sheet,
            ((panels_width + 16) as i64, (top + STRIP + 40) as i64),
            bar_height,
            max_mm,
            clipped,
            heat_name,
        );
        sheet
    }
}

/// The error heat maps' scale tops at this percentile of the sheet's errors (every vertex of
/// every frame), rounded up to a [`nice_ceiling`]: on the demo's truth sheet 10 mm, where the
/// largest error (the tongue, which no marker sees) would make it 50 mm and the skin's errors,
/// mostly below 8 mm, would all look alike.
pub const ERROR_SCALE_PERCENTILE: f64 = 95.0;

/// The top of a sheet's colour scale for its per-frame heat values, and whether some value
/// lies above it (drawn in the top colour): errors (`errors`) up to their
/// [`ERROR_SCALE_PERCENTILE`]th percentile, displacements up to their largest, rounded up to a
/// [`nice_ceiling`].
pub fn heat_scale(heats: &[Vec<f64>], errors: bool) -> (f64, bool) {
    let values = || heats.iter().flatten().copied().filter(|x| x.is_finite());
    let largest = values().fold(0.0, f64::max);
    let top = nice_ceiling(if errors {
        percentile(values(), ERROR_SCALE_PERCENTILE)
    } else {
        largest
    });
    (top, largest > top)
}

/// The `p`th percentile (0–100, nearest rank) of `values`; 0 for none.
fn percentile(values: impl Iterator<Item = f64>, p: f64) -> f64 {
    let mut v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let rank = ((p / 100.0) * v.len() as f64).ceil() as usize;
    v[rank.clamp(1, v.len()) - 1]
}

/// A value in mm for a row label: one decimal, two below 1 mm.
fn mm_text_precise(v: f64) -> String {
    if v < 1.0 {
        format!("{v:.2}")
    } else {
        format!("{v:.1}")
    }
}

/// The rest mesh with its markers, numbered, and a legend of their names.
#[derive(Clone, Debug)]
pub struct MarkerSheet {
    /// Title line.
    pub title: String,
    /// Rest positions, metres.
    pub rest: Vec<[f64; 3]>,
    /// Triangles over them.
    pub triangles: Vec<[u32; 3]>,
    /// The markers: name and rest position.
    pub markers: Vec<(String, [f64; 3])>,
    /// Panel size, pixels.
    pub panel: usize,
}

impl MarkerSheet {
    /// Draw the sheet: front and side, then the legend.
    pub fn render(&self) -> Image {
        let panel = self.panel.max(64);
        let framing = Framing::new(&self.rest, panel);
        let line = GLYPH_HEIGHT + 5;
        let per_column = ((panel - 10) / line).max(1);
        let columns = self.markers.len().div_ceil(per_column).max(1);
        let longest = self
            .markers
            .iter()
            .enumerate()
            .map(|(i, (n, _))| text_width(&format!("{i:2} {n}"), 1))
            .max()
            .unwrap_or(0);
        let column_width = longest + 16;
        let width = 2 * panel + columns * column_width + 10;
        let height = 2 * STRIP + panel + 6;
        let mut sheet = Image::new(width, height, PAPER);
        sheet.text(8, 6, &self.title, 2, INK);
        let points: Vec<[f64; 3]> = self.markers.iter().map(|m| m.1).collect();
        for (c, view) in [View::Front, View::Side].into_iter().enumerate() {
            let (mut img, depth) = draw_mesh(
                view,
                &framing,
                &self.rest,
                &self.triangles,
                Paint::Flat(RESULT_ALBEDO),
            );
            let at = draw_markers(&mut img, &depth, view, &framing, &points, 3.0);
            for (i, p) in at.iter().enumerate() {
                if let Some([x, y]) = p {
                    img.label(
                        *x as i64 + 5,
                        *y as i64 - GLYPH_HEIGHT as i64 - 2,
                        &i.to_string(),
                        1,
                        INK,
                        [255, 255, 255],
                    );
                }
            }
            sheet.text(
                (c * panel + 8) as i64,
                (STRIP + 6) as i64,
                &format!("REST {}", view.name()),
                2,
                INK,
            );
            sheet.blit(&img, c * panel, 2 * STRIP);
        }
        for (i, (name, _)) in self.markers.iter().enumerate() {
            let x = 2 * panel + 10 + (i / per_column) * column_width;
            let y = 2 * STRIP + 5 + (i % per_column) * line;
            sheet.text(x as i64, y as i64, &format!("{i:2} {name}"), 1, INK);
        }
        sheet
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit quad facing +z, two triangles, centred at the origin.
    fn quad() -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        (
            vec![
                [-0.05, -0.05, 0.0],
                [0.05, -0.05, 0.0],
                [0.05, 0.05, 0.0],
                [-0.05, 0.05, 0.0],
            ],
            vec![[0, 1, 2], [0, 2, 3]],
        )
    }

    #[test]
    fn framing_centres_the_box_and_views_agree_on_scale() {
        let (p, _) = quad();
        let f = Framing::new(&p, 100);
        assert!((f.scale - 900.0).abs() < 1e-9);
        let c = f.to_pixel(View::Front, &[0.0, 0.0, 0.0]);
        assert_eq!([c[0], c[1]], [50.0, 50.0]);
        // Up is up the picture; the subject's left is on the right from the front.
        assert!(f.to_pixel(View::Front, &[0.0, 0.05, 0.0])[1] < 50.0);
        assert!(f.to_pixel(View::Front, &[0.05, 0.0, 0.0])[0] > 50.0);
        // From the side, the front (+z) is on the right and −x is nearer.
        assert!(f.to_pixel(View::Side, &[0.0, 0.0, 0.05])[0] > 50.0);
        assert!(f.to_pixel(View::Side, &[-0.05, 0.0, 0.0])[2] > 0.0);
    }

    #[test]
    fn framing_grows_for_drawn_points_but_only_so_far() {
        let (p, _) = quad();
        let rest = Framing::new(&p, 100);
        assert_eq!(Framing::around(&p, &p, 100), rest);
        // 2 mm beyond the 10 cm box: all of it; 1 m beyond: only 5 mm (5 %).
        let near = Framing::around(&p, &[[0.0, 0.052, 0.0]], 100);
        assert!((near.scale - 90.0 / 0.102).abs() < 1e-9);
        let far = Framing::around(&p, &[[0.0, 1.05, 0.0]], 100);
        assert!((far.scale - 90.0 / 0.105).abs() < 1e-9);
    }

    #[test]
    fn a_close_up_frames_its_vertices_where_they_go_with_a_margin() {
        let (p, _) = quad();
        // Vertices 0 and 1 (the bottom edge, 10 cm wide); vertex 1 drops 4 cm in a frame.
        let mut dropped = p.clone();
        dropped[1][1] -= 0.04;
        let f = Framing::focused(&p, &[&dropped], &[0, 1], 100);
        // The box is 10 × 4 cm, widened by 3 cm each side: 16 cm across, 10 cm tall, 6 cm
        // deep. The front panel is 1.6 times as wide as tall and frames it at 900 pixels a
        // metre, as the height does; the side's box is taller than deep, a square panel.
        assert_eq!((f.size, f.widths), (100, [160, 100]));
        assert!((f.scale - 90.0 / 0.10).abs() < 1e-9, "{}", f.scale);
        let c = f.to_pixel(View::Front, &[0.0, -0.07, 0.0]);
        assert!(
            (c[0] - 80.0).abs() < 1e-9 && (c[1] - 50.0).abs() < 1e-9,
            "{c:?}"
        );
        assert!((f.to_pixel(View::Side, &[0.0, -0.07, 0.0])[0] - 50.0).abs() < 1e-9);
        // A strip (the edge alone, 16 × 6 × 6 cm with the margin): panels at most twice as
        // wide as tall, the scale then set by the width.
        let strip = Framing::focused(&p, &[], &[0, 1], 100);
        assert_eq!(strip.widths, [200, 100]);
        assert!((strip.scale - 180.0 / 0.16).abs() < 1e-9, "{}", strip.scale);
        // A box as tall as wide keeps square panels, framed as the whole box would be.
        let all = Framing::focused(&p, &[], &[0, 1, 2, 3], 100);
        assert_eq!(all.widths, [100, 100]);
        assert_eq!(
            all,
            Framing::new(&[[-0.08, -0.08, -0.03], [0.08, 0.08, 0.03]], 100)
        );
        // Ids a frame lacks are left out; no focus frames the rest box.
        assert_eq!(
            Framing::focused(&p, &[&p[..1]], &[0, 1], 100),
            Framing::focused(&p, &[], &[0, 1], 100)
        );
        assert_eq!(
            Framing::focused(&p, &[&dropped], &[], 100),
            Framing::new(&p, 100)
        );
    }

    #[test]
    fn a_facing_quad_fills_the_framed_box_and_an_edge_on_one_nothing() {
        let (p, t) = quad();
        let f = Framing::new(&p, 100);
        let (img, _) = draw_mesh(View::Front, &f, &p, &t, Paint::Flat([200, 200, 200]));
        let drawn = img.pixels.iter().filter(|&&c| c != PAPER).count();
        assert_eq!(drawn, 90 * 90);
        let (img, _) = draw_mesh(View::Side, &f, &p, &t, Paint::Flat([200, 200, 200]));
        assert!(img.pixels.iter().all(|&c| c == PAPER));
    }

    #[test]
    fn heat_follows_the_values_and_bad_triangles_are_skipped() {
        let (p, mut t) = quad();
        t.push([0, 1, 99]);
        let f = Framing::new(&p, 40);
        let values = [0.0, 0.0, 10.0, 10.0];
        let (img, _) = draw_mesh(
            View::Front,
            &f,
            &p,
            &t,
            Paint::Heat {
                values_mm: &values,
                max_mm: 10.0,
            },
        );
        let lum = |c: Rgb| c.iter().map(|&x| u32::from(x)).sum::<u32>();
        // Bright at the top (values 10), dark at the bottom (values 0).
        assert!(lum(img.get(20, 4).unwrap()) > lum(img.get(20, 35).unwrap()) + 100);
    }

    #[test]
    fn a_few_large_errors_do_not_set_the_scale_but_displacements_do() {
        // 96 vertices off by up to 4 mm, four by 40 mm (a tongue): the errors' scale shows the
        // skin's 4 mm and clips the four; the same values as displacements keep all of them.
        let values: Vec<f64> = (0..100)
            .map(|i| if i < 96 { f64::from(i) / 24.0 } else { 40.0 })
            .collect();
        let heats = vec![values];
        assert_eq!(heat_scale(&heats, true), (5.0, true));
        assert_eq!(heat_scale(&heats, false), (50.0, false));
        assert_eq!(heat_scale(&[vec![0.0; 4]], true), (1.0, false));
        assert_eq!(heat_scale(&[], true), (1.0, false));
        assert_eq!(percentile([3.0, 1.0, 2.0].into_iter(), 50.0), 2.0);
    }

    #[test]
    fn sheets_have_the_expected_layout() {
        let (p, t) = quad();
        let moved: Vec<[f64; 3]> = p.iter().map(|q| [q[0], q[1], q[2] + 0.002]).collect();
        let frame = SheetFrame {
            label: "lifted".into(),
            positions: moved.clone(),
            truth: Some(p.clone()),
            markers: vec![p[0]],
        };
        let mut sheet = Sheet {
            title: "test".into(),
            rest: p.clone(),
            triangles: t.clone(),
            frames: vec![frame.clone(), frame],
            panel: 80,
            focus: Vec::new(),
            scale_mm: None,
        };
        assert!(sheet.has_truth());
        let img = sheet.render();
        assert_eq!(img.width, 6 * 80 + BAR_WIDTH + 30);
        assert_eq!(img.height, 2 * STRIP + 2 * (STRIP + 80) + 6);
        // The error here is 2 mm everywhere: its own scale tops at 2, a shared one where given.
        assert_eq!(sheet.scale(), (2.0, false));
        sheet.scale_mm = Some(1.0);
        assert_eq!(sheet.scale(), (1.0, true));
        // A close-up of the bottom edge, a strip: each column as wide as its view's panel.
        sheet.focus = vec![0, 1];
        let f = Framing::focused(&p, &[&moved, &p], &[0, 1], 80);
        assert!(f.widths[0] > f.widths[1] && f.widths[1] >= 80, "{f:?}");
        let img = sheet.render();
        assert_eq!(img.width, 3 * (f.widths[0] + f.widths[1]) + BAR_WIDTH + 30);
        assert_eq!(img.height, 2 * STRIP + 2 * (STRIP + 80) + 6);
        sheet.focus.clear();
        sheet.frames[1].truth = None;
        assert!(!sheet.has_truth());
        assert_eq!(sheet.render().width, 4 * 80 + BAR_WIDTH + 30);
        let markers = MarkerSheet {
            title: "markers".into(),
            rest: p,
            triangles: t,
            markers: vec![("A".into(), [0.0, 0.0, 0.0])],
            panel: 80,
        };
        let img = markers.render();
        assert!(img.pixels.contains(&MARKER));
    }
}
