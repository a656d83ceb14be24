//! Segmentation check: three CT planes in the valve frame with the mask's
//! contour, the landmarks and the suture paths, so that a reader can see at
//! a glance whether the lumen, the frame and the paths sit where the CT says.

use super::ct_plane::{Sampler, contour, window};
use super::label_layout;
use super::legend::{LegendItem, Swatch, draw_legend_row};
use super::notice::notice;
use super::palette::{BACKGROUND, INK};
use super::scale_bar::draw_scale_bar;
use super::text::{HAlign, TextStyle, VAlign, draw_text, text_width};
use super::to_figure;
use crate::Figure;
use crate::raster::{Camera, Canvas, Rgb8};
use coapt_geom::{Point3, ValveFrame, Vector3, Volume};

const PANEL: u32 = 320;
const GAP: f64 = 10.0;
const HEAD: f64 = 34.0;
const FOOT: f64 = 64.0;
const ID: &str = "ct_check";
const TITLE: &str = "Segmentation check on CT planes";

/// Display window, HU: soft tissue grey, contrast-filled lumen bright.
const WINDOW: (f64, f64) = (-200.0, 600.0);
/// Points and paths closer than this to a plane count as on it, mm.
const SLAB_MM: f64 = 1.5;

const OUTSIDE: Rgb8 = [28, 32, 52];
const MASK: Rgb8 = [255, 205, 0];
const PATH: Rgb8 = [40, 230, 110];
const PATH_FAR: Rgb8 = [30, 150, 80];
const LANDMARK: Rgb8 = [255, 70, 170];
const TRACE: Rgb8 = [110, 170, 255];

struct Plane {
    title: String,
    cam: Camera,
    /// Other planes and the annulus, as world segments drawn dashed.
    traces: Vec<[Point3; 2]>,
}

/// Three planes through the valve at mid-height between the annulus and the
/// mean commissure height: a short-axis plane seen from the aorta (C1 up)
/// and two long-axis planes (through C1, and perpendicular to it) with the
/// flow axis up. The mask (any grid) is outlined in yellow; landmarks and
/// suture paths are solid within ±1.5 mm of a plane, thin beyond it.
pub fn ct_check(
    ct: &Volume<i16>,
    mask: Option<&Volume<u8>>,
    frame: &ValveFrame,
    points: &[(String, Point3)],
    paths: &[Vec<Point3>],
) -> Figure {
    let Some(planes) = planes(frame) else {
        return notice(
            ID,
            TITLE,
            "the valve frame is not finite, so the CT planes through the valve cannot be placed",
        );
    };
    let width = (3.0 * PANEL as f64 + 4.0 * GAP) as u32;
    let height = (HEAD + PANEL as f64 + FOOT) as u32;
    let mut c = Canvas::new(width, height, 2, BACKGROUND);
    let head = TextStyle::new(13.5, INK).align(HAlign::Centre, VAlign::Baseline);
    for (k, pl) in planes.iter().enumerate() {
        let x0 = GAP + k as f64 * (PANEL as f64 + GAP);
        let img = render_plane(ct, mask, pl, points, paths);
        c.blit(&img, x0 as i64, HEAD as i64);
        draw_text(
            &mut c,
            x0 + 0.5 * PANEL as f64,
            HEAD - 10.0,
            &pl.title,
            &head,
        );
    }
    let items = [
        LegendItem::new(Swatch::Line(MASK), "mask contour"),
        LegendItem::new(Swatch::Line(PATH), "suture path within ±1.5 mm"),
        LegendItem::new(Swatch::ThinLine(PATH_FAR), "beyond (projected)"),
        LegendItem::new(Swatch::Dot(LANDMARK), "landmark within ±1.5 mm"),
        LegendItem::new(Swatch::Ring(LANDMARK), "beyond"),
        LegendItem::new(Swatch::Dashed(TRACE), "annulus, other planes"),
    ];
    let fy = HEAD + PANEL as f64 + 10.0;
    draw_legend_row(&mut c, GAP, fy, &items[..3], 12.0);
    draw_legend_row(&mut c, GAP, fy + 22.0, &items[3..], 12.0);
    draw_scale_bar(
        &mut c,
        width as f64 - GAP - 130.0,
        height as f64 - 12.0,
        planes[0].cam.mm_per_px(),
        120.0,
    );
    let mut caption = format!(
        "CT (window {} to {} HU) on three planes through the valve at mid-height between the annulus and the \
         commissures: short axis seen from the aorta (C1 up), and long axes through C1 and perpendicular to it \
         (flow axis up). Yellow: segmentation contour; green: suture paths (solid within ±{SLAB_MM} mm of \
         the plane, thin beyond); pink: landmarks (and the coronary ostia, RCA and \
         LCA, where coapt found them); blue dashes: the annulus plane and the other planes.",
        WINDOW.0, WINDOW.1
    );
    if mask.is_none() {
        caption.push_str(" No mask was given, so no contour is drawn.");
    }
    to_figure(ID, TITLE, &caption, &c)
}

fn planes(f: &ValveFrame) -> Option<Vec<Plane>> {
    let (o, a, e1) = (f.origin_mm, f.axis, f.e1);
    let e2 = f.e2();
    let hc = f
        .commissures_mm
        .iter()
        .map(|c| (c - o).dot(&a))
        .sum::<f64>()
        / 3.0;
    let rc = f
        .commissures_mm
        .iter()
        .map(|c| {
            let d = c - o;
            (d - a * d.dot(&a)).norm()
        })
        .fold(0.0, f64::max);
    if !(hc.is_finite() && rc.is_finite()) {
        return None;
    }
    let mid = o + a * (0.5 * hc);
    // Wide enough for the root and its surroundings, and for the commissures
    // and the annulus on the long-axis planes.
    let half = (1.6 * rc).max(0.8 * hc.abs() + 6.0).max(10.0);
    let mm_per_px = 2.0 * half / PANEL as f64;
    let cam = |view: Vector3, up: Vector3| Camera::new(view, up, mid, mm_per_px, PANEL, PANEL);
    let seg = |p: Point3, d: Vector3| [p - d * (2.0 * half), p + d * (2.0 * half)];
    Some(vec![
        Plane {
            title: format!("Short axis, {:.1} mm above annulus", 0.5 * hc),
            cam: cam(-a, e1)?,
            traces: vec![seg(mid, e1), seg(mid, e2)],
        },
        Plane {
            title: "Long axis through C1".to_string(),
            cam: cam(-e2, a)?,
            traces: vec![seg(o, e1), seg(mid, e1)],
        },
        Plane {
            title: "Long axis perpendicular to C1".to_string(),
            cam: cam(e1, a)?,
            traces: vec![seg(o, e2), seg(mid, e2)],
        },
    ])
}

fn render_plane(
    ct: &Volume<i16>,
    mask: Option<&Volume<u8>>,
    pl: &Plane,
    points: &[(String, Point3)],
    paths: &[Vec<Point3>],
) -> coapt_io::png::Rgb {
    let cam = &pl.cam;
    let mut c = Canvas::new(PANEL, PANEL, 2, OUTSIDE);
    let (w, h) = (PANEL as f64, PANEL as f64);
    let ct = Sampler::new(ct);
    c.fill_with(0.0, 0.0, w, h, |x, y| {
        ct.trilinear(&cam.unproject(x, y))
            .map(|v| [window(v, WINDOW.0, WINDOW.1); 3])
    });
    for t in &pl.traces {
        let (a, b) = (cam.project(&t[0]), cam.project(&t[1]));
        c.dashed_polyline(&[[a[0], a[1]], [b[0], b[1]]], 1.2, 6.0, 5.0, TRACE);
    }
    if let Some(m) = mask.map(Sampler::new) {
        // Nearest sampling at pixel centres, then a marching-squares outline.
        let n = PANEL as usize;
        let inside: Vec<bool> = (0..n * n)
            .map(|k| {
                let (i, j) = (k % n, k / n);
                m.nearest(&cam.unproject(i as f64 + 0.5, j as f64 + 0.5))
                    .is_some_and(|v| v > 0)
            })
            .collect();
        for s in contour(&inside, n, n) {
            let p = s.map(|q| [q[0] + 0.5, q[1] + 0.5]);
            c.line(p[0], p[1], 1.6, MASK);
        }
    }
    let normal = cam.view();
    let centre = cam.centre();
    let dist = |p: &Point3| (p - centre).dot(&normal);
    for path in paths {
        for s in path.windows(2) {
            draw_clipped(&mut c, cam, &s[0], &s[1], dist(&s[0]), dist(&s[1]));
        }
    }
    let label = TextStyle::new(13.0, [255; 3])
        .align(HAlign::Left, VAlign::Middle)
        .halo([0; 3]);
    let mut shown = Vec::new();
    for (name, p) in points {
        let d = dist(p);
        let q = cam.project(p);
        if !(d.is_finite() && q[0].is_finite() && q[1].is_finite()) {
            continue;
        }
        if d.abs() <= SLAB_MM {
            c.disc(q[0], q[1], 4.5, LANDMARK);
        } else {
            c.ring(q[0], q[1], 4.0, 1.5, LANDMARK);
        }
        shown.push((name, [q[0], q[1]]));
    }
    let anchors: Vec<[f64; 2]> = shown.iter().map(|s| s.1).collect();
    let widths: Vec<f64> = shown.iter().map(|s| text_width(13.0, s.0)).collect();
    for ((name, _), o) in shown
        .iter()
        .zip(label_layout::place(&anchors, &widths, 13.0))
    {
        draw_text(&mut c, o[0], o[1], name, &label);
    }
    c.finish()
}

/// Segment ab with signed distances da, db to the plane: the part within
/// the slab drawn solid, the rest thin.
fn draw_clipped(c: &mut Canvas, cam: &Camera, a: &Point3, b: &Point3, da: f64, db: f64) {
    if !(da.is_finite() && db.is_finite()) {
        return;
    }
    let (pa, pb) = (cam.project(a), cam.project(b));
    let at = |t: f64| [pa[0] + (pb[0] - pa[0]) * t, pa[1] + (pb[1] - pa[1]) * t];
    let (t0, t1) = if (db - da).abs() < 1e-12 {
        if da.abs() <= SLAB_MM {
            (0.0, 1.0)
        } else {
            (1.0, 1.0)
        }
    } else {
        let u = (SLAB_MM - da) / (db - da);
        let v = (-SLAB_MM - da) / (db - da);
        (u.min(v).clamp(0.0, 1.0), u.max(v).clamp(0.0, 1.0))
    };
    if t0 > 0.0 {
        c.line(at(0.0), at(t0), 1.0, PATH_FAR);
    }
    if t1 < 1.0 {
        c.line(at(t1), at(1.0), 1.0, PATH_FAR);
    }
    if t1 > t0 {
        c.line(at(t0), at(t1), 2.6, PATH);
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_valve::{count, decode};
    use super::*;
    use coapt_geom::{Matrix3, volume::affine_from_parts};

    /// A bright cylinder (the lumen, 400 HU) of radius 10 mm along world z
    /// in soft tissue (40 HU), and its mask on a cropped, coarser grid.
    fn phantom() -> (Volume<i16>, Volume<u8>, ValveFrame) {
        let n = 48;
        let aff = affine_from_parts(
            [1.0, 1.0, 1.0],
            &Matrix3::identity(),
            Point3::new(-24.0, -24.0, -10.0),
        );
        let mut vals = Vec::with_capacity(n * n * n);
        for _k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let (x, y) = (i as f64 - 24.0, j as f64 - 24.0);
                    vals.push(if x.hypot(y) < 10.0 { 400 } else { 40 });
                }
            }
        }
        let ct = Volume::from_fortran_vec([n, n, n], aff, vals).unwrap();
        let maff = affine_from_parts(
            [0.5, 0.5, 2.0],
            &Matrix3::identity(),
            Point3::new(-15.0, -15.0, -8.0),
        );
        let (mi, mk) = (61, 17);
        let mut mv = Vec::new();
        for _k in 0..mk {
            for j in 0..mi {
                for i in 0..mi {
                    let (x, y) = (-15.0 + 0.5 * i as f64, -15.0 + 0.5 * j as f64);
                    mv.push(u8::from(x.hypot(y) < 10.0));
                }
            }
        }
        let mask = Volume::from_fortran_vec([mi, mi, mk], maff, mv).unwrap();
        let o = Point3::new(0.0, 0.0, 0.0);
        let c = |deg: f64| {
            Point3::new(
                9.0 * deg.to_radians().cos(),
                9.0 * deg.to_radians().sin(),
                16.0,
            )
        };
        let frame = ValveFrame::new(o, Vector3::z(), [c(0.0), c(120.0), c(240.0)], None).unwrap();
        (ct, mask, frame)
    }

    fn panel_pixels(img: &coapt_io::png::Rgb, k: usize) -> Vec<[u8; 3]> {
        let x0 = GAP as usize + k * (PANEL as usize + GAP as usize);
        (HEAD as usize..HEAD as usize + PANEL as usize)
            .flat_map(|y| (x0..x0 + PANEL as usize).map(move |x| (x, y)))
            .map(|(x, y)| img.px[x + y * img.w])
            .collect()
    }

    #[test]
    fn lumen_is_bright_and_outlined_in_every_plane() {
        let (ct, mask, frame) = phantom();
        let f = ct_check(&ct, Some(&mask), &frame, &[], &[]);
        let img = decode(&f.png);
        assert_eq!((img.w as u32, img.h as u32), (f.width, f.height));
        let lumen = window(400.0, WINDOW.0, WINDOW.1);
        for k in 0..3 {
            let px = panel_pixels(&img, k);
            assert!(
                px.iter().filter(|p| **p == [lumen; 3]).count() > 5000,
                "panel {k}"
            );
            assert!(px.iter().filter(|p| **p == MASK).count() > 300, "panel {k}");
        }
        // On the short-axis plane the contour is a circle of radius 10 mm
        // about the panel centre: every contour pixel is about 10 mm out.
        let half = (1.6f64 * 9.0).max(0.8 * 16.0 + 6.0).max(10.0);
        let mmpp = 2.0 * half / PANEL as f64;
        let px = panel_pixels(&img, 0);
        for (i, p) in px.iter().enumerate() {
            if *p == MASK {
                let (x, y) = (
                    (i % PANEL as usize) as f64 + 0.5,
                    (i / PANEL as usize) as f64 + 0.5,
                );
                let r = (x - 160.0).hypot(y - 160.0) * mmpp;
                assert!((r - 10.0).abs() < 0.8, "contour at {r} mm");
            }
        }
    }

    #[test]
    fn points_and_paths_in_the_slab_are_solid() {
        let (ct, mask, frame) = phantom();
        // A point on the short-axis plane (z = 8) and one far above it.
        let pts = vec![
            ("N1".to_string(), Point3::new(5.0, 0.0, 8.0)),
            ("C1".to_string(), frame.commissures_mm[0]),
        ];
        let ring: Vec<Point3> = (0..=36)
            .map(|k| {
                let t = (k as f64 * 10.0).to_radians();
                Point3::new(10.0 * t.cos(), 10.0 * t.sin(), 8.0)
            })
            .collect();
        let f = ct_check(&ct, Some(&mask), &frame, &pts, &[ring]);
        let img = decode(&f.png);
        let short = panel_pixels(&img, 0);
        assert!(short.iter().filter(|p| **p == LANDMARK).count() > 40);
        assert!(short.iter().filter(|p| **p == PATH).count() > 500);
        // The ring crosses the long-axis planes at two points each: little
        // solid path there, and the far parts are thin.
        let long = panel_pixels(&img, 1);
        let solid = long.iter().filter(|p| **p == PATH).count();
        assert!(solid > 0 && solid < 200, "{solid}");
        assert!(count(&img, PATH_FAR) > 0);
    }

    #[test]
    fn no_mask_oblique_grid_and_bad_frames_are_handled() {
        let (ct, _, frame) = phantom();
        let f = ct_check(
            &ct,
            None,
            &frame,
            &[("X".into(), Point3::new(f64::NAN, 0.0, 0.0))],
            &[vec![]],
        );
        assert!(f.caption.contains("No mask"));
        let img = decode(&f.png);
        assert!((0..3).all(|k| !panel_pixels(&img, k).contains(&MASK)));
        let mut bad = frame.clone();
        bad.axis = Vector3::new(f64::NAN, 0.0, 1.0);
        assert!(
            ct_check(&ct, None, &bad, &[], &[])
                .caption
                .starts_with("Not drawn")
        );
        // A CT that does not reach the planes leaves them "outside", not blank.
        let far = affine_from_parts([1.0; 3], &Matrix3::identity(), Point3::new(500.0, 0.0, 0.0));
        let tiny = Volume::from_fortran_vec([1, 1, 1], far, vec![100i16]).unwrap();
        let img = decode(&ct_check(&tiny, None, &frame, &[], &[]).png);
        let panel = panel_pixels(&img, 0);
        assert!(panel.iter().filter(|p| **p == OUTSIDE).count() > 90_000);
        assert!(
            !panel.iter().any(|p| p[0] == p[1] && p[1] == p[2]),
            "no CT grey"
        );
        let a = ct_check(&ct, None, &frame, &[], &[]);
        let b = ct_check(&ct, None, &frame, &[], &[]);
        assert_eq!(a.png, b.png);
    }
}
