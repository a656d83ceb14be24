//! Line charts (plotters on an in-memory RGB buffer, embedded font): solver
//! convergence now, the leaflet-size sweep later.

use plotters::prelude::*;
use plotters::series::DashedLineSeries;

use super::font::{FAMILY, register_with_plotters};
use super::notice::notice;
use crate::io::png::{Rgb, encode};
use crate::report::Figure;
use crate::report::raster::Rgb8;

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

fn rgb(c: Rgb8) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

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
    let mut buf = vec![255u8; (w * h * 3) as usize];
    register_with_plotters();
    let drawn = draw(chart, &runs, &hlines, (x0, x1, y0, y1), &mut buf, (w, h));
    if let Err(e) = drawn {
        return notice(
            &chart.id,
            &chart.title,
            &format!("the chart could not be drawn ({e})"),
        );
    }
    let img = Rgb {
        w: w as usize,
        h: h as usize,
        px: buf.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
    };
    Figure {
        id: chart.id.clone(),
        title: chart.title.clone(),
        caption: chart.caption.clone(),
        width: w,
        height: h,
        png: encode(&img),
    }
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

fn draw(
    chart: &XyChart,
    runs: &[Vec<Vec<(f64, f64)>>],
    hlines: &[(&str, f64, Option<usize>)],
    (x0, x1, y0, y1): Ranges,
    buf: &mut [u8],
    size: (u32, u32),
) -> Result<(), Box<dyn std::error::Error>> {
    let root = BitMapBackend::<plotters::backend::RGBPixel>::with_buffer_and_format(buf, size)?
        .into_drawing_area();
    root.fill(&WHITE)?;
    let mut cc = ChartBuilder::on(&root)
        .caption(&chart.title, (FAMILY, 18).into_font())
        .margin(14)
        .x_label_area_size(44)
        .y_label_area_size(72)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    let log = chart.log_y;
    let y_fmt = move |v: &f64| if log { log_label(*v) } else { tick_label(*v) };
    let whole = chart.x_integer;
    let x_fmt = move |v: &f64| {
        if whole && (v - v.round()).abs() > 1e-6 {
            String::new()
        } else {
            tick_label(*v)
        }
    };
    // With one label per unit at most, plotters puts its ticks on whole numbers.
    let x_labels = if whole {
        ((x1 - x0).floor() as usize + 1).clamp(2, 12)
    } else {
        10
    };
    cc.configure_mesh()
        .x_labels(x_labels)
        .x_desc(chart.x_label.as_str())
        .y_desc(chart.y_label.as_str())
        .label_style((FAMILY, 13).into_font())
        .axis_desc_style((FAMILY, 14).into_font())
        .y_label_formatter(&y_fmt)
        .x_label_formatter(&x_fmt)
        .light_line_style(RGBColor(238, 238, 238))
        .bold_line_style(RGBColor(215, 215, 215))
        .draw()?;
    for (k, (s, r)) in chart.series.iter().zip(runs).enumerate() {
        let colour = rgb(COLOURS[k % COLOURS.len()]);
        let style = ShapeStyle::from(&colour).stroke_width(2);
        let mut first = true;
        for run in r {
            let a = cc.draw_series(LineSeries::new(run.iter().copied(), style))?;
            if first {
                a.label(s.name.as_str())
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 22, y)], style));
                first = false;
            }
            if s.markers {
                cc.draw_series(run.iter().map(|&p| Circle::new(p, 3, colour.filled())))?;
            }
        }
    }
    for &(name, y, of) in hlines {
        let colour = of.map_or(HLINE, |k| COLOURS[k % COLOURS.len()]);
        let style = ShapeStyle::from(&rgb(colour)).stroke_width(2);
        cc.draw_series(DashedLineSeries::new(vec![(x0, y), (x1, y)], 8, 5, style))?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 22, y)], style));
    }
    cc.configure_series_labels()
        .position(legend_corner(runs, hlines, (x0, x1, y0, y1)).position())
        .label_font((FAMILY, 13).into_font())
        .background_style(WHITE.mix(0.9))
        .border_style(RGBColor(160, 160, 160))
        .draw()?;
    root.present()?;
    Ok(())
}

/// A corner of the plot for the legend.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Corner {
    UpperRight,
    UpperLeft,
    LowerRight,
    LowerLeft,
}

impl Corner {
    fn position(self) -> SeriesLabelPosition {
        match self {
            Corner::UpperRight => SeriesLabelPosition::UpperRight,
            Corner::UpperLeft => SeriesLabelPosition::UpperLeft,
            Corner::LowerRight => SeriesLabelPosition::LowerRight,
            Corner::LowerLeft => SeriesLabelPosition::LowerLeft,
        }
    }
}

/// The corner whose box (the outer 40 % of each axis) holds the least of the
/// plot, so the legend does not cover a line or a threshold: each data
/// point counts one, each reference line through the box five (a line is
/// read along its whole length). Ties keep the usual upper right.
fn legend_corner(
    runs: &[Vec<Vec<(f64, f64)>>],
    hlines: &[(&str, f64, Option<usize>)],
    (x0, x1, y0, y1): Ranges,
) -> Corner {
    let (wx, wy) = (0.4 * (x1 - x0), 0.4 * (y1 - y0));
    let cost = |c: Corner| {
        let (right, upper) = match c {
            Corner::UpperRight => (true, true),
            Corner::UpperLeft => (false, true),
            Corner::LowerRight => (true, false),
            Corner::LowerLeft => (false, false),
        };
        let in_x = |x: f64| if right { x >= x1 - wx } else { x <= x0 + wx };
        let in_y = |y: f64| if upper { y >= y1 - wy } else { y <= y0 + wy };
        let points = runs
            .iter()
            .flatten()
            .flatten()
            .filter(|&&(x, y)| in_x(x) && in_y(y))
            .count();
        points + 5 * hlines.iter().filter(|&&(_, y, _)| in_y(y)).count()
    };
    [
        Corner::UpperRight,
        Corner::UpperLeft,
        Corner::LowerRight,
        Corner::LowerLeft,
    ]
    .into_iter()
    .min_by_key(|&c| cost(c))
    .expect("four corners")
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
        let rising: Vec<Vec<(f64, f64)>> = vec![(0..10).map(|k| (k as f64, k as f64)).collect()];
        let r = (0.0, 9.0, 0.0, 9.0);
        // A line from lower left to upper right leaves the other corners.
        let c = legend_corner(&[rising.clone()], &[], r);
        assert!(matches!(c, Corner::UpperLeft | Corner::LowerRight), "{c:?}");
        // A threshold near the top rules out both upper corners.
        assert_eq!(
            legend_corner(&[rising], &[("t", 8.5, None)], r),
            Corner::LowerRight
        );
        // Nothing to avoid: the usual corner.
        assert_eq!(legend_corner(&[], &[], r), Corner::UpperRight);
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
