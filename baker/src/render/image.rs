//! An RGB image with a z-buffer rasteriser for triangles, filled rectangles, dots and text.

use super::font::{glyph, ADVANCE, GLYPH_HEIGHT, GLYPH_WIDTH};

/// An RGB colour.
pub type Rgb = [u8; 3];

/// An RGB image, row-major from the top-left pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// The pixels, `width × height`, row-major.
    pub pixels: Vec<Rgb>,
}

/// A vertex in pixel space: x right, y down (pixel centres at `i + 0.5`), and depth, larger
/// nearer the viewer.
pub type ScreenPoint = [f64; 3];

impl Image {
    /// An image filled with `background`.
    pub fn new(width: usize, height: usize, background: Rgb) -> Self {
        Self {
            width,
            height,
            pixels: vec![background; width * height],
        }
    }

    /// The pixel at (`x`, `y`), or `None` outside.
    pub fn get(&self, x: usize, y: usize) -> Option<Rgb> {
        (x < self.width && y < self.height).then(|| self.pixels[y * self.width + x])
    }

    /// Set the pixel at (`x`, `y`) (ignored outside the image).
    pub fn set(&mut self, x: i64, y: i64, c: Rgb) {
        if x >= 0 && y >= 0 && (x as usize) < self.width && (y as usize) < self.height {
            self.pixels[y as usize * self.width + x as usize] = c;
        }
    }

    /// Fill the rectangle with top-left corner (`x`, `y`), clipped to the image.
    pub fn fill_rect(&mut self, x: i64, y: i64, w: usize, h: usize, c: Rgb) {
        for yy in y..y + h as i64 {
            for xx in x..x + w as i64 {
                self.set(xx, yy, c);
            }
        }
    }

    /// Copy `other` with its top-left corner at (`x`, `y`).
    pub fn blit(&mut self, other: &Image, x: usize, y: usize) {
        for row in 0..other.height {
            for col in 0..other.width {
                self.set(
                    (x + col) as i64,
                    (y + row) as i64,
                    other.pixels[row * other.width + col],
                );
            }
        }
    }

    /// A filled disc of `radius` pixels at (`cx`, `cy`) with a one-pixel `outline`.
    pub fn dot(&mut self, cx: f64, cy: f64, radius: f64, fill: Rgb, outline: Rgb) {
        let r = radius + 1.0;
        for y in (cy - r).floor() as i64..=(cy + r).ceil() as i64 {
            for x in (cx - r).floor() as i64..=(cx + r).ceil() as i64 {
                let d = ((x as f64 + 0.5 - cx).powi(2) + (y as f64 + 0.5 - cy).powi(2)).sqrt();
                if d <= radius {
                    self.set(x, y, fill);
                } else if d <= r {
                    self.set(x, y, outline);
                }
            }
        }
    }

    /// Draw `text` with its top-left corner at (`x`, `y`), each font pixel `scale` × `scale`.
    pub fn text(&mut self, x: i64, y: i64, text: &str, scale: usize, c: Rgb) {
        for (i, ch) in text.chars().enumerate() {
            let rows = glyph(ch);
            let x0 = x + (i * ADVANCE * scale) as i64;
            for (r, bits) in rows.iter().enumerate() {
                for col in 0..GLYPH_WIDTH {
                    if bits & (1 << (GLYPH_WIDTH - 1 - col)) != 0 {
                        let px = x0 + (col * scale) as i64;
                        let py = y + (r * scale) as i64;
                        self.fill_rect(px, py, scale, scale, c);
                    }
                }
            }
        }
    }

    /// `text` on a filled box one pixel larger all round.
    pub fn label(&mut self, x: i64, y: i64, text: &str, scale: usize, c: Rgb, background: Rgb) {
        let w = super::font::text_width(text, scale);
        self.fill_rect(x - 1, y - 1, w + 2, GLYPH_HEIGHT * scale + 2, background);
        self.text(x, y, text, scale, c);
    }

    /// Encode as an 8-bit RGB PNG.
    pub fn to_png(&self) -> Result<Vec<u8>, png::EncodingError> {
        let mut bytes = Vec::new();
        let mut encoder = png::Encoder::new(&mut bytes, self.width as u32, self.height as u32);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_compression(png::Compression::High);
        let mut writer = encoder.write_header()?;
        writer.write_image_data(&self.pixels.concat())?;
        writer.finish()?;
        Ok(bytes)
    }
}

/// A depth buffer the size of an image: per pixel, the depth of the nearest surface drawn so
/// far (`-∞` where nothing is).
#[derive(Clone, Debug)]
pub struct DepthBuffer {
    width: usize,
    depth: Vec<f64>,
}

impl DepthBuffer {
    /// An empty buffer for `image`.
    pub fn for_image(image: &Image) -> Self {
        Self {
            width: image.width,
            depth: vec![f64::NEG_INFINITY; image.width * image.height],
        }
    }

    /// The nearest depth drawn at (`x`, `y`) (`-∞` outside or where nothing is).
    pub fn at(&self, x: i64, y: i64) -> f64 {
        if x < 0 || y < 0 || x as usize >= self.width {
            return f64::NEG_INFINITY;
        }
        self.depth
            .get(y as usize * self.width + x as usize)
            .copied()
            .unwrap_or(f64::NEG_INFINITY)
    }
}

/// Fill triangle `t` (pixel space) into `image` where it is nearer than `depth`; `colour`
/// gives each covered pixel's colour from its barycentric coordinates. A pixel is covered when
/// its centre is inside the triangle (or on an edge). Degenerate triangles draw nothing.
pub fn fill_triangle(
    image: &mut Image,
    depth: &mut DepthBuffer,
    t: [ScreenPoint; 3],
    mut colour: impl FnMut([f64; 3]) -> Rgb,
) {
    let [a, b, c] = t;
    let area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
    if area.abs() < 1e-12 || !area.is_finite() {
        return;
    }
    let lo_x = a[0].min(b[0]).min(c[0]).floor().max(0.0) as usize;
    let hi_x = (a[0].max(b[0]).max(c[0]).ceil() as i64).min(image.width as i64 - 1);
    let lo_y = a[1].min(b[1]).min(c[1]).floor().max(0.0) as usize;
    let hi_y = (a[1].max(b[1]).max(c[1]).ceil() as i64).min(image.height as i64 - 1);
    if hi_x < 0 || hi_y < 0 {
        return;
    }
    let edge = |p: &ScreenPoint, q: &ScreenPoint, x: f64, y: f64| {
        (q[0] - p[0]) * (y - p[1]) - (q[1] - p[1]) * (x - p[0])
    };
    for y in lo_y..=hi_y as usize {
        for x in lo_x..=hi_x as usize {
            let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
            let w = [
                edge(&b, &c, px, py) / area,
                edge(&c, &a, px, py) / area,
                edge(&a, &b, px, py) / area,
            ];
            if w.iter().any(|&wi| wi < -1e-9) {
                continue;
            }
            let z = w[0] * a[2] + w[1] * b[2] + w[2] * c[2];
            let i = y * image.width + x;
            if z > depth.depth[i] {
                depth.depth[i] = z;
                image.pixels[i] = colour(w);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const RED: Rgb = [255, 0, 0];
    const BLUE: Rgb = [0, 0, 255];

    fn covered(image: &Image, c: Rgb) -> Vec<(usize, usize)> {
        (0..image.height)
            .flat_map(|y| (0..image.width).map(move |x| (x, y)))
            .filter(|&(x, y)| image.get(x, y) == Some(c))
            .collect()
    }

    #[test]
    fn a_right_triangle_covers_the_pixels_whose_centres_it_contains() {
        let mut image = Image::new(8, 8, [0; 3]);
        let mut depth = DepthBuffer::for_image(&image);
        // Legs of 4 along x and y from (0, 0): centres (x + .5, y + .5) with x + y + 1 <= 4.
        fill_triangle(
            &mut image,
            &mut depth,
            [[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [0.0, 4.0, 0.0]],
            |_| RED,
        );
        let mut want = Vec::new();
        for y in 0..4 {
            for x in 0..4 {
                if x + y < 4 {
                    want.push((x, y));
                }
            }
        }
        want.sort_by_key(|&(x, y)| (y, x));
        assert_eq!(covered(&image, RED), want);
        // Winding does not matter.
        let mut other = Image::new(8, 8, [0; 3]);
        let mut depth = DepthBuffer::for_image(&other);
        fill_triangle(
            &mut other,
            &mut depth,
            [[0.0, 0.0, 0.0], [0.0, 4.0, 0.0], [4.0, 0.0, 0.0]],
            |_| RED,
        );
        assert_eq!(other, image);
    }

    #[test]
    fn the_nearer_triangle_wins_in_either_drawing_order() {
        let far = [[0.0, 0.0, -1.0], [8.0, 0.0, -1.0], [0.0, 8.0, -1.0]];
        let near = [[0.0, 0.0, 1.0], [8.0, 0.0, 1.0], [0.0, 8.0, 1.0]];
        for order in [[(far, RED), (near, BLUE)], [(near, BLUE), (far, RED)]] {
            let mut image = Image::new(8, 8, [0; 3]);
            let mut depth = DepthBuffer::for_image(&image);
            for (t, c) in order {
                fill_triangle(&mut image, &mut depth, t, |_| c);
            }
            assert_eq!(image.get(1, 1), Some(BLUE));
            assert!(covered(&image, RED).is_empty());
            assert_eq!(depth.at(1, 1), 1.0);
        }
    }

    #[test]
    fn barycentric_colours_and_clipping() {
        let mut image = Image::new(4, 4, [0; 3]);
        let mut depth = DepthBuffer::for_image(&image);
        // Far larger than the image: clipped, and the weights still sum to one.
        fill_triangle(
            &mut image,
            &mut depth,
            [[-50.0, -50.0, 0.0], [60.0, -50.0, 0.0], [-50.0, 60.0, 0.0]],
            |w| {
                assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-9);
                [7, 7, 7]
            },
        );
        assert_eq!(covered(&image, [7, 7, 7]).len(), 16);
    }

    #[test]
    fn text_and_png() {
        let mut image = Image::new(12, 9, [0; 3]);
        image.text(1, 1, "1", 1, RED);
        // The glyph '1': its stem is column 2 of the glyph.
        assert_eq!(image.get(3, 2), Some(RED));
        assert_eq!(image.get(1, 1), Some([0; 3]));
        let png = image.to_png().unwrap();
        assert_eq!(&png[1..4], b"PNG");
    }
}
