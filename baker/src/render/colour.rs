//! The colour map of the heat maps (viridis, perceptually uniform and readable in grey) and the
//! colour bar that labels it in millimetres.

use super::font::GLYPH_HEIGHT;
use super::image::{Image, Rgb};

/// Viridis sampled at nine evenly spaced points from 0 to 1; [`viridis`] interpolates linearly.
const VIRIDIS: [Rgb; 9] = [
    [68, 1, 84],
    [71, 44, 122],
    [59, 81, 139],
    [44, 113, 142],
    [33, 144, 141],
    [39, 173, 129],
    [92, 200, 99],
    [170, 220, 50],
    [253, 231, 37],
];

/// The viridis colour at `t` (clamped to [0, 1]; NaN counts as 0).
pub fn viridis(t: f64) -> Rgb {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let x = t * (VIRIDIS.len() - 1) as f64;
    let i = (x.floor() as usize).min(VIRIDIS.len() - 2);
    let f = x - i as f64;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    [0, 1, 2].map(|c| (f64::from(a[c]) + f * (f64::from(b[c]) - f64::from(a[c]))).round() as u8)
}

/// The smallest "nice" number (1, 2 or 5 × 10ⁿ) at least `x`; 1 for zero, negative or
/// non-finite input.
pub fn nice_ceiling(x: f64) -> f64 {
    if !(x.is_finite() && x > 0.0) {
        return 1.0;
    }
    let decade = 10f64.powf(x.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * decade)
        .find(|&v| v >= x * (1.0 - 1e-12))
        .unwrap_or(10.0 * decade)
}

/// Text of a millimetre value on the bar: no more decimals than it needs.
pub fn mm_text(v: f64) -> String {
    if v >= 10.0 || v == v.round() {
        format!("{v:.0}")
    } else if v >= 1.0 {
        format!("{v:.1}")
    } else {
        format!("{v:.2}")
    }
}

/// Width in pixels of the colour bar drawn by [`colour_bar`] (strip, ticks and labels).
pub const BAR_WIDTH: usize = 90;

/// Draw a vertical colour bar at (`x`, `y`), `height` pixels tall: `max_mm` at the top, 0 at
/// the bottom, six labelled ticks (fifths of a [`nice_ceiling`] are round numbers), `title`
/// above it. With `clipped` (larger values were drawn in the top colour) the top label reads
/// `max_mm+`.
pub fn colour_bar(
    image: &mut Image,
    (x, y): (i64, i64),
    height: usize,
    max_mm: f64,
    clipped: bool,
    title: &str,
) {
    const STRIP: usize = 22;
    const INK: Rgb = [20, 20, 20];
    image.text(x, y - 3 * GLYPH_HEIGHT as i64 - 12, title, 1, INK);
    image.text(x, y - 2 * GLYPH_HEIGHT as i64 - 6, "MM", 2, INK);
    for row in 0..height {
        let t = 1.0 - row as f64 / (height.max(2) - 1) as f64;
        image.fill_rect(x, y + row as i64, STRIP, 1, viridis(t));
    }
    for tick in 0..=5 {
        let t = f64::from(tick) / 5.0;
        let row = y + ((1.0 - t) * (height.max(2) - 1) as f64).round() as i64;
        image.fill_rect(x + STRIP as i64, row, 5, 1, INK);
        let mut label = mm_text(t * max_mm);
        if clipped && tick == 5 {
            label.push('+');
        }
        image.text(
            x + STRIP as i64 + 8,
            row - GLYPH_HEIGHT as i64,
            &label,
            2,
            INK,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn viridis_runs_dark_to_bright_and_clamps() {
        assert_eq!(viridis(0.0), VIRIDIS[0]);
        assert_eq!(viridis(1.0), VIRIDIS[8]);
        assert_eq!(viridis(-3.0), VIRIDIS[0]);
        assert_eq!(viridis(f64::NAN), VIRIDIS[0]);
        assert_eq!(viridis(0.5), VIRIDIS[4]);
        let lum = |c: Rgb| 0.3 * f64::from(c[0]) + 0.59 * f64::from(c[1]) + 0.11 * f64::from(c[2]);
        for i in 0..20 {
            let (a, b) = (f64::from(i) / 20.0, f64::from(i + 1) / 20.0);
            assert!(lum(viridis(b)) > lum(viridis(a)), "{a}");
        }
    }

    #[test]
    fn nice_ceilings() {
        assert_eq!(nice_ceiling(37.2), 50.0);
        assert_eq!(nice_ceiling(10.0), 10.0);
        assert_eq!(nice_ceiling(0.13), 0.2);
        assert_eq!(nice_ceiling(0.0), 1.0);
        assert_eq!(mm_text(12.5), "12");
        assert_eq!(mm_text(2.5), "2.5");
        assert_eq!(mm_text(0.05), "0.05");
    }

    #[test]
    fn the_bar_runs_from_the_top_colour_to_the_bottom_colour() {
        let mut image = Image::new(120, 140, [255; 3]);
        colour_bar(&mut image, (4, 30), 100, 20.0, false, "ERROR");
        assert_eq!(image.get(10, 30), Some(viridis(1.0)));
        assert_eq!(image.get(10, 129), Some(viridis(0.0)));
        // A tick label beside the top: some dark ink right of the strip.
        let inked = (30..80).any(|x| (20..40).any(|y| image.get(x, y) == Some([20, 20, 20])));
        assert!(inked);
    }

    #[test]
    fn a_clipped_bar_says_so_at_the_top() {
        let ink = |clipped| {
            let mut image = Image::new(160, 140, [255; 3]);
            colour_bar(&mut image, (4, 30), 100, 20.0, clipped, "ERROR");
            (30..160)
                .flat_map(|x| (18..42).map(move |y| (x, y)))
                .filter(|&(x, y)| image.get(x, y) == Some([20, 20, 20]))
                .count()
        };
        assert!(ink(true) > ink(false));
    }
}
