//! The grid's picture: wall time (log) against the error in coaptation
//! height (log), one line per model × solver × contact through its meshes,
//! each point labelled with its h. Colour is the model, marker the solver;
//! hollow markers did not converge. Drawn by plotters with the embedded
//! font, so the same rows give the same bytes.

use plotters::prelude::*;

use super::close_grid::{Grid, Row};
use crate::io::png::{Rgb, encode};
use crate::report::figures::font::{FAMILY, register_with_plotters};
use crate::report::figures::notice::notice;

const WIDTH: u32 = 960;
const HEIGHT: u32 = 640;
/// Width of the legend panel at the right.
const LEGEND_W: u32 = 250;

/// Okabe–Ito colours, one per model.
const COLOURS: [RGBColor; 4] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
];

/// One drawable point: (wall s, |error| mm, h mm, converged).
type Point = (f64, f64, f64, bool);

struct Series {
    name: String,
    colour: RGBColor,
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
    let mut buf = vec![255u8; (WIDTH * HEIGHT * 3) as usize];
    register_with_plotters();
    if let Err(e) = draw(&s, title, (x0, x1, y0, y1), &mut buf) {
        return notice(
            "close_grid",
            title,
            &format!("the chart could not be drawn ({e})"),
        )
        .png;
    }
    encode(&Rgb {
        w: WIDTH as usize,
        h: HEIGHT as usize,
        px: buf.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
    })
}

fn draw(
    series: &[Series],
    title: &str,
    (x0, x1, y0, y1): (f64, f64, f64, f64),
    buf: &mut [u8],
) -> Result<(), Box<dyn std::error::Error>> {
    let root =
        BitMapBackend::<plotters::backend::RGBPixel>::with_buffer_and_format(buf, (WIDTH, HEIGHT))?
            .into_drawing_area();
    root.fill(&WHITE)?;
    // The legend gets its own panel so it never hides a point.
    let (plot, side) = root.split_horizontally(WIDTH - LEGEND_W);
    let mut cc = ChartBuilder::on(&plot)
        .caption(title, (FAMILY, 18).into_font())
        .margin(14)
        .x_label_area_size(46)
        .y_label_area_size(76)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())?;
    cc.configure_mesh()
        .x_desc("wall time of the closure (s, log scale)")
        .y_desc("|error in coaptation height| vs reference (mm, log scale)")
        .label_style((FAMILY, 13).into_font())
        .axis_desc_style((FAMILY, 14).into_font())
        .x_label_formatter(&|v: &f64| label(*v))
        .y_label_formatter(&|v: &f64| label(*v))
        .light_line_style(RGBColor(238, 238, 238))
        .bold_line_style(RGBColor(215, 215, 215))
        .draw()?;
    for s in series {
        let colour = s.colour;
        let line = ShapeStyle::from(&colour).stroke_width(1);
        cc.draw_series(LineSeries::new(s.points.iter().map(|p| (p.0, p.1)), line))?;
        for &(x, y, h, conv) in &s.points {
            cc.draw_series(std::iter::once(
                EmptyElement::at((x, y))
                    + shape(s.marker, (0, 0), colour, conv)
                    + Text::new(format!("{h}"), (6, -14), (FAMILY, 11).into_font()),
            ))?;
        }
    }
    let font = (FAMILY, 13).into_font();
    let mut y = 48;
    for s in series {
        let line = ShapeStyle::from(&s.colour).stroke_width(1);
        side.draw(
            &(EmptyElement::at((8, y))
                + PathElement::new(vec![(0, 0), (24, 0)], line)
                + shape(s.marker, (12, 0), s.colour, true)
                + Text::new(s.name.clone(), (32, -7), font.clone())),
        )?;
        y += 22;
    }
    for note in [
        "point labels: h (mm)",
        "hollow marker: not converged",
        "reference rows (zero error)",
        "are not drawn",
    ] {
        y += 18;
        side.draw(&Text::new(note, (8, y), (FAMILY, 12).into_font()))?;
    }
    root.present()?;
    Ok(())
}

/// Marker of a solver at an offset (pixels): circle Newton, triangle
/// combined, square relaxation.
fn shape<DB: DrawingBackend>(
    kind: usize,
    at: (i32, i32),
    colour: RGBColor,
    filled: bool,
) -> DynElement<'static, DB, (i32, i32)> {
    let style = if filled {
        colour.filled()
    } else {
        ShapeStyle::from(&colour).stroke_width(2)
    };
    let (x, y) = at;
    let tri = vec![(x, y - 5), (x - 5, y + 4), (x + 5, y + 4)];
    match kind {
        0 => Circle::new((x, y), 4, style).into_dyn(),
        1 if filled => Polygon::new(tri, style).into_dyn(),
        1 => PathElement::new(vec![tri[0], tri[1], tri[2], tri[0]], style).into_dyn(),
        _ => Rectangle::new([(x - 4, y - 4), (x + 4, y + 4)], style).into_dyn(),
    }
}
