//! A small software rasteriser for the report's figures: orthographic
//! camera, z-buffered triangles with Lambert shading, depth-tested 3-D lines,
//! and 2-D overlays (lines, discs, rectangles, sampled images).
//!
//! Everything is single-threaded and evaluated in a fixed order, so the same
//! inputs give the same bytes on every machine and thread count. Drawing
//! happens on a supersampled grid (`ss`×`ss` samples per output pixel) that
//! [`Canvas::finish`] box-filters with integer arithmetic; callers work in
//! output-pixel coordinates (x right, y down, pixel centres at +0.5).

use coapt_geom::{Point3, Vector3};
use coapt_io::png::Rgb;

pub type Rgb8 = [u8; 3];

/// An orthographic view: the viewer looks along `view`; `up` is the image's
/// upward direction; `centre` lands in the middle of the image.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    centre: Point3,
    right: Vector3,
    up: Vector3,
    view: Vector3,
    mm_per_px: f64,
    width: u32,
    height: u32,
}

impl Camera {
    /// `None` when a direction or the centre is not finite, `view` is zero or
    /// `mm_per_px` is not positive. An `up` parallel to `view` is replaced by
    /// a fixed perpendicular so that a degenerate request still gives an image.
    pub fn new(
        view: Vector3,
        up: Vector3,
        centre: Point3,
        mm_per_px: f64,
        width: u32,
        height: u32,
    ) -> Option<Self> {
        let finite = |v: &Vector3| v.iter().all(|c| c.is_finite());
        if !finite(&view) || !finite(&up) || !finite(&centre.coords) {
            return None;
        }
        if !(mm_per_px.is_finite() && mm_per_px > 0.0) {
            return None;
        }
        let view = view.try_normalize(1e-12)?;
        let up = perpendicular_part(&up, &view)
            .or_else(|| perpendicular_part(&Vector3::z(), &view))
            .or_else(|| perpendicular_part(&Vector3::y(), &view))?;
        Some(Self {
            centre,
            right: view.cross(&up),
            up,
            view,
            mm_per_px,
            width,
            height,
        })
    }

    /// The camera that frames `points` (non-finite ones ignored) with
    /// `margin_px` free on every side of a `width`×`height` image, or with
    /// a fixed 1 mm/px scale around `fallback_centre` when there are none.
    pub fn fit(
        view: Vector3,
        up: Vector3,
        points: &[Point3],
        width: u32,
        height: u32,
        margin_px: f64,
        fallback_centre: Point3,
    ) -> Option<Self> {
        let probe = Self::new(view, up, Point3::origin(), 1.0, width, height)?;
        let (lo, hi) = probe.extent(points)?;
        let span_x = (hi[0] - lo[0]).max(1e-6);
        let span_y = (hi[1] - lo[1]).max(1e-6);
        let avail_x = (width as f64 - 2.0 * margin_px).max(1.0);
        let avail_y = (height as f64 - 2.0 * margin_px).max(1.0);
        let mm_per_px = (span_x / avail_x).max(span_y / avail_y);
        let c = probe.right * (0.5 * (lo[0] + hi[0])) + probe.up * (0.5 * (lo[1] + hi[1]));
        let centre = if c.iter().all(|v| v.is_finite()) {
            Point3::from(c)
        } else {
            fallback_centre
        };
        Self::new(view, up, centre, mm_per_px, width, height)
    }

    /// Smallest and largest (right, up) coordinates in mm, relative to the
    /// world origin, of the finite `points`; `None` when there are none.
    pub fn extent(&self, points: &[Point3]) -> Option<([f64; 2], [f64; 2])> {
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for p in points
            .iter()
            .filter(|p| p.coords.iter().all(|c| c.is_finite()))
        {
            let a = [p.coords.dot(&self.right), p.coords.dot(&self.up)];
            for k in 0..2 {
                lo[k] = lo[k].min(a[k]);
                hi[k] = hi[k].max(a[k]);
            }
        }
        (lo[0] <= hi[0]).then_some((lo, hi))
    }

    /// Same directions and centre at another scale or image size.
    pub fn with_scale(&self, mm_per_px: f64, width: u32, height: u32) -> Option<Self> {
        Self::new(self.view, self.up, self.centre, mm_per_px, width, height)
    }

    pub fn mm_per_px(&self) -> f64 {
        self.mm_per_px
    }
    pub fn view(&self) -> Vector3 {
        self.view
    }
    pub fn up(&self) -> Vector3 {
        self.up
    }
    pub fn right(&self) -> Vector3 {
        self.right
    }
    pub fn centre(&self) -> Point3 {
        self.centre
    }

    /// Image position (output pixels, y down) and depth (mm along `view`,
    /// larger is farther) of a world point.
    #[inline]
    pub fn project(&self, p: &Point3) -> [f64; 3] {
        let d = p - self.centre;
        [
            0.5 * self.width as f64 + d.dot(&self.right) / self.mm_per_px,
            0.5 * self.height as f64 - d.dot(&self.up) / self.mm_per_px,
            d.dot(&self.view),
        ]
    }

    /// The world point at image position (x, y) on the plane through `centre`
    /// perpendicular to `view`.
    pub fn unproject(&self, x: f64, y: f64) -> Point3 {
        self.centre
            + self.right * ((x - 0.5 * self.width as f64) * self.mm_per_px)
            + self.up * ((0.5 * self.height as f64 - y) * self.mm_per_px)
    }

    /// Unit vector from a surface towards the light: above, left of and
    /// slightly in front of the viewer, so that no common surface is lit
    /// exactly edge-on.
    pub fn light(&self) -> Vector3 {
        (self.up * 0.45 - self.right * 0.35 - self.view * 0.82).normalize()
    }
}

fn perpendicular_part(v: &Vector3, n: &Vector3) -> Option<Vector3> {
    (v - n * v.dot(n)).try_normalize(1e-9)
}

/// How triangle brightness follows the surface normal.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shading {
    /// The paint colour as is.
    None,
    /// One normal per triangle.
    Flat,
    /// Area-weighted vertex normals interpolated across the triangle.
    Smooth,
}

/// Lambert factor for `|n·l|`: membranes are seen from both sides, so a
/// back face is lit like a front face.
#[inline]
fn lambert(cos: f64) -> f64 {
    const AMBIENT: f64 = 0.38;
    AMBIENT + (1.0 - AMBIENT) * cos.abs().min(1.0)
}

/// A triangle mesh to draw: positions, triangles and, per corner, three
/// numbers (a colour, class weights, …) that `paint` turns into a colour
/// after interpolation.
pub struct MeshLayer<'a> {
    pub positions: &'a [Point3],
    pub triangles: &'a [[u32; 3]],
    /// Value of corner `k` of triangle `t`.
    pub corner: &'a dyn Fn(usize, usize) -> [f32; 3],
    /// Colour of triangle `t` at an interpolated corner value.
    pub paint: &'a dyn Fn(usize, [f32; 3]) -> Rgb8,
    pub shading: Shading,
}

/// The drawing surface: colour and depth on the supersampled grid.
pub struct Canvas {
    w: usize,
    h: usize,
    ss: usize,
    px: Vec<Rgb8>,
    /// f32 is plenty for millimetre depths and halves the buffer's traffic.
    depth: Vec<f32>,
}

impl Canvas {
    /// A `width`×`height` canvas (at least 1×1) with `ss`×`ss` samples per
    /// pixel (1..=4).
    pub fn new(width: u32, height: u32, ss: u32, background: Rgb8) -> Self {
        let ss = ss.clamp(1, 4) as usize;
        let w = (width.max(1) as usize) * ss;
        let h = (height.max(1) as usize) * ss;
        Self {
            w,
            h,
            ss,
            px: vec![background; w * h],
            depth: vec![f32::INFINITY; w * h],
        }
    }

    pub fn width(&self) -> u32 {
        (self.w / self.ss) as u32
    }
    pub fn height(&self) -> u32 {
        (self.h / self.ss) as u32
    }
    pub fn samples_per_side(&self) -> usize {
        self.ss
    }

    /// Box-filter the samples into the output image, rounding to nearest.
    pub fn finish(&self) -> Rgb {
        let (w, h, ss) = (self.w / self.ss, self.h / self.ss, self.ss);
        let n = (ss * ss) as u32;
        let mut px = Vec::with_capacity(w * h);
        for y in 0..h {
            for x in 0..w {
                let mut acc = [0u32; 3];
                for sy in 0..ss {
                    let row = (y * ss + sy) * self.w + x * ss;
                    for s in &self.px[row..row + ss] {
                        for c in 0..3 {
                            acc[c] += s[c] as u32;
                        }
                    }
                }
                px.push(acc.map(|a| ((a + n / 2) / n) as u8));
            }
        }
        Rgb { w, h, px }
    }

    /// Colour of the sample at supersampled position (sx, sy), if inside.
    pub fn sample(&self, sx: usize, sy: usize) -> Option<Rgb8> {
        (sx < self.w && sy < self.h).then(|| self.px[sx + sy * self.w])
    }

    /// Depth at supersampled position (sx, sy); infinite where nothing was drawn.
    pub fn sample_depth(&self, sx: usize, sy: usize) -> Option<f64> {
        (sx < self.w && sy < self.h).then(|| self.depth[sx + sy * self.w] as f64)
    }

    /// Mix `colour` into one sample with opacity `alpha` (0..=1); samples
    /// outside the canvas are ignored.
    #[inline]
    pub fn blend_sample(&mut self, sx: i64, sy: i64, colour: Rgb8, alpha: f32) {
        if sx < 0 || sy < 0 || sx >= self.w as i64 || sy >= self.h as i64 {
            return;
        }
        let a = if alpha.is_finite() {
            alpha.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let i = sx as usize + sy as usize * self.w;
        let p = &mut self.px[i];
        for c in 0..3 {
            let v = p[c] as f32 + (colour[c] as f32 - p[c] as f32) * a;
            p[c] = (v + 0.5).clamp(0.0, 255.0) as u8;
        }
    }

    /// Samples whose centres lie in the output-pixel rectangle [x0, x1)×[y0, y1),
    /// as supersampled index ranges (empty when outside or not finite).
    fn sample_range(&self, x0: f64, x1: f64, y0: f64, y1: f64) -> (usize, usize, usize, usize) {
        let s = self.ss as f64;
        let clampx = |v: f64| {
            if v.is_nan() {
                0
            } else {
                (v * s - 0.5).ceil().clamp(0.0, self.w as f64) as usize
            }
        };
        let clampy = |v: f64| {
            if v.is_nan() {
                0
            } else {
                (v * s - 0.5).ceil().clamp(0.0, self.h as f64) as usize
            }
        };
        (clampx(x0), clampx(x1), clampy(y0), clampy(y1))
    }

    /// Fill the rectangle [x0, x1)×[y0, y1) (output pixels) with `f(x, y)`
    /// evaluated at each sample centre; `None` leaves the sample as it is.
    /// Used for resampled images (CT planes) and colour ramps.
    pub fn fill_with(
        &mut self,
        x0: f64,
        y0: f64,
        x1: f64,
        y1: f64,
        mut f: impl FnMut(f64, f64) -> Option<Rgb8>,
    ) {
        if ![x0, y0, x1, y1].iter().all(|v| v.is_finite()) {
            return;
        }
        let (sx0, sx1, sy0, sy1) = self.sample_range(x0, x1, y0, y1);
        let s = self.ss as f64;
        for sy in sy0..sy1 {
            let y = (sy as f64 + 0.5) / s;
            for sx in sx0..sx1 {
                let x = (sx as f64 + 0.5) / s;
                if let Some(c) = f(x, y) {
                    self.px[sx + sy * self.w] = c;
                }
            }
        }
    }

    /// Copy a finished image with its top-left corner at output pixel
    /// (x, y); parts outside the canvas are dropped. Lets a figure draw its
    /// panels on canvases of their own, which clips them for free.
    pub fn blit(&mut self, img: &Rgb, x: i64, y: i64) {
        if img.px.len() < img.w * img.h {
            return;
        }
        let ss = self.ss as i64;
        for iy in 0..img.h as i64 {
            for ix in 0..img.w as i64 {
                let c = img.px[(ix + iy * img.w as i64) as usize];
                for sy in 0..ss {
                    for sx in 0..ss {
                        let (px, py) = ((x + ix) * ss + sx, (y + iy) * ss + sy);
                        if px >= 0 && py >= 0 && (px as usize) < self.w && (py as usize) < self.h {
                            self.px[px as usize + py as usize * self.w] = c;
                        }
                    }
                }
            }
        }
    }

    /// A filled axis-aligned rectangle.
    pub fn rect(&mut self, x0: f64, y0: f64, x1: f64, y1: f64, colour: Rgb8) {
        self.fill_with(x0, y0, x1, y1, |_, _| Some(colour));
    }

    /// A rectangle's outline of the given width, drawn inside it.
    pub fn rect_outline(&mut self, x0: f64, y0: f64, x1: f64, y1: f64, width: f64, colour: Rgb8) {
        self.rect(x0, y0, x1, y0 + width, colour);
        self.rect(x0, y1 - width, x1, y1, colour);
        self.rect(x0, y0, x0 + width, y1, colour);
        self.rect(x1 - width, y0, x1, y1, colour);
    }

    /// A filled disc.
    pub fn disc(&mut self, cx: f64, cy: f64, r: f64, colour: Rgb8) {
        self.capsule([cx, cy], [cx, cy], r, colour, None);
    }

    /// A circle of radius `r` and line width `width`.
    pub fn ring(&mut self, cx: f64, cy: f64, r: f64, width: f64, colour: Rgb8) {
        if !(cx.is_finite() && cy.is_finite() && r.is_finite() && width.is_finite()) {
            return;
        }
        let (ri, ro) = ((r - 0.5 * width).max(0.0), r + 0.5 * width);
        self.fill_with(cx - ro, cy - ro, cx + ro, cy + ro, |x, y| {
            let d = (x - cx).hypot(y - cy);
            (d >= ri && d <= ro).then_some(colour)
        });
    }

    /// A straight 2-D line of the given width with round caps.
    pub fn line(&mut self, a: [f64; 2], b: [f64; 2], width: f64, colour: Rgb8) {
        self.capsule(a, b, 0.5 * width, colour, None);
    }

    /// Consecutive points joined by lines.
    pub fn polyline(&mut self, pts: &[[f64; 2]], width: f64, colour: Rgb8) {
        for w in pts.windows(2) {
            self.line(w[0], w[1], width, colour);
        }
    }

    /// A dashed polyline: `dash` pixels drawn, `gap` pixels skipped, the
    /// pattern running on across vertices.
    pub fn dashed_polyline(
        &mut self,
        pts: &[[f64; 2]],
        width: f64,
        dash: f64,
        gap: f64,
        colour: Rgb8,
    ) {
        if !(dash > 0.0 && gap >= 0.0 && dash.is_finite() && gap.is_finite()) {
            return self.polyline(pts, width, colour);
        }
        let period = dash + gap;
        let mut phase = 0.0f64;
        for w in pts.windows(2) {
            let (a, b) = (w[0], w[1]);
            let len = (b[0] - a[0]).hypot(b[1] - a[1]);
            if !len.is_finite() {
                continue;
            }
            let mut s = 0.0;
            while s < len {
                let in_dash = phase < dash;
                let step = if in_dash {
                    dash - phase
                } else {
                    period - phase
                }
                .min(len - s);
                if in_dash {
                    let p = |t: f64| {
                        [
                            a[0] + (b[0] - a[0]) * t / len,
                            a[1] + (b[1] - a[1]) * t / len,
                        ]
                    };
                    self.line(p(s), p(s + step), width, colour);
                }
                s += step;
                phase = (phase + step) % period;
            }
        }
    }

    /// A 3-D segment of width `width` (pixels), hidden where the z-buffer
    /// holds something nearer by more than `tolerance_mm`. Depth is not
    /// written, so lines never hide surfaces.
    pub fn line3(
        &mut self,
        cam: &Camera,
        a: &Point3,
        b: &Point3,
        width: f64,
        colour: Rgb8,
        tolerance_mm: f64,
    ) {
        let (pa, pb) = (cam.project(a), cam.project(b));
        self.capsule(
            [pa[0], pa[1]],
            [pb[0], pb[1]],
            0.5 * width,
            colour,
            Some((pa[2], pb[2], tolerance_mm)),
        );
    }

    /// Samples within `r` of segment ab; with `depth` = (depth at a, depth at
    /// b, tolerance), only where the stored depth is not nearer than the
    /// segment's by more than the tolerance.
    fn capsule(
        &mut self,
        a: [f64; 2],
        b: [f64; 2],
        r: f64,
        colour: Rgb8,
        depth: Option<(f64, f64, f64)>,
    ) {
        if !(a.iter().chain(b.iter()).all(|v| v.is_finite()) && r.is_finite() && r > 0.0) {
            return;
        }
        if let Some((da, db, tol)) = depth
            && !(da.is_finite() && db.is_finite() && tol.is_finite())
        {
            return;
        }
        let s = self.ss as f64;
        let (a, b, r) = ([a[0] * s, a[1] * s], [b[0] * s, b[1] * s], r * s);
        let x0 = (a[0].min(b[0]) - r - 0.5).floor().max(0.0);
        let x1 = (a[0].max(b[0]) + r + 0.5).ceil().min(self.w as f64);
        let y0 = (a[1].min(b[1]) - r - 0.5).floor().max(0.0);
        let y1 = (a[1].max(b[1]) + r + 0.5).ceil().min(self.h as f64);
        if x0 >= x1 || y0 >= y1 {
            return;
        }
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let len2 = dx * dx + dy * dy;
        let r2 = r * r;
        for sy in y0 as usize..y1 as usize {
            let py = sy as f64 + 0.5;
            for sx in x0 as usize..x1 as usize {
                let px = sx as f64 + 0.5;
                let t = if len2 > 0.0 {
                    (((px - a[0]) * dx + (py - a[1]) * dy) / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let (ex, ey) = (px - a[0] - t * dx, py - a[1] - t * dy);
                if ex * ex + ey * ey > r2 {
                    continue;
                }
                let i = sx + sy * self.w;
                if let Some((da, db, tol)) = depth
                    && da + (db - da) * t > self.depth[i] as f64 + tol
                {
                    continue;
                }
                self.px[i] = colour;
            }
        }
    }

    /// Draw a mesh with the z-buffer: the nearest surface wins; at equal
    /// depth the triangle drawn first (see `tile_order`) stays. Triangles with a vertex index out
    /// of range or a non-finite position are skipped.
    pub fn draw_mesh(&mut self, cam: &Camera, layer: &MeshLayer) {
        let n = layer.positions.len();
        let proj: Vec<[f64; 3]> = layer.positions.iter().map(|p| cam.project(p)).collect();
        let normals = match layer.shading {
            Shading::Smooth => Some(vertex_normals(layer.positions, layer.triangles)),
            _ => None,
        };
        let light = cam.light();
        // Visibility first (nearest triangle id per sample, 0 for none),
        // shading after: each visible sample is shaded once.
        let mut vis = vec![0u32; self.w * self.h];
        let mut setup: Vec<Option<TriShade>> = vec![None; layer.triangles.len()];
        for t in tile_order(&proj, layer.triangles) {
            let tri = &layer.triangles[t];
            let idx = tri.map(|i| i as usize);
            if idx.iter().any(|&i| i >= n) {
                continue;
            }
            let p = idx.map(|i| proj[i]);
            if p.iter().flatten().any(|v| !v.is_finite()) {
                continue;
            }
            let w = idx.map(|i| layer.positions[i]);
            let face = (w[1] - w[0]).cross(&(w[2] - w[0])).try_normalize(1e-300);
            let light_at: [f64; 3] = match (&normals, layer.shading) {
                (_, Shading::None) => [1.0; 3],
                (Some(vn), Shading::Smooth) => {
                    // Orient vertex normals with the face so that the
                    // interpolation never passes through zero inside it.
                    let f = face.unwrap_or_else(Vector3::zeros);
                    idx.map(|i| {
                        let v = vn[i];
                        let v = if v.dot(&f) < 0.0 { -v } else { v };
                        v.dot(&light)
                    })
                }
                _ => [face.map_or(1.0, |f| lambert(f.dot(&light))); 3],
            };
            let corner = [0, 1, 2].map(|k| (layer.corner)(t, k));
            let twice_area = (p[1][0] - p[0][0]) * (p[2][1] - p[0][1])
                - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]);
            setup[t] = Some(TriShade {
                p,
                inv_area: 1.0 / twice_area,
                light_at,
                corner,
            });
            let id = t as u32 + 1;
            self.fill_triangle(p, |i| vis[i] = id);
        }
        // Shade each visible sample once, whatever the overdraw.
        let smooth = layer.shading == Shading::Smooth;
        let inv_ss = 1.0 / self.ss as f64;
        for (i, &id) in vis.iter().enumerate() {
            let Some(Some(ts)) = id.checked_sub(1).map(|t| &setup[t as usize]) else {
                continue;
            };
            let t = id as usize - 1;
            let pt = [
                ((i % self.w) as f64 + 0.5) * inv_ss,
                ((i / self.w) as f64 + 0.5) * inv_ss,
            ];
            let q = &ts.p;
            let e = |a: &[f64; 3], b: &[f64; 3]| {
                (b[0] - a[0]) * (pt[1] - a[1]) - (b[1] - a[1]) * (pt[0] - a[0])
            };
            // Snapping may put a sample a hair outside: clamp the weights.
            let b0 = (e(&q[1], &q[2]) * ts.inv_area).clamp(0.0, 1.0);
            let b1 = (e(&q[2], &q[0]) * ts.inv_area).clamp(0.0, 1.0 - b0);
            let b = [b0, b1, 1.0 - b0 - b1];
            let mut v = [0f32; 3];
            for (c, out) in v.iter_mut().enumerate() {
                *out = (b[0] * ts.corner[0][c] as f64
                    + b[1] * ts.corner[1][c] as f64
                    + b[2] * ts.corner[2][c] as f64) as f32;
            }
            let base = (layer.paint)(t, v);
            let l = if smooth {
                lambert(b[0] * ts.light_at[0] + b[1] * ts.light_at[1] + b[2] * ts.light_at[2])
            } else {
                ts.light_at[0]
            };
            // Truncating +½ rounds the non-negative product without a libm call.
            self.px[i] = base.map(|c| (c as f64 * l + 0.5).clamp(0.0, 255.0) as u8);
        }
    }

    /// Rasterise one projected triangle (output-pixel x, y and depth per
    /// corner) with a top-left fill rule, so that triangles sharing an edge
    /// cover each sample exactly once. The depth buffer is updated here;
    /// `hit` gets the index of each sample the triangle now owns.
    ///
    /// Corners are snapped to 1/16 of a sample and the edge functions are
    /// evaluated in integers: exact, so the fill rule is watertight for any
    /// mesh and the result cannot depend on evaluation order. Corners more
    /// than 2²⁴ samples away (only absurd zooms or overflowing inputs) make
    /// the triangle be skipped rather than wrap around.
    fn fill_triangle(&mut self, p: [[f64; 3]; 3], mut hit: impl FnMut(usize)) {
        const SUB: i64 = 16;
        const LIMIT: f64 = (1i64 << 24) as f64;
        let s = self.ss as f64;
        let in_range = |v: f64| (v * s).abs() < LIMIT;
        if p.iter().any(|v| !(in_range(v[0]) && in_range(v[1]))) {
            return;
        }
        let fix = |v: f64| (v * s * SUB as f64).round() as i64;
        let mut q = p.map(|v| [fix(v[0]), fix(v[1])]);
        let mut z = p.map(|v| v[2]);
        let mut area = edge_i(&q[0], &q[1], &q[2]);
        if area == 0 {
            return;
        }
        // Make the winding positive so that one fill rule serves both; the
        // swap is undone on the weights handed to `shade`.
        let swap = area < 0;
        if swap {
            q.swap(1, 2);
            z.swap(1, 2);
            area = -area;
        }
        let inv_area = 1.0 / area as f64;
        let min_x = q.iter().map(|v| v[0]).min().unwrap_or(0);
        let max_x = q.iter().map(|v| v[0]).max().unwrap_or(0);
        let min_y = q.iter().map(|v| v[1]).min().unwrap_or(0);
        let max_y = q.iter().map(|v| v[1]).max().unwrap_or(0);
        // Sample (sx, sy) sits at ((sx + ½)·SUB, (sy + ½)·SUB).
        let first = |lo: i64| (lo - SUB / 2 + SUB - 1).div_euclid(SUB).max(0);
        let last = |hi: i64, n: usize| (hi - SUB / 2).div_euclid(SUB).min(n as i64 - 1);
        let (sx0, sx1) = (first(min_x), last(max_x, self.w));
        let (sy0, sy1) = (first(min_y), last(max_y, self.h));
        if sx0 > sx1 || sy0 > sy1 {
            return;
        }
        // Edge k is opposite corner k: from q[k+1] to q[k+2].
        let ends = [0, 1, 2].map(|k| (q[(k + 1) % 3], q[(k + 2) % 3]));
        let bias = ends.map(|(a, b)| if is_top_left_i(&a, &b) { 0 } else { -1 });
        let step_x = ends.map(|(a, b)| -(b[1] - a[1]) * SUB);
        let slope = ends.map(|(a, b)| a[1] - b[1]);
        let inv_slope = slope.map(|v| if v != 0 { 1.0 / v as f64 } else { 0.0 });
        for sy in sy0..=sy1 {
            let py = sy * SUB + SUB / 2;
            // Narrow a wide row to where every edge function can be ≥ 0
            // (a sample of slack each side, so truncation may stand in for
            // floor and ceil), so that slivers seen edge-on cost their area
            // and not their bounding box; the exact test below still decides
            // every sample.
            let (mut lo, mut hi) = (sx0, sx1);
            if sx1 - sx0 > 8 {
                for k in 0..3 {
                    let (a, b) = &ends[k];
                    let c = ((b[0] - a[0]) * (py - a[1])) as f64;
                    let x_at = (a[0] as f64 - c * inv_slope[k]) * (1.0 / SUB as f64) - 0.5;
                    if slope[k] > 0 {
                        lo = lo.max(x_at as i64 - 1);
                    } else if slope[k] < 0 {
                        hi = hi.min(x_at as i64 + 1);
                    } else if c < 0.0 {
                        hi = lo - 1;
                    }
                }
            }
            if lo > hi {
                continue;
            }
            let px = lo * SUB + SUB / 2;
            let mut e = [0, 1, 2].map(|k| edge_i(&ends[k].0, &ends[k].1, &[px, py]));
            let row = sy as usize * self.w;
            for sx in lo..=hi {
                if e[0] + bias[0] >= 0 && e[1] + bias[1] >= 0 && e[2] + bias[2] >= 0 {
                    let b = e.map(|v| v as f64 * inv_area);
                    let depth = (b[0] * z[0] + b[1] * z[1] + b[2] * z[2]) as f32;
                    let i = row + sx as usize;
                    if depth < self.depth[i] {
                        self.depth[i] = depth;
                        hit(i);
                    }
                }
                for k in 0..3 {
                    e[k] += step_x[k];
                }
            }
        }
    }
}

/// Twice the signed area of (a, b, p) in fixed point; positive when p is to
/// the right of a→b in y-down image coordinates, i.e. clockwise on screen.
#[inline]
fn edge_i(a: &[i64; 2], b: &[i64; 2], p: &[i64; 2]) -> i64 {
    (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
}

/// Top or left edge of a positively wound triangle (y down): samples exactly
/// on it belong to this triangle, not its neighbour.
#[inline]
fn is_top_left_i(a: &[i64; 2], b: &[i64; 2]) -> bool {
    (a[1] == b[1] && b[0] > a[0]) || b[1] < a[1]
}

/// What the shading pass needs of one triangle: projected corners (output
/// pixels, depth), 1 / twice its signed area, light at its corners and its
/// corner values.
#[derive(Clone, Copy)]
struct TriShade {
    p: [[f64; 3]; 3],
    inv_area: f64,
    light_at: [f64; 3],
    corner: [[f32; 3]; 3],
}

/// Triangle indices ordered by the Z-order (Morton) code of the 8-pixel
/// tile under their first corner, ties by index: neighbouring triangles are
/// then drawn one after another and hit the same cache lines of the
/// buffers, whatever order the mesher left them in. Bad triangles go last
/// (and are skipped there).
fn tile_order(proj: &[[f64; 3]], tris: &[[u32; 3]]) -> Vec<usize> {
    let key = |t: &[u32; 3]| -> u64 {
        let Some(p) = proj.get(t[0] as usize) else {
            return u64::MAX;
        };
        if !(p[0].is_finite() && p[1].is_finite()) {
            return u64::MAX;
        }
        let tile = |v: f64| ((v / 8.0).clamp(0.0, 65535.0)) as u64;
        let (mut x, mut y) = (tile(p[0]), tile(p[1]));
        let mut code = 0u64;
        for bit in 0..16 {
            code |= ((x & 1) << (2 * bit)) | ((y & 1) << (2 * bit + 1));
            x >>= 1;
            y >>= 1;
        }
        code
    };
    let mut order: Vec<(u64, usize)> = tris.iter().enumerate().map(|(i, t)| (key(t), i)).collect();
    order.sort_unstable();
    order.into_iter().map(|(_, i)| i).collect()
}

/// Area-weighted vertex normals (unnormalised sums of face area vectors),
/// ignoring triangles with bad indices or non-finite corners.
fn vertex_normals(pos: &[Point3], tris: &[[u32; 3]]) -> Vec<Vector3> {
    let mut n = vec![Vector3::zeros(); pos.len()];
    for t in tris {
        let i = t.map(|i| i as usize);
        if i.iter().any(|&k| k >= pos.len()) {
            continue;
        }
        let a = (pos[i[1]] - pos[i[0]]).cross(&(pos[i[2]] - pos[i[0]]));
        if a.iter().all(|c| c.is_finite()) {
            for k in i {
                n[k] += a;
            }
        }
    }
    n.into_iter()
        .map(|v| v.try_normalize(1e-300).unwrap_or_else(Vector3::zeros))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const WHITE: Rgb8 = [255; 3];
    const RED: Rgb8 = [255, 0, 0];
    const BLUE: Rgb8 = [0, 0, 255];

    fn top_camera(w: u32, h: u32) -> Camera {
        // Looking down −z with +y up: world x → image right, world y → image up.
        Camera::new(
            -Vector3::z(),
            Vector3::y(),
            Point3::new(w as f64 / 2.0, h as f64 / 2.0, 0.0),
            1.0,
            w,
            h,
        )
        .unwrap()
    }

    fn flat<'a>(
        pos: &'a [Point3],
        tris: &'a [[u32; 3]],
        colours: &'a dyn Fn(usize, [f32; 3]) -> Rgb8,
    ) -> MeshLayer<'a> {
        MeshLayer {
            positions: pos,
            triangles: tris,
            corner: &|_, _| [0.0; 3],
            paint: colours,
            shading: Shading::None,
        }
    }

    #[test]
    fn camera_maps_world_axes_to_image_axes() {
        let cam = top_camera(100, 80);
        let p = cam.project(&Point3::new(60.0, 50.0, -3.0));
        // +x is right of centre, +y (up) is above the centre row, depth grows along −z.
        assert_eq!(p, [60.0, 30.0, 3.0]);
        let q = cam.unproject(p[0], p[1]);
        assert!((q - Point3::new(60.0, 50.0, 0.0)).norm() < 1e-12);
        assert!(Camera::new(Vector3::zeros(), Vector3::y(), Point3::origin(), 1.0, 1, 1).is_none());
        assert!(Camera::new(-Vector3::z(), Vector3::y(), Point3::origin(), 0.0, 1, 1).is_none());
        // An up vector along the view still yields an orthonormal camera.
        let c = Camera::new(Vector3::z(), Vector3::z(), Point3::origin(), 1.0, 4, 4).unwrap();
        assert!(c.up().dot(&c.view()).abs() < 1e-12 && (c.right().norm() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn fit_frames_points_inside_margin() {
        let pts = [Point3::new(-10.0, 0.0, 0.0), Point3::new(30.0, 20.0, 5.0)];
        let cam = Camera::fit(
            -Vector3::z(),
            Vector3::y(),
            &pts,
            200,
            100,
            10.0,
            Point3::origin(),
        )
        .unwrap();
        let a = cam.project(&pts[0]);
        let b = cam.project(&pts[1]);
        // 40 mm over 180 px wide, 20 mm over 80 px high: the height limits.
        assert!((cam.mm_per_px() - 0.25).abs() < 1e-12);
        assert!((a[0] - 20.0).abs() < 1e-9 && (b[0] - 180.0).abs() < 1e-9);
        assert!((a[1] - 90.0).abs() < 1e-9 && (b[1] - 10.0).abs() < 1e-9);
        let none = Camera::fit(
            -Vector3::z(),
            Vector3::y(),
            &[],
            10,
            10,
            1.0,
            Point3::origin(),
        );
        assert!(none.is_none());
    }

    #[test]
    fn triangle_covers_exactly_the_pixels_whose_centres_are_inside() {
        let cam = top_camera(20, 20);
        // Image corners (2,2), (12,2), (2,12) ↔ world y = 20 − image y.
        let pos = [
            Point3::new(2.0, 18.0, 0.0),
            Point3::new(12.0, 18.0, 0.0),
            Point3::new(2.0, 8.0, 0.0),
        ];
        let tris = [[0u32, 1, 2]];
        let mut c = Canvas::new(20, 20, 1, WHITE);
        c.draw_mesh(&cam, &flat(&pos, &tris, &|_, _| RED));
        let img = c.finish();
        for y in 0..20 {
            for x in 0..20 {
                let (cx, cy) = (x as f64 + 0.5, y as f64 + 0.5);
                let inside = cx > 2.0 && cy > 2.0 && (cx - 2.0) + (cy - 2.0) < 10.0;
                let want = if inside { RED } else { WHITE };
                assert_eq!(img.px[x + 20 * y], want, "pixel ({x},{y})");
            }
        }
    }

    #[test]
    fn shared_edge_is_covered_once_and_without_gaps() {
        // Two triangles of a square split along its diagonal, whose samples
        // lie exactly on the diagonal: each must land in one triangle only.
        let cam = top_camera(8, 8);
        let pos = [
            Point3::new(0.0, 8.0, 0.0),
            Point3::new(8.0, 8.0, 0.0),
            Point3::new(8.0, 0.0, 0.0),
            Point3::new(0.0, 0.0, 0.0),
        ];
        let tris = [[0u32, 1, 2], [0, 2, 3]];
        let mut hits = vec![0u32; 64];
        for t in 0..2 {
            let mut c = Canvas::new(8, 8, 1, WHITE);
            c.draw_mesh(&cam, &flat(&pos, &tris[t..t + 1], &|_, _| RED));
            for (i, p) in c.finish().px.iter().enumerate() {
                hits[i] += (*p == RED) as u32;
            }
        }
        assert!(hits.iter().all(|&h| h == 1), "{hits:?}");
    }

    #[test]
    fn jittered_mesh_covers_every_inner_sample_exactly_once() {
        // A 7×7 grid with irregular, non-representable offsets, split into
        // 72 triangles: the exact fill rule must neither double-cover nor
        // leave gaps along any shared edge, whatever its slope.
        let cam = top_camera(40, 40);
        let n = 7;
        let jitter = |i: usize, j: usize| ((i * 7 + j * 13) % 11) as f64 / 11.0 * 2.3 - 1.15;
        let pos: Vec<Point3> = (0..n * n)
            .map(|k| {
                let (i, j) = (k % n, k / n);
                let inner = (1..n - 1).contains(&i) && (1..n - 1).contains(&j);
                let (dx, dy) = if inner {
                    (jitter(i, j), jitter(j, i))
                } else {
                    (0.0, 0.0)
                };
                Point3::new(2.0 + 6.0 * i as f64 + dx, 2.0 + 6.0 * j as f64 + dy, 0.0)
            })
            .collect();
        let mut tris = Vec::new();
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let k = (i + j * n) as u32;
                let m = n as u32;
                if (i + j) % 2 == 0 {
                    tris.push([k, k + 1, k + m + 1]);
                    tris.push([k, k + m + 1, k + m]);
                } else {
                    tris.push([k, k + 1, k + m]);
                    tris.push([k + 1, k + m + 1, k + m]);
                }
            }
        }
        let mut hits = vec![0u32; 40 * 40];
        for t in 0..tris.len() {
            let mut c = Canvas::new(40, 40, 1, WHITE);
            c.draw_mesh(&cam, &flat(&pos, &tris[t..t + 1], &|_, _| RED));
            for (i, p) in c.finish().px.iter().enumerate() {
                hits[i] += (*p == RED) as u32;
            }
        }
        // The grid spans world 2..38, i.e. image 2..38 as well.
        for y in 3..37 {
            for x in 3..37 {
                assert_eq!(hits[x + 40 * y], 1, "sample ({x},{y})");
            }
        }
        assert!(hits.iter().all(|&h| h <= 1));
    }

    #[test]
    fn z_buffer_keeps_the_nearer_triangle_in_either_order() {
        let cam = top_camera(10, 10);
        let quad = |z: f64| {
            vec![
                Point3::new(1.0, 9.0, z),
                Point3::new(9.0, 9.0, z),
                Point3::new(9.0, 1.0, z),
                Point3::new(1.0, 1.0, z),
            ]
        };
        // The viewer looks down −z: z = 5 is nearer than z = −5.
        let mut pos = quad(5.0);
        pos.extend(quad(-5.0));
        let near = [[0u32, 1, 2], [0, 2, 3]];
        let far = [[4u32, 5, 6], [4, 6, 7]];
        for order in [[near, far], [far, near]] {
            let tris: Vec<[u32; 3]> = order.concat();
            let paint = |t: usize, _: [f32; 3]| if tris[t][0] == 0 { RED } else { BLUE };
            let mut c = Canvas::new(10, 10, 2, WHITE);
            c.draw_mesh(&cam, &flat(&pos, &tris, &paint));
            assert_eq!(c.finish().px[5 + 10 * 5], RED);
        }
    }

    #[test]
    fn lambert_is_two_sided_and_brightest_facing_the_light() {
        let cam = top_camera(10, 10);
        let l = cam.light();
        // A triangle facing the light, and the same triangle wound the other way.
        let e1 = l.cross(&Vector3::x()).normalize();
        let e2 = l.cross(&e1);
        let c = Point3::new(5.0, 5.0, 0.0);
        let pos = [c - e1 * 20.0 - e2 * 20.0, c + e1 * 40.0, c + e2 * 40.0];
        let mut out = vec![];
        for tris in [[[0u32, 1, 2]], [[0u32, 2, 1]]] {
            let mut canvas = Canvas::new(10, 10, 1, [0; 3]);
            let layer = MeshLayer {
                shading: Shading::Flat,
                ..flat(&pos, &tris, &|_, _| [200, 100, 50])
            };
            canvas.draw_mesh(&cam, &layer);
            out.push(canvas.finish().px[55]);
        }
        assert_eq!(out[0], [200, 100, 50]);
        assert_eq!(out[0], out[1]);
    }

    #[test]
    fn per_vertex_values_are_interpolated() {
        let cam = top_camera(30, 30);
        let pos = [
            Point3::new(0.0, 30.0, 0.0),
            Point3::new(30.0, 30.0, 0.0),
            Point3::new(0.0, 0.0, 0.0),
        ];
        let tris = [[0u32, 1, 2]];
        let corner = |_: usize, k: usize| if k == 1 { [255.0, 0.0, 0.0] } else { [0.0; 3] };
        let paint = |_: usize, v: [f32; 3]| [v[0].round() as u8, 0, 0];
        let layer = MeshLayer {
            positions: &pos,
            triangles: &tris,
            corner: &corner,
            paint: &paint,
            shading: Shading::None,
        };
        let mut c = Canvas::new(30, 30, 1, WHITE);
        c.draw_mesh(&cam, &layer);
        let img = c.finish();
        // Red grows with x (towards corner 1) along the top row.
        let r = |x: usize| img.px[x][0];
        assert!(r(2) < r(14) && r(14) < r(27));
        assert!((r(14) as i32 - 123).abs() <= 1, "{}", r(14));
    }

    #[test]
    fn bad_triangles_are_skipped_without_panicking() {
        let cam = top_camera(10, 10);
        let pos = [
            Point3::new(1.0, 1.0, 0.0),
            Point3::new(f64::NAN, 5.0, 0.0),
            Point3::new(5.0, 9.0, 0.0),
            Point3::new(5.0, 9.0, 0.0),
        ];
        let tris = [[0u32, 1, 2], [0, 2, 9], [0, 2, 3]];
        let mut c = Canvas::new(10, 10, 2, WHITE);
        c.draw_mesh(&cam, &flat(&pos, &tris, &|_, _| RED));
        c.line([f64::NAN, 0.0], [3.0, 3.0], 2.0, RED);
        c.disc(f64::INFINITY, 1.0, 3.0, RED);
        c.ring(1.0, 1.0, f64::NAN, 1.0, RED);
        c.fill_with(f64::NAN, 0.0, 5.0, 5.0, |_, _| Some(RED));
        assert!(c.finish().px.iter().all(|p| *p == WHITE));
        let z = Canvas::new(0, 0, 0, WHITE).finish();
        assert_eq!((z.w, z.h, z.px.len()), (1, 1, 1));
    }

    #[test]
    fn lines_and_discs_cover_their_shapes() {
        let mut c = Canvas::new(20, 20, 2, WHITE);
        c.line([2.0, 10.0], [18.0, 10.0], 2.0, RED);
        c.disc(10.0, 4.0, 2.0, BLUE);
        let img = c.finish();
        assert_eq!(img.px[5 + 20 * 9], RED);
        assert_eq!(img.px[5 + 20 * 10], RED);
        assert_eq!(img.px[5 + 20 * 12], WHITE);
        assert_eq!(img.px[9 + 20 * 3], BLUE);
        assert_eq!(img.px[10 + 20 * 7], WHITE);
        // A partly covered pixel is a mix, not either colour.
        let mut c = Canvas::new(4, 4, 2, WHITE);
        c.rect(0.0, 0.0, 1.5, 4.0, [0; 3]);
        assert_eq!(c.finish().px[1], [128; 3]);
    }

    #[test]
    fn blit_copies_pixels_and_clips() {
        let mut src = Canvas::new(3, 2, 1, RED);
        src.rect(0.0, 0.0, 1.0, 1.0, BLUE);
        let img = src.finish();
        let mut c = Canvas::new(4, 4, 2, WHITE);
        c.blit(&img, 2, 3);
        c.blit(&img, -10, 0);
        let out = c.finish();
        assert_eq!(out.px[2 + 4 * 3], BLUE);
        assert_eq!(out.px[3 + 4 * 3], RED);
        assert_eq!(out.px[1 + 4 * 3], WHITE);
        assert_eq!(out.px[0], WHITE);
    }

    #[test]
    fn dashes_leave_gaps() {
        let mut c = Canvas::new(40, 5, 1, WHITE);
        c.dashed_polyline(&[[0.0, 2.5], [20.0, 2.5], [40.0, 2.5]], 1.0, 4.0, 4.0, RED);
        let img = c.finish();
        let row: Vec<bool> = (0..40).map(|x| img.px[x + 80] == RED).collect();
        assert!(row[1] && row[2] && !row[5] && !row[6] && row[9] && !row[14] && row[17]);
    }

    #[test]
    fn line3_is_hidden_behind_nearer_surfaces() {
        let cam = top_camera(20, 20);
        let pos = [
            Point3::new(0.0, 20.0, 1.0),
            Point3::new(10.0, 20.0, 1.0),
            Point3::new(10.0, 0.0, 1.0),
            Point3::new(0.0, 0.0, 1.0),
        ];
        let tris = [[0u32, 1, 2], [0, 2, 3]];
        let mut c = Canvas::new(20, 20, 1, WHITE);
        c.draw_mesh(&cam, &flat(&pos, &tris, &|_, _| BLUE));
        // Runs under the quad (z = −1) on the left, in the open on the right.
        c.line3(
            &cam,
            &Point3::new(1.0, 10.0, -1.0),
            &Point3::new(19.0, 10.0, -1.0),
            1.0,
            RED,
            0.5,
        );
        let img = c.finish();
        assert_eq!(img.px[4 + 20 * 9], BLUE);
        assert_eq!(img.px[15 + 20 * 9], RED);
        // In front of the quad it shows.
        let mut c2 = Canvas::new(20, 20, 1, WHITE);
        c2.draw_mesh(&cam, &flat(&pos, &tris, &|_, _| BLUE));
        c2.line3(
            &cam,
            &Point3::new(1.0, 10.0, 3.0),
            &Point3::new(9.0, 10.0, 3.0),
            1.0,
            RED,
            0.0,
        );
        assert_eq!(c2.finish().px[4 + 20 * 9], RED);
    }
}
