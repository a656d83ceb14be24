//! A 2-D chart's frame on the canvas: data ranges mapped to a pixel box,
//! ticks on round numbers with grid lines and labels, the title and the
//! axis titles (the y one turned upright). The report's line charts
//! (`xy_chart.rs`) and the benchmarks' log-log picture
//! (`bench/close_grid_plot.rs`) draw on it, so every figure comes from the
//! one rasteriser and the embedded font.

use super::palette::{BACKGROUND, INK};
use super::text::{HAlign, TextStyle, VAlign, draw_text, text_width};
use crate::raster::{Canvas, Rgb8};
use coapt_io::png::Rgb;

/// Grid lines.
const GRID: Rgb8 = [225, 225, 225];
/// The axis lines.
const AXIS: Rgb8 = [90, 90, 90];
pub const TITLE_SIZE: f64 = 18.0;
pub const LABEL_SIZE: f64 = 13.0;
pub const DESC_SIZE: f64 = 14.0;

/// The data box: `x` and `y` ranges drawn in the pixel box `left..right`,
/// `top..bottom` (y grows upwards in data, downwards in pixels).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    pub x: (f64, f64),
    pub y: (f64, f64),
    pub left: f64,
    pub top: f64,
    pub right: f64,
    pub bottom: f64,
}

impl Frame {
    /// The pixel of data point (x, y).
    pub fn px(&self, x: f64, y: f64) -> [f64; 2] {
        let u = (x - self.x.0) / (self.x.1 - self.x.0);
        let v = (y - self.y.0) / (self.y.1 - self.y.0);
        [
            self.left + u * (self.right - self.left),
            self.bottom - v * (self.bottom - self.top),
        ]
    }
}

/// Ticks on multiples of a round step (1, 2 or 5 × 10^k), as many as fit
/// in `max` without going under `min_step`, inside [lo, hi].
pub fn ticks(lo: f64, hi: f64, max: usize, min_step: f64) -> Vec<f64> {
    let span = hi - lo;
    if !(span.is_finite() && span > 0.0) || max == 0 {
        return Vec::new();
    }
    let raw = (span / max as f64).max(min_step);
    let exp = raw.log10().floor() as i32;
    let mag = 10f64.powi(exp);
    let m = [1u32, 2, 5, 10]
        .into_iter()
        .find(|&m| m as f64 * mag >= raw * (1.0 - 1e-9))
        .unwrap_or(10);
    let step = m as f64 * mag;
    // k·m / 10^−exp, not k·step: 3 × 0.2 is 0.6000000000000001.
    let at = |k: i64| {
        let units = (k * m as i64) as f64;
        if exp < 0 {
            units / 10f64.powi(-exp)
        } else {
            units * mag
        }
    };
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last)
        .map(at)
        .filter(|t| *t >= lo && *t <= hi)
        // -0.0 prints as "-0".
        .map(|t| if t == 0.0 { 0.0 } else { t })
        .collect()
}

/// What a frame shows besides the data: titles and labelled ticks.
pub struct Axes<'a> {
    pub title: &'a str,
    pub x_desc: &'a str,
    pub y_desc: &'a str,
    pub x_ticks: Vec<(f64, String)>,
    pub y_ticks: Vec<(f64, String)>,
}

/// The title above the box, grid lines at the ticks, the axis lines on the
/// left and at the bottom, tick labels and the axis titles.
pub fn draw_axes(c: &mut Canvas, f: &Frame, a: &Axes) {
    let title = TextStyle::new(TITLE_SIZE, INK).align(HAlign::Centre, VAlign::Top);
    draw_text(c, 0.5 * (f.left + f.right), 10.0, a.title, &title);
    for (x, _) in &a.x_ticks {
        let p = f.px(*x, f.y.0)[0];
        c.line([p, f.top], [p, f.bottom], 1.0, GRID);
    }
    for (y, _) in &a.y_ticks {
        let p = f.px(f.x.0, *y)[1];
        c.line([f.left, p], [f.right, p], 1.0, GRID);
    }
    c.line([f.left, f.top], [f.left, f.bottom], 1.0, AXIS);
    c.line([f.left, f.bottom], [f.right, f.bottom], 1.0, AXIS);
    let below = TextStyle::new(LABEL_SIZE, INK).align(HAlign::Centre, VAlign::Top);
    for (x, label) in &a.x_ticks {
        let p = f.px(*x, f.y.0)[0];
        c.line([p, f.bottom], [p, f.bottom + 5.0], 1.0, AXIS);
        draw_text(c, p, f.bottom + 9.0, label, &below);
    }
    let left = TextStyle::new(LABEL_SIZE, INK).align(HAlign::Right, VAlign::Middle);
    let mut widest: f64 = 0.0;
    for (y, label) in &a.y_ticks {
        let p = f.px(f.x.0, *y)[1];
        c.line([f.left - 5.0, p], [f.left, p], 1.0, AXIS);
        draw_text(c, f.left - 8.0, p, label, &left);
        widest = widest.max(text_width(LABEL_SIZE, label));
    }
    let desc = TextStyle::new(DESC_SIZE, INK).align(HAlign::Centre, VAlign::Top);
    draw_text(
        c,
        0.5 * (f.left + f.right),
        f.bottom + 28.0,
        a.x_desc,
        &desc,
    );
    let x = (f.left - 8.0 - widest - 8.0 - DESC_SIZE).max(2.0);
    upright_text(c, x, 0.5 * (f.top + f.bottom), a.y_desc, DESC_SIZE);
}

/// `s` read from bottom to top, its left edge at `x` and centred on `y`
/// (on a white ground: it is drawn on a canvas of its own, turned and
/// copied).
pub fn upright_text(c: &mut Canvas, x: f64, y: f64, s: &str, size: f64) {
    let w = text_width(size, s).ceil() as u32 + 4;
    let h = (1.4 * size).ceil() as u32;
    let mut t = Canvas::new(w, h, c.samples_per_side() as u32, BACKGROUND);
    let style = TextStyle::new(size, INK).align(HAlign::Left, VAlign::Top);
    draw_text(&mut t, 2.0, 0.2 * size, s, &style);
    let flat = t.finish();
    // A quarter turn anticlockwise: column x of the text becomes row
    // (w − 1 − x) of the picture.
    let mut px = Vec::with_capacity(flat.px.len());
    for row in 0..flat.w {
        for col in 0..flat.h {
            px.push(flat.px[(flat.w - 1 - row) + col * flat.w]);
        }
    }
    let turned = Rgb {
        w: flat.h,
        h: flat.w,
        px,
    };
    c.blit(
        &turned,
        x.round() as i64,
        (y - 0.5 * turned.h as f64).round() as i64,
    );
}

/// A white box with a grey border holding one row per entry: a sample of
/// the entry's line (drawn by `key` in the 24 × 12 px box it is given) and
/// its name; its top-left corner at `at`. The box's size.
pub fn legend_box(
    c: &mut Canvas,
    at: [f64; 2],
    names: &[&str],
    key: &mut dyn FnMut(&mut Canvas, usize, [f64; 2]),
) -> [f64; 2] {
    let size = [legend_width(names), 8.0 + 20.0 * names.len() as f64];
    c.rect(at[0], at[1], at[0] + size[0], at[1] + size[1], BACKGROUND);
    c.rect_outline(
        at[0],
        at[1],
        at[0] + size[0],
        at[1] + size[1],
        1.0,
        [160, 160, 160],
    );
    let style = TextStyle::new(LABEL_SIZE, INK).align(HAlign::Left, VAlign::Middle);
    for (k, name) in names.iter().enumerate() {
        let y = at[1] + 14.0 + 20.0 * k as f64;
        key(c, k, [at[0] + 8.0, y]);
        draw_text(c, at[0] + 40.0, y, name, &style);
    }
    size
}

/// The width [`legend_box`] takes for `names`.
pub fn legend_width(names: &[&str]) -> f64 {
    let widest = names
        .iter()
        .map(|n| text_width(LABEL_SIZE, n))
        .fold(0.0, f64::max);
    48.0 + widest
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_fall_on_round_numbers_inside_the_range() {
        assert_eq!(
            ticks(0.0, 10.0, 10, 0.0),
            (0..=10).map(f64::from).collect::<Vec<_>>()
        );
        assert_eq!(ticks(-0.3, 0.95, 5, 0.0), [0.0, 0.5]);
        assert_eq!(ticks(-0.3, 0.95, 7, 0.0), [-0.2, 0.0, 0.2, 0.4, 0.6, 0.8]);
        assert_eq!(
            ticks(-6.2, -0.4, 10, 0.0),
            [-6.0, -5.0, -4.0, -3.0, -2.0, -1.0]
        );
        assert_eq!(
            ticks(12.6, 35.4, 12, 1.0),
            (14..=34).step_by(2).map(f64::from).collect::<Vec<_>>()
        );
        // A whole-number axis never ticks between two integers.
        assert_eq!(ticks(20.7, 23.3, 10, 1.0), [21.0, 22.0, 23.0]);
        assert!(ticks(1.0, 1.0, 10, 0.0).is_empty());
        assert!(ticks(0.0, f64::NAN, 10, 0.0).is_empty());
    }

    #[test]
    fn the_frame_maps_corners_to_corners() {
        let f = Frame {
            x: (2.0, 4.0),
            y: (-1.0, 1.0),
            left: 10.0,
            top: 20.0,
            right: 110.0,
            bottom: 220.0,
        };
        assert_eq!(f.px(2.0, -1.0), [10.0, 220.0]);
        assert_eq!(f.px(4.0, 1.0), [110.0, 20.0]);
        assert_eq!(f.px(3.0, 0.0), [60.0, 120.0]);
    }

    /// Upright text is the flat text turned: as tall as the flat one is
    /// wide, and ink only inside that strip.
    #[test]
    fn upright_text_stands_in_its_strip() {
        let mut c = Canvas::new(60, 200, 2, BACKGROUND);
        upright_text(&mut c, 10.0, 100.0, "height (mm)", 14.0);
        let img = c.finish();
        let inked: Vec<(usize, usize)> = (0..img.h)
            .flat_map(|y| (0..img.w).map(move |x| (x, y)))
            .filter(|&(x, y)| img.px[x + y * img.w][0] < 128)
            .collect();
        assert!(inked.len() > 50);
        let (x0, x1) = (
            inked.iter().map(|p| p.0).min().unwrap(),
            inked.iter().map(|p| p.0).max().unwrap(),
        );
        let (y0, y1) = (
            inked.iter().map(|p| p.1).min().unwrap(),
            inked.iter().map(|p| p.1).max().unwrap(),
        );
        assert!(x0 >= 10 && x1 < 10 + 20, "{x0}..{x1}");
        let tall = (y1 - y0) as f64;
        let wide = text_width(14.0, "height (mm)");
        assert!(
            tall > 0.8 * wide && tall < wide + 2.0,
            "{tall} against {wide}"
        );
        assert!(y0 as f64 > 100.0 - 0.5 * wide - 4.0 && (y1 as f64) < 100.0 + 0.5 * wide + 4.0);
    }
}
