//! Discontinuity masks as images in the mesh's cylindrical projection (paper 000 §4.3: "a
//! texture is defined in the cylindrical coordinate space of each model"; §6.1 renders such masks
//! for new meshes through the same projection).
//!
//! One 8-bit grey PNG per mask. The projection wraps around the vertical (y) axis through the
//! centre of the mesh's bounds: the image's x runs with the angle `atan2(x, z)` from the back of
//! the head (left edge) through the front (the middle column) round to the back again, its y
//! from the top of the mesh (row 0) to the bottom. A pixel of at least [`UPPER_MIN`] puts the
//! vertices that land on it on the mask's upper side (upper lip, upper eyelid), one of at most
//! [`LOWER_MAX`] on the lower side; anything between leaves them unmasked. Like a texture, the
//! image only labels the surface it sees: a vertex hidden behind another part of the mesh at its
//! pixel (inside the mouth, the inner side of closed lips) is left unlabelled, and the masks give
//! it the side of the nearest labelled vertex along the surface.
//! [`write_sides`] renders a mask's sides into such an image: a template to paint on.

use std::path::{Path, PathBuf};

use thiserror::Error;

use crate::model::Side;

/// A vertex further inside than this fraction of the bounding-box diagonal behind the outermost
/// surface at its pixel is hidden from the image.
pub const HIDDEN_FRACTION: f64 = 0.01;

/// Largest width or height of a mask image read, pixels (the largest `facebake mask-images`
/// writes). Checked from the PNG header before any buffer is allocated, as the header alone
/// sizes the buffers: reading costs 9 to 12 bytes a pixel (the decoded image, one to four bytes,
/// and an f64 depth buffer), so at most about 800 MB.
pub const MAX_SIDE: u32 = 8192;

/// Grey level written for the upper side.
pub const UPPER: u8 = 255;
/// Grey level written for the lower side.
pub const LOWER: u8 = 0;
/// Grey level written where no mask applies.
pub const UNMASKED: u8 = 128;
/// Pixels at or above this are the upper side.
pub const UPPER_MIN: u8 = 192;
/// Pixels at or below this are the lower side.
pub const LOWER_MAX: u8 = 63;

/// A mask image could not be read or written.
#[derive(Debug, Error)]
pub enum MaskImageError {
    /// The file could not be opened, read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The file is not a PNG the reader understands.
    #[error("{}: not a readable PNG: {message}", path.display())]
    Decode {
        /// The file.
        path: PathBuf,
        /// What the decoder said.
        message: String,
    },
    /// The image decodes but cannot serve as a mask.
    #[error("{}: {message}", path.display())]
    Content {
        /// The file.
        path: PathBuf,
        /// The problem.
        message: String,
    },
}

/// The cylindrical projection of a mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cylinder {
    centre_x: f64,
    centre_z: f64,
    y_top: f64,
    y_bottom: f64,
}

impl Cylinder {
    /// The projection around the vertical axis through the centre of `positions`' bounds.
    pub fn of(positions: &[[f64; 3]]) -> Self {
        let (lo, hi) = crate::model::bounds(positions.iter().copied());
        Self {
            centre_x: 0.5 * (lo[0] + hi[0]),
            centre_z: 0.5 * (lo[2] + hi[2]),
            y_top: hi[1],
            y_bottom: lo[1],
        }
    }

    /// (u, v) in [0, 1]: u the angle from the back of the head round through the front (0.5),
    /// v from the top (0) to the bottom (1).
    pub fn project(&self, p: &[f64; 3]) -> [f64; 2] {
        let angle = (p[0] - self.centre_x).atan2(p[2] - self.centre_z);
        let u = 0.5 + angle / (2.0 * std::f64::consts::PI);
        let height = (self.y_top - self.y_bottom).max(f64::MIN_POSITIVE);
        [
            u.clamp(0.0, 1.0),
            ((self.y_top - p[1]) / height).clamp(0.0, 1.0),
        ]
    }

    /// Distance from the projection's axis.
    pub fn radius(&self, p: &[f64; 3]) -> f64 {
        (p[0] - self.centre_x).hypot(p[2] - self.centre_z)
    }

    fn pixel(&self, p: &[f64; 3], width: usize, height: usize) -> (usize, usize) {
        let [u, v] = self.project(p);
        let x = ((u * width as f64) as usize).min(width - 1);
        let y = ((v * (height - 1) as f64).round() as usize).min(height - 1);
        (x, y)
    }
}

/// The glTF vertices a mask image puts on the upper and on the lower side: those it sees (see the
/// module docs) on a pixel of either side's grey level.
pub fn read_sides(
    path: &Path,
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
) -> Result<(Vec<u32>, Vec<u32>), MaskImageError> {
    let file = std::fs::File::open(path).map_err(|source| MaskImageError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let decode = |message: String| MaskImageError::Decode {
        path: path.to_path_buf(),
        message,
    };
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
    let mut reader = decoder.read_info().map_err(|e| decode(e.to_string()))?;
    let (w, h) = (reader.info().width, reader.info().height);
    if w > MAX_SIDE || h > MAX_SIDE {
        return Err(MaskImageError::Content {
            path: path.to_path_buf(),
            message: format!(
                "the header says {w} × {h} pixels; mask images are read up to {MAX_SIDE} × \
                 {MAX_SIDE} pixels"
            ),
        });
    }
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| decode("the image is too large".into()))?;
    let mut buf = vec![0u8; size];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| decode(e.to_string()))?;
    let (width, height) = (info.width as usize, info.height as usize);
    let channels = info.color_type.samples();
    if width < 2 || height < 2 {
        return Err(MaskImageError::Content {
            path: path.to_path_buf(),
            message: format!("{width} × {height} pixels is too small for a mask"),
        });
    }
    let cylinder = Cylinder::of(positions);
    // Depth: per pixel the largest distance from the axis of any triangle covering it.
    let radius = |p: &[f64; 3]| cylinder.radius(p);
    let mut depth = vec![f64::NEG_INFINITY; width * height];
    for_each_triangle(&cylinder, positions, triangles, width, height, |q, t| {
        let r = t
            .iter()
            .map(|&i| radius(&positions[i]))
            .fold(f64::MIN, f64::max);
        fill_triangle(width, height, q, |at| depth[at] = depth[at].max(r));
    });
    let (lo, hi) = crate::model::bounds(positions.iter().copied());
    let tolerance = HIDDEN_FRACTION * crate::mesh::distance(&lo, &hi);
    let (mut upper, mut lower) = (Vec::new(), Vec::new());
    for (v, p) in positions.iter().enumerate() {
        let (x, y) = cylinder.pixel(p, width, height);
        if radius(p) < depth[y * width + x] - tolerance {
            continue; // hidden behind the surface the image shows
        }
        // The first channel: grey, or red of an RGB(A) image.
        let value = buf[y * info.line_size + x * channels];
        if value >= UPPER_MIN {
            upper.push(v as u32);
        } else if value <= LOWER_MAX {
            lower.push(v as u32);
        }
    }
    if upper.is_empty() || lower.is_empty() {
        return Err(MaskImageError::Content {
            path: path.to_path_buf(),
            message: format!(
                "the image puts {} vertices on the upper side and {} on the lower: a mask needs both \
                 (white ≥ {UPPER_MIN} upper, black ≤ {LOWER_MAX} lower, in the cylindrical projection)",
                upper.len(),
                lower.len()
            ),
        });
    }
    Ok((upper, lower))
}

/// Render a mask's sides into a `width` × `height` grey PNG in the cylindrical projection:
/// every triangle whose three vertices are on the same side with a strength of at least ½ is
/// filled with [`UPPER`] or [`LOWER`], the rest of the image is [`UNMASKED`]. Triangles that
/// cross the back seam are left out.
pub fn write_sides(
    path: &Path,
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
    side: &[Option<Side>],
    strength: &[f64],
    width: usize,
    height: usize,
) -> Result<(), MaskImageError> {
    let cylinder = Cylinder::of(positions);
    let mut image = vec![UNMASKED; width * height];
    let mut depth = vec![f64::NEG_INFINITY; width * height];
    for_each_triangle(
        &cylinder,
        positions,
        triangles,
        width,
        height,
        |q, [a, b, c]| {
            let r = [a, b, c]
                .iter()
                .map(|&i| cylinder.radius(&positions[i]))
                .fold(f64::MIN, f64::max);
            let strong = [a, b, c]
                .iter()
                .all(|&i| strength.get(i).is_some_and(|&w| w >= 0.5));
            let value = match (side.get(a), side.get(b), side.get(c)) {
                (Some(Some(s)), Some(Some(s2)), Some(Some(s3))) if strong && s == s2 && s == s3 => {
                    if *s == Side::Upper {
                        UPPER
                    } else {
                        LOWER
                    }
                }
                _ => UNMASKED,
            };
            // The outermost surface at a pixel decides its value, as the reader sees it.
            fill_triangle(width, height, q, |at| {
                if r >= depth[at] {
                    depth[at] = r;
                    image[at] = value;
                }
            });
        },
    );
    let file = std::fs::File::create(path).map_err(|source| MaskImageError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let io = |e: png::EncodingError| MaskImageError::Io {
        path: path.to_path_buf(),
        source: std::io::Error::other(e.to_string()),
    };
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), width as u32, height as u32);
    encoder.set_color(png::ColorType::Grayscale);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().map_err(io)?;
    writer.write_image_data(&image).map_err(io)?;
    writer.finish().map_err(io)
}

/// Call `f` with every mesh triangle's corners in pixel coordinates and its vertex indices,
/// leaving out triangles that cross the back seam.
fn for_each_triangle(
    cylinder: &Cylinder,
    positions: &[[f64; 3]],
    triangles: &[[u32; 3]],
    width: usize,
    height: usize,
    mut f: impl FnMut([[f64; 2]; 3], [usize; 3]),
) {
    let scale = |p: &[f64; 3]| {
        let [u, v] = cylinder.project(p);
        [u * width as f64, v * (height - 1) as f64]
    };
    for t in triangles {
        let idx = t.map(|i| i as usize);
        if idx.iter().any(|&i| i >= positions.len()) {
            continue;
        }
        let q = idx.map(|i| scale(&positions[i]));
        let us = q.map(|p| p[0]);
        let spread = us.iter().copied().fold(f64::MIN, f64::max)
            - us.iter().copied().fold(f64::MAX, f64::min);
        if spread <= 0.5 * width as f64 {
            f(q, idx);
        }
    }
}

/// Call `set` with the index of every pixel whose centre lies inside the triangle `q` (pixel
/// coordinates), and of the pixels of its corners, so that thin triangles still mark their
/// vertices.
fn fill_triangle(width: usize, height: usize, q: [[f64; 2]; 3], mut set: impl FnMut(usize)) {
    let edge = |a: [f64; 2], b: [f64; 2], p: [f64; 2]| {
        (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
    };
    let area = edge(q[0], q[1], q[2]);
    let range = |c: usize, limit: usize| {
        let lo = q
            .iter()
            .map(|p| p[c])
            .fold(f64::MAX, f64::min)
            .floor()
            .max(0.0) as usize;
        let hi = (q
            .iter()
            .map(|p| p[c])
            .fold(f64::MIN, f64::max)
            .ceil()
            .max(0.0) as usize)
            .min(limit - 1);
        lo..=hi
    };
    if area.abs() > 1e-12 {
        for y in range(1, height) {
            for x in range(0, width) {
                let p = [x as f64 + 0.5, y as f64];
                let w = [
                    edge(q[1], q[2], p),
                    edge(q[2], q[0], p),
                    edge(q[0], q[1], p),
                ];
                if w.iter().all(|&e| e * area >= 0.0) {
                    set(y * width + x);
                }
            }
        }
    }
    for p in q {
        let (x, y) = (
            (p[0] as usize).min(width - 1),
            (p[1].round() as usize).min(height - 1),
        );
        set(y * width + x);
    }
}
