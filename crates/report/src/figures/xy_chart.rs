//! Line charts on the one rasteriser (`plot_frame.rs`, the embedded font):
//! solver convergence and the leaflet-size sweep.

use super::notice::notice;
use super::plot_frame::{Axes, Frame, draw_axes, legend_box, legend_width, ticks};
use super::to_figure;
use crate::Figure;
use crate::raster::{Canvas, Rgb8};

/// One named curve; non-finite points (and, on a log axis, non-positive
/// values) are left out and the line is broken there.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    /// Mark every point, for sparse data such as a size sweep.
    pub markers: bool,
}

impl Series {
    pub fn new(name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            name: name.into(),
            points,
            markers: false,
        }
    }
    pub fn with_markers(self) -> Self {
        Self {
            markers: true,
            ..self
        }
    }
}

/// A chart: axis labels carry their units ("leaflet size (mm)").
#[derive(Debug, Clone, PartialEq)]
pub struct XyChart {
    pub id: String,
    pub title: String,
    pub caption: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    /// Named horizontal reference lines (thresholds, tolerances), dashed:
    /// in the colour of the series they judge (its index), else red.
    pub hlines: Vec<(String, f64, Option<usize>)>,
    pub log_y: bool,
    /// Ticks on whole x values only (sizes, counts): no "13.2".
    pub x_integer: bool,
    pub width: u32,
    pub height: u32,
}

impl XyChart {
    pub fn new(id: &str, title: &str, x_label: &str, y_label: &str) -> Self {
        Self {
            id: id.into(),
            title: title.into(),
            caption: String::new(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            series: Vec::new(),
            hlines: Vec::new(),
            log_y: false,
            x_integer: false,
            width: 720,
            height: 420,
        }
    }
}

/// Okabe–Ito colours: distinguishable in print and for colour-blind readers.
const COLOURS: [Rgb8; 6] = [
    [0, 114, 178],
    [213, 94, 0],
    [0, 158, 115],
    [204, 121, 167],
    [230, 159, 0],
    [86, 180, 233],
];
const HLINE: Rgb8 = [200, 30, 40];

/// Render the chart; a notice figure when no series has a drawable point.
pub fn xy_chart(chart: &XyChart) -> Figure {
    let ty = |y: f64| {
        if chart.log_y {
            if y > 0.0 { y.log10() } else { f64::NAN }
        } else {
            y
        }
    };
    // Runs of drawable points, in plotted (possibly log10) coordinates.
    let runs: Vec<Vec<Vec<(f64, f64)>>> = chart
        .series
        .iter()
        .map(|s| {
            let mut out: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
            for &(x, y) in &s.points {
                let y = ty(y);
                if x.is_finite() && y.is_finite() {
                    if let Some(r) = out.last_mut() {
                        r.push((x, y));
                    }
                } else if out.last().is_some_and(|r| !r.is_empty()) {
                    out.push(Vec::new());
                }
            }
            out.retain(|r| !r.is_empty());
            out
        })
        .collect();
    let hlines: Vec<(&str, f64, Option<usize>)> = chart
        .hlines
        .iter()
        .map(|(n, y, k)| (n.as_str(), ty(*y), *k))
        .filter(|(_, y, _)| y.is_finite())
        .collect();
    let all = runs.iter().flatten().flatten();
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for &(x, y) in all {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if x0 > x1 {
        return notice(
            &chart.id,
            &chart.title,
            &format!("{}: no finite data to plot", chart.title),
        );
    }
    for &(_, y, _) in &hlines {
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    let (x0, x1) = pad(x0, x1, 0.02);
    let (y0, y1) = pad(y0, y1, 0.06);
    let (w, h) = (chart.width.clamp(200, 4000), chart.height.clamp(150, 4000));
    let entries = legend_entries(chart, &runs, &hlines);
    let names: Vec<&str> = entries.iter().map(|e| e.0).collect();
    let size = [legend_width(&names), 8.0 + 20.0 * names.len() as f64];
    let (corner, y1) = legend_place(
        &runs,
        &hlines,
        (x0, x1, y0, y1),
        plot_frame((x0, x1, y0, y1), w as f64, h as f64),
        size,
    );
    let legend = Legend {
        entries: &entries,
        size,
        corner,
    };
    let mut canvas = Canvas::new(w, h, 2, [255, 255, 255]);
    draw(
        chart,
        &runs,
        &hlines,
        (x0, x1, y0, y1),
        &legend,
        &mut canvas,
    );
    to_figure(&chart.id, &chart.title, &chart.caption, &canvas)
}

/// Widen [lo, hi] by `frac` of its span on each side (±1 around a single value).
fn pad(lo: f64, hi: f64, frac: f64) -> (f64, f64) {
    let span = hi - lo;
    if span > 1e-12 * lo.abs().max(hi.abs()).max(1e-300) {
        (lo - frac * span, hi + frac * span)
    } else {
        let d = (0.1 * lo.abs()).max(1.0);
        (lo - d, hi + d)
    }
}

/// Tick label on a log10 axis: the value itself, in the shortest honest form.
fn log_label(v: f64) -> String {
    let x = 10f64.powf(v);
    if (v - v.round()).abs() < 1e-9 {
        let e = v.round() as i32;
        return match e {
            -2..=3 => format!("{}", 10f64.powi(e)),
            _ => format!("1e{e}"),
        };
    }
    format!("{x:.2e}")
}

/// Tick label on a linear axis: no trailing zeros ("20", not "20.0").
fn tick_label(v: f64) -> String {
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

type Ranges = (f64, f64, f64, f64);

/// Margin around the chart, and room for the title, the x labels and the
/// y labels (pixels).
const MARGIN: f64 = 14.0;
const TITLE_ROOM: f64 = 30.0;
const X_LABEL_ROOM: f64 = 44.0;
const Y_LABEL_ROOM: f64 = 72.0;

/// The plot's frame on a `w` × `h` px chart.
fn plot_frame((x0, x1, y0, y1): Ranges, w: f64, h: f64) -> Frame {
    Frame {
        x: (x0, x1),
        y: (y0, y1),
        left: MARGIN + Y_LABEL_ROOM,
        top: MARGIN + TITLE_ROOM,
        right: w - MARGIN,
        bottom: h - MARGIN - X_LABEL_ROOM,
    }
}

/// The legend's rows (name, colour, dashed), its size (px) and its corner.
struct Legend<'a> {
    entries: &'a [(&'a str, Rgb8, bool)],
    size: [f64; 2],
    corner: Corner,
}

fn draw(
    chart: &XyChart,
    runs: &[Vec<Vec<(f64, f64)>>],
    hlines: &[(&str, f64, Option<usize>)],
    ranges: Ranges,
    legend: &Legend,
    c: &mut Canvas,
) {
    let (x0, x1, y0, y1) = ranges;
    let f = plot_frame(ranges, c.width() as f64, c.height() as f64);
    let log = chart.log_y;
    let y_ticks = ticks(y0, y1, 10, 0.0)
        .into_iter()
        .map(|v| (v, if log { log_label(v) } else { tick_label(v) }))
        .collect();
    let x_ticks = x_ticks(chart, runs, (x0, x1))
        .into_iter()
        .map(|v| (v, tick_label(v)))
        .collect();
    draw_axes(
        c,
        &f,
        &Axes {
            title: &chart.title,
            x_desc: &chart.x_label,
            y_desc: &chart.y_label,
            x_ticks,
            y_ticks,
        },
    );
    let colour_of = |k: usize| COLOURS[k % COLOURS.len()];
    for (k, (s, r)) in chart.series.iter().zip(runs).enumerate() {
        for run in r {
            let pts: Vec<[f64; 2]> = run.iter().map(|&(x, y)| f.px(x, y)).collect();
            c.polyline(&pts, 2.0, colour_of(k));
            if s.markers {
                for p in &pts {
                    c.disc(p[0], p[1], 3.0, colour_of(k));
                }
            }
        }
    }
    for &(_, y, of) in hlines {
        let colour = of.map_or(HLINE, colour_of);
        c.dashed_polyline(&[f.px(x0, y), f.px(x1, y)], 2.0, 8.0, 5.0, colour);
    }
    let names: Vec<&str> = legend.entries.iter().map(|e| e.0).collect();
    let at = legend_at(&f, legend.corner, legend.size);
    legend_box(c, at, &names, &mut |c, k, p| {
        let (_, colour, dashed) = legend.entries[k];
        let line = [p, [p[0] + 24.0, p[1]]];
        if dashed {
            c.dashed_polyline(&line, 2.0, 8.0, 5.0, colour);
        } else {
            c.polyline(&line, 2.0, colour);
        }
    });
}

/// Ticks of the x axis: on a whole-number axis with a dozen values at
/// most (sizes of a sweep), those values; else round numbers, whole ones
/// on a whole-number axis.
fn x_ticks(chart: &XyChart, runs: &[Vec<Vec<(f64, f64)>>], (x0, x1): (f64, f64)) -> Vec<f64> {
    if chart.x_integer {
        let mut xs: Vec<f64> = runs.iter().flatten().flatten().map(|p| p.0).collect();
        xs.sort_by(f64::total_cmp);
        xs.dedup();
        if (2..=12).contains(&xs.len()) && xs.iter().all(|x| x.fract() == 0.0) {
            return xs;
        }
    }
    ticks(x0, x1, 10, if chart.x_integer { 1.0 } else { 0.0 })
}

/// A corner of the plot for the legend.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Corner {
    UpperRight,
    UpperLeft,
    LowerRight,
    LowerLeft,
}

/// The legend's rows: each series that has a line, then each reference
/// line (dashed), with their colours.
fn legend_entries<'a>(
    chart: &'a XyChart,
    runs: &[Vec<Vec<(f64, f64)>>],
    hlines: &[(&'a str, f64, Option<usize>)],
) -> Vec<(&'a str, Rgb8, bool)> {
    let colour_of = |k: usize| COLOURS[k % COLOURS.len()];
    let mut entries = Vec::new();
    for (k, (s, r)) in chart.series.iter().zip(runs).enumerate() {
        if !r.is_empty() {
            entries.push((s.name.as_str(), colour_of(k), false));
        }
    }
    for &(name, _, of) in hlines {
        entries.push((name, of.map_or(HLINE, colour_of), true));
    }
    entries
}

/// Top-left corner (px) of a legend of `size` px in `corner` of the plot.
fn legend_at(f: &Frame, corner: Corner, size: [f64; 2]) -> [f64; 2] {
    match corner {
        Corner::UpperRight => [f.right - 8.0 - size[0], f.top + 8.0],
        Corner::UpperLeft => [f.left + 8.0, f.top + 8.0],
        Corner::LowerRight => [f.right - 8.0 - size[0], f.bottom - 8.0 - size[1]],
        Corner::LowerLeft => [f.left + 8.0, f.bottom - 8.0 - size[1]],
    }
}

/// Gap (px) kept between the legend and what it would otherwise touch.
const LEGEND_CLEAR_PX: f64 = 4.0;

/// Where the legend goes and the top of the y range: the first corner
/// (upper right, upper left, lower right, lower left) whose legend box,
/// grown by [`LEGEND_CLEAR_PX`], no drawn line, marker or reference line
/// enters; when each is entered, the upper right, with the y range raised
/// until everything drawn lies below the legend.
fn legend_place(
    runs: &[Vec<Vec<(f64, f64)>>],
    hlines: &[(&str, f64, Option<usize>)],
    (x0, x1, y0, y1): Ranges,
    f: Frame,
    size: [f64; 2],
) -> (Corner, f64) {
    let corners = [
        Corner::UpperRight,
        Corner::UpperLeft,
        Corner::LowerRight,
        Corner::LowerLeft,
    ];
    let clear = |corner: Corner| {
        let at = legend_at(&f, corner, size);
        let g = LEGEND_CLEAR_PX;
        let (lo, hi) = (
            [at[0] - g, at[1] - g],
            [at[0] + size[0] + g, at[1] + size[1] + g],
        );
        let enters = |a: [f64; 2], b: [f64; 2]| segment_enters_box(a, b, lo, hi);
        let lines = runs.iter().flatten().all(|run| {
            let px: Vec<[f64; 2]> = run.iter().map(|&(x, y)| f.px(x, y)).collect();
            px.iter().all(|&p| !enters(p, p)) && px.windows(2).all(|w| !enters(w[0], w[1]))
        });
        lines
            && hlines
                .iter()
                .all(|&(_, y, _)| !enters(f.px(x0, y), f.px(x1, y)))
    };
    if let Some(c) = corners.into_iter().find(|&c| clear(c)) {
        return (c, y1);
    }
    // Everything drawn lies at or below y_max; the legend takes the top
    // `cover` px of the plot's height: raise y1 until y_max maps below it.
    let y_max = runs
        .iter()
        .flatten()
        .flatten()
        .map(|p| p.1)
        .chain(hlines.iter().map(|h| h.1))
        .fold(y0, f64::max);
    let height = f.bottom - f.top;
    let share = ((8.0 + size[1] + 2.0 * LEGEND_CLEAR_PX) / height).min(0.6);
    (
        Corner::UpperRight,
        y1.max((y_max - share * y0) / (1.0 - share)),
    )
}

/// Whether the segment a–b (px) meets the box [lo, hi] (Liang–Barsky).
fn segment_enters_box(a: [f64; 2], b: [f64; 2], lo: [f64; 2], hi: [f64; 2]) -> bool {
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for k in 0..2 {
        let d = b[k] - a[k];
        for (p, q) in [(-d, a[k] - lo[k]), (d, hi[k] - a[k])] {
            if p == 0.0 {
                if q < 0.0 {
                    return false;
                }
            } else {
                let r = q / p;
                if p < 0.0 {
                    t0 = t0.max(r);
                } else {
                    t1 = t1.min(r);
                }
            }
        }
    }
    t0 <= t1
}

#[cfg(test)]
mod tests {
    use super::super::test_valve::{count, decode};
    use super::*;

    fn sweep() -> XyChart {
        let mut c = XyChart::new(
            "sizing",
            "Leaflet size sweep",
            "leaflet size (mm)",
            "height (mm)",
        );
        c.series.push(
            Series::new(
                "coaptation height",
                (0..8)
                    .map(|k| (21.0 + k as f64, 6.0 + 0.5 * k as f64))
                    .collect(),
            )
            .with_markers(),
        );
        c.series.push(Series::new(
            "effective height",
            (0..8)
                .map(|k| (21.0 + k as f64, 8.0 + 0.4 * k as f64))
                .collect(),
        ));
        c.hlines
            .push(("effective height 9 mm".into(), 9.0, Some(1)));
        c
    }

    #[test]
    fn chart_draws_each_series_in_its_colour() {
        let f = xy_chart(&sweep());
        let img = decode(&f.png);
        assert_eq!((img.w, img.h), (720, 420));
        assert!(count(&img, COLOURS[0]) > 200, "{}", count(&img, COLOURS[0]));
        assert!(count(&img, COLOURS[1]) > 200);
        // The threshold is dashed in the colour of the height it judges.
        assert_eq!(count(&img, HLINE), 0);
        // Text went through the embedded font: dark anti-aliased pixels exist.
        assert!(
            img.px
                .iter()
                .filter(|p| p[0] < 60 && p[1] < 60 && p[2] < 60)
                .count()
                > 300
        );
    }

    #[test]
    fn the_legend_goes_where_the_plot_is_empty() {
        let frame = |r: Ranges| plot_frame(r, 720.0, 405.0);
        let size = [150.0, 48.0];
        let rising: Vec<Vec<(f64, f64)>> = vec![(0..10).map(|k| (k as f64, k as f64)).collect()];
        let r = (0.0, 9.0, 0.0, 9.0);
        // A line from lower left to upper right leaves the other corners.
        let (c, y1) = legend_place(&[rising.clone()], &[], r, frame(r), size);
        assert_eq!((c, y1), (Corner::UpperLeft, 9.0));
        // A threshold near the top rules out both upper corners.
        let (c, _) = legend_place(&[rising.clone()], &[("t", 8.5, None)], r, frame(r), size);
        assert_eq!(c, Corner::LowerRight);
        // Nothing to avoid: the usual corner, the range as it was.
        assert_eq!(
            legend_place(&[], &[], r, frame(r), size),
            (Corner::UpperRight, 9.0)
        );
        // Lines across the whole width at the top and the bottom (a sweep
        // of two sizes): no corner is free, so the range grows upwards until
        // the upper right one is, and nothing drawn then enters it.
        let flat: Vec<Vec<(f64, f64)>> =
            vec![vec![(0.0, 8.5), (9.0, 8.6)], vec![(0.0, 0.5), (9.0, 0.4)]];
        let (c, y1) = legend_place(&[flat.clone()], &[], r, frame(r), size);
        assert_eq!(c, Corner::UpperRight);
        assert!(y1 > 9.0, "{y1}");
        let grown = (0.0, 9.0, 0.0, y1);
        let f = frame(grown);
        let at = legend_at(&f, c, size);
        let below = at[1] + size[1] + LEGEND_CLEAR_PX;
        for &(x, y) in flat.iter().flatten() {
            assert!(f.px(x, y)[1] >= below - 1e-9, "({x}, {y}) under the legend");
        }
    }

    #[test]
    fn a_segment_enters_a_box_when_it_crosses_or_ends_in_it() {
        let (lo, hi) = ([0.0, 0.0], [10.0, 5.0]);
        assert!(segment_enters_box([-5.0, 2.0], [15.0, 2.0], lo, hi));
        assert!(segment_enters_box([5.0, 2.0], [5.0, 2.0], lo, hi));
        assert!(segment_enters_box([-1.0, -1.0], [1.0, 1.0], lo, hi));
        assert!(!segment_enters_box([-5.0, 6.0], [15.0, 6.0], lo, hi));
        assert!(!segment_enters_box([-2.0, 0.0], [0.0, -2.0], lo, hi));
        assert!(!segment_enters_box([11.0, 0.0], [20.0, 5.0], lo, hi));
    }

    #[test]
    fn charts_are_bit_identical_across_runs_and_threads() {
        let a = xy_chart(&sweep());
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let b = pool.install(|| xy_chart(&sweep()));
        let c = std::thread::spawn(|| xy_chart(&sweep())).join().unwrap();
        assert_eq!(a.png, b.png);
        assert_eq!(a.png, c.png);
    }

    #[test]
    fn empty_or_degenerate_data_gives_a_notice_or_a_chart() {
        let mut c = XyChart::new("x", "Empty", "x", "y");
        assert!(xy_chart(&c).caption.starts_with("Not drawn"));
        c.series.push(Series::new(
            "nan",
            vec![(f64::NAN, 1.0), (1.0, f64::INFINITY)],
        ));
        assert!(xy_chart(&c).caption.starts_with("Not drawn"));
        // A single point, and a log axis with a zero, still chart.
        c.series
            .push(Series::new("one", vec![(3.0, 0.0), (4.0, 2.0)]));
        c.log_y = true;
        c.width = 0;
        let f = xy_chart(&c);
        assert!(!f.caption.starts_with("Not drawn"));
        assert_eq!(f.width, 200);
    }

    /// A sweep's few whole sizes are its ticks; many sizes, or a
    /// continuous axis, tick on round numbers.
    #[test]
    fn a_sweep_ticks_at_its_own_sizes() {
        let mut c = XyChart::new("s", "Sweep", "size", "mm");
        c.x_integer = true;
        let runs = |xs: &[f64]| vec![vec![xs.iter().map(|&x| (x, 1.0)).collect::<Vec<_>>()]];
        assert_eq!(
            x_ticks(&c, &runs(&[13.0, 15.0, 19.0]), (12.0, 20.0)),
            [13.0, 15.0, 19.0]
        );
        let many: Vec<f64> = (0..20).map(f64::from).collect();
        assert_eq!(
            x_ticks(&c, &runs(&many), (-0.5, 19.5)),
            [0.0, 2.0, 4.0, 6.0, 8.0, 10.0, 12.0, 14.0, 16.0, 18.0]
        );
        c.x_integer = false;
        assert_eq!(
            x_ticks(&c, &runs(&[13.0, 15.0]), (12.5, 15.5)),
            [12.5, 13.0, 13.5, 14.0, 14.5, 15.0, 15.5]
        );
    }

    #[test]
    fn log_labels_read_as_values() {
        assert_eq!(log_label(-2.0), "0.01");
        assert_eq!(log_label(0.0), "1");
        assert_eq!(log_label(-6.0), "1e-6");
        assert_eq!(log_label(0.5), "3.16e0");
        assert_eq!(tick_label(20.0), "20");
        assert_eq!(tick_label(2.5), "2.5");
        assert_eq!(tick_label(-0.00001), "0");
    }
}
