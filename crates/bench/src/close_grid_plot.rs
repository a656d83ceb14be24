//! The grid's picture: wall time (log) against the error in coaptation
//! height (log), one line per model × solver × contact through its meshes,
//! each point labelled with its h. Colour is the model, marker the solver;
//! hollow markers did not converge. Drawn on the report's frame
//! (`report::figures::plot_frame`) with the embedded font, so the same rows
//! give the same bytes.

use super::close_grid::{Grid, Row};
use coapt_io::png::encode;
use coapt_report::figures::notice::notice;
use coapt_report::figures::palette::INK;
use coapt_report::figures::plot_frame::{Axes, Frame, draw_axes, ticks};
use coapt_report::figures::text::{HAlign, TextStyle, VAlign, draw_text};
use coapt_report::raster::{Canvas, Rgb8};

const WIDTH: u32 = 960;
const HEIGHT: u32 = 640;
/// Width of the legend panel at the right.
const LEGEND_W: u32 = 250;

/// Okabe–Ito colours, one per model.
const COLOURS: [Rgb8; 4] = [[0, 114, 178], [213, 94, 0], [0, 158, 115], [204, 121, 167]];

/// One drawable point: (wall s, |error| mm, h mm, converged).
type Point = (f64, f64, f64, bool);

struct Series {
    name: String,
    colour: Rgb8,
    marker: usize,
    points: Vec<Point>,
}

fn series(g: &Grid) -> Vec<Series> {
    let mut keys: Vec<(&str, &str, &str)> = Vec::new();
    for r in &g.rows {
        let k = (r.model.as_str(), r.solver.as_str(), r.contact.as_str());
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    let mut models: Vec<&str> = keys.iter().map(|k| k.0).collect();
    models.dedup();
    let solver_marker = |s: &str| match s {
        "newton" => 0,
        "combined" => 1,
        _ => 2,
    };
    let drawable = |r: &Row| -> Option<Point> {
        let e = r.errors.as_ref()?.height_mm?.abs();
        (r.wall_s > 0.0 && r.wall_s.is_finite() && e > 0.0 && e.is_finite()).then_some((
            r.wall_s,
            e,
            r.h,
            r.converged(),
        ))
    };
    keys.iter()
        .map(|&(m, s, c)| Series {
            name: format!("{m} {s} ({c})"),
            colour: COLOURS[models.iter().position(|x| *x == m).unwrap_or(0) % COLOURS.len()],
            marker: solver_marker(s),
            points: g
                .rows
                .iter()
                .filter(|r| (r.model.as_str(), r.solver.as_str(), r.contact.as_str()) == (m, s, c))
                .filter_map(drawable)
                .collect(),
        })
        .filter(|s| !s.points.is_empty())
        .collect()
}

/// Tick label of a log axis: the value in its shortest honest form.
fn label(v: f64) -> String {
    if !(1e-3..1000.0).contains(&v) {
        format!("{v:.0e}")
    } else {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

/// The PNG bytes; a notice picture when no row has a measured error
/// (the reference rows themselves have none on a log axis).
pub fn png(g: &Grid, title: &str) -> Vec<u8> {
    let s = series(g);
    let pts = s.iter().flat_map(|s| s.points.iter());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y, _, _) in pts {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if s.is_empty() {
        return notice(
            "close_grid",
            title,
            "no row has an error against a reference to plot (a reference needs a converged Newton row; its own error is zero)",
        )
        .png;
    }
    // Half a decade of room around the points, for labels and markers.
    let widen = |lo: f64, hi: f64| (lo / 10f64.powf(0.25), hi * 10f64.powf(0.25));
    let (x0, x1) = widen(x0, x1);
    let (y0, y1) = widen(y0, y1);
    let mut canvas = Canvas::new(WIDTH, HEIGHT, 2, [255, 255, 255]);
    draw(&s, title, (x0, x1, y0, y1), &mut canvas);
    encode(&canvas.finish())
}

/// Ticks of a log axis over [lo, hi] (values, not logarithms): 1, 2 and 5
/// of each decade when the range spans less than three decades; else
/// whole decades, every one, second or fifth so that about a dozen fit.
fn log_ticks(lo: f64, hi: f64) -> Vec<(f64, String)> {
    let (a, b) = (lo.log10(), hi.log10());
    let mut out: Vec<f64> = ticks(a, b, 12, 1.0)
        .into_iter()
        .map(|e| 10f64.powf(e))
        .collect();
    if b - a < 3.0 {
        out = (a.floor() as i32..=b.ceil() as i32)
            .flat_map(|e| [1.0, 2.0, 5.0].map(|m| m * 10f64.powi(e)))
            .filter(|v| *v >= lo && *v <= hi)
            .collect();
    }
    out.into_iter().map(|v| (v.log10(), label(v))).collect()
}

fn draw(series: &[Series], title: &str, (x0, x1, y0, y1): (f64, f64, f64, f64), c: &mut Canvas) {
    // The data in decades; the legend gets its own panel at the right so it
    // never hides a point.
    let f = Frame {
        x: (x0.log10(), x1.log10()),
        y: (y0.log10(), y1.log10()),
        left: 14.0 + 76.0,
        top: 14.0 + 30.0,
        right: (WIDTH - LEGEND_W) as f64 - 14.0,
        bottom: HEIGHT as f64 - 14.0 - 46.0,
    };
    draw_axes(
        c,
        &f,
        &Axes {
            title,
            x_desc: "wall time of the closure (s, log scale)",
            y_desc: "|error in coaptation height| vs reference (mm, log scale)",
            x_ticks: log_ticks(x0, x1),
            y_ticks: log_ticks(y0, y1),
        },
    );
    let at = |x: f64, y: f64| f.px(x.log10(), y.log10());
    let small = TextStyle::new(11.0, INK).align(HAlign::Left, VAlign::Baseline);
    for s in series {
        let pts: Vec<[f64; 2]> = s.points.iter().map(|p| at(p.0, p.1)).collect();
        c.polyline(&pts, 1.0, s.colour);
        for (p, &(_, _, h, conv)) in pts.iter().zip(&s.points) {
            shape(c, s.marker, *p, s.colour, conv);
            draw_text(c, p[0] + 6.0, p[1] - 6.0, &format!("{h}"), &small);
        }
    }
    let x = (WIDTH - LEGEND_W) as f64 + 8.0;
    let text = TextStyle::new(13.0, INK).align(HAlign::Left, VAlign::Middle);
    let mut y = 48.0;
    for s in series {
        c.line([x, y], [x + 24.0, y], 1.0, s.colour);
        shape(c, s.marker, [x + 12.0, y], s.colour, true);
        draw_text(c, x + 32.0, y, &s.name, &text);
        y += 22.0;
    }
    let note = TextStyle::new(12.0, INK).align(HAlign::Left, VAlign::Baseline);
    for line in [
        "point labels: h (mm)",
        "hollow marker: not converged",
        "reference rows (zero error)",
        "are not drawn",
    ] {
        y += 18.0;
        draw_text(c, x, y, line, &note);
    }
}

/// Marker of a solver at pixel `p`: circle Newton, triangle combined,
/// square relaxation; hollow when the closure did not converge.
fn shape(c: &mut Canvas, kind: usize, p: [f64; 2], colour: Rgb8, filled: bool) {
    let [x, y] = p;
    let tri = [[x, y - 5.0], [x - 5.0, y + 4.0], [x + 5.0, y + 4.0]];
    match (kind, filled) {
        (0, true) => c.disc(x, y, 4.0, colour),
        (0, false) => c.ring(x, y, 4.0, 2.0, colour),
        (1, true) => c.fill_with(x - 5.0, y - 5.0, x + 5.0, y + 4.0, |px, py| {
            inside(&tri, [px, py]).then_some(colour)
        }),
        (1, false) => c.polyline(&[tri[0], tri[1], tri[2], tri[0]], 2.0, colour),
        (_, true) => c.rect(x - 4.0, y - 4.0, x + 4.0, y + 4.0, colour),
        (_, false) => c.rect_outline(x - 4.0, y - 4.0, x + 4.0, y + 4.0, 2.0, colour),
    }
}

/// Whether `p` lies in the triangle `t` (either winding).
fn inside(t: &[[f64; 2]; 3], p: [f64; 2]) -> bool {
    let side =
        |a: [f64; 2], b: [f64; 2]| (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
    let s = [side(t[0], t[1]), side(t[1], t[2]), side(t[2], t[0])];
    s.iter().all(|v| *v >= 0.0) || s.iter().all(|v| *v <= 0.0)
}
