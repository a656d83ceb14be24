//! Planar template outlines: a closed chain of segments, circular arcs and
//! densely sampled curves, each tagged as sutured (attachment edge) or free
//! edge. Coordinates are template millimetres (u, v).

use std::f64::consts::PI;

pub type P2 = [f64; 2];

/// Which part of the leaflet boundary a piece belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Edge {
    /// Attachment edge, sewn to the aortic wall.
    Sutured,
    /// Free edge, coapting with the neighbours.
    Free,
}

impl Edge {
    /// Code written to `boundary` point data (0 interior).
    pub fn code(self) -> u8 {
        match self {
            Edge::Sutured => 1,
            Edge::Free => 2,
        }
    }
}

/// One boundary piece.
#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    Segment {
        a: P2,
        b: P2,
    },
    /// Arc of `radius` about `centre` from angle `start` over `sweep` radians
    /// (positive: counter-clockwise).
    Arc {
        centre: P2,
        radius: f64,
        start: f64,
        sweep: f64,
    },
    /// A smooth curve given by dense samples; arc length is that of the
    /// polyline (the samples are fine enough that the chord error is far
    /// below any mesh size).
    Sampled {
        pts: Vec<P2>,
        cum: Vec<f64>,
    },
}

impl Shape {
    pub fn sampled(pts: Vec<P2>) -> Shape {
        let mut cum = Vec::with_capacity(pts.len());
        let mut s = 0.0;
        cum.push(0.0);
        for w in pts.windows(2) {
            s += dist(w[0], w[1]);
            cum.push(s);
        }
        Shape::Sampled { pts, cum }
    }

    pub fn length(&self) -> f64 {
        match self {
            Shape::Segment { a, b } => dist(*a, *b),
            Shape::Arc { radius, sweep, .. } => radius * sweep.abs(),
            Shape::Sampled { cum, .. } => *cum.last().unwrap_or(&0.0),
        }
    }

    /// Point at arc length `s` from the start (clamped to the piece).
    pub fn at(&self, s: f64) -> P2 {
        let len = self.length();
        let s = s.clamp(0.0, len);
        match self {
            Shape::Segment { a, b } => {
                let t = if len > 0.0 { s / len } else { 0.0 };
                lerp(*a, *b, t)
            }
            Shape::Arc {
                centre,
                radius,
                start,
                sweep,
            } => {
                let th = start + sweep.signum() * s / radius;
                [centre[0] + radius * th.cos(), centre[1] + radius * th.sin()]
            }
            Shape::Sampled { pts, cum } => {
                let i = cum.partition_point(|&c| c <= s).clamp(1, pts.len() - 1);
                let d = cum[i] - cum[i - 1];
                let t = if d > 0.0 { (s - cum[i - 1]) / d } else { 0.0 };
                lerp(pts[i - 1], pts[i], t)
            }
        }
    }

    pub fn start(&self) -> P2 {
        self.at(0.0)
    }

    pub fn end(&self) -> P2 {
        match self {
            Shape::Segment { b, .. } => *b,
            Shape::Sampled { pts, .. } => *pts.last().unwrap(),
            _ => self.at(self.length()),
        }
    }

    pub fn reversed(&self) -> Shape {
        match self {
            Shape::Segment { a, b } => Shape::Segment { a: *b, b: *a },
            Shape::Arc {
                centre,
                radius,
                start,
                sweep,
            } => Shape::Arc {
                centre: *centre,
                radius: *radius,
                start: start + sweep,
                sweep: -sweep,
            },
            Shape::Sampled { pts, .. } => Shape::sampled(pts.iter().rev().copied().collect()),
        }
    }

    /// ∮ (x dy − y dx) / 2 over the piece (Green's theorem), exact for
    /// segments and arcs.
    fn green(&self) -> f64 {
        match self {
            Shape::Segment { a, b } => 0.5 * (a[0] * b[1] - a[1] * b[0]),
            Shape::Arc {
                centre,
                radius: r,
                start,
                sweep,
            } => {
                let (t0, t1) = (*start, start + sweep);
                0.5 * (r * r * sweep + r * centre[0] * (t1.sin() - t0.sin())
                    - r * centre[1] * (t1.cos() - t0.cos()))
            }
            Shape::Sampled { pts, .. } => pts
                .windows(2)
                .map(|w| 0.5 * (w[0][0] * w[1][1] - w[0][1] * w[1][0]))
                .sum(),
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Piece {
    pub shape: Shape,
    pub edge: Edge,
}

/// A closed, counter-clockwise chain of pieces. Corners (piece junctions)
/// are kept as mesh nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct Outline {
    pub pieces: Vec<Piece>,
}

impl Outline {
    /// Chain `pieces` (each must start where the previous ends, the last
    /// closing on the first) and orient it counter-clockwise.
    pub fn new(pieces: Vec<Piece>) -> Result<Outline, String> {
        if pieces.is_empty() {
            return Err("empty outline".into());
        }
        let scale = pieces.iter().map(|p| p.shape.length()).sum::<f64>();
        for (i, p) in pieces.iter().enumerate() {
            if !(p.shape.length() > 1e-9 * scale) {
                return Err(format!("outline piece {i} has zero length"));
            }
            let next = &pieces[(i + 1) % pieces.len()];
            if dist(p.shape.end(), next.shape.start()) > 1e-9 * scale {
                return Err(format!("outline pieces {i} and {} do not meet", i + 1));
            }
        }
        let mut o = Outline { pieces };
        if o.area() < 0.0 {
            o.pieces = o
                .pieces
                .iter()
                .rev()
                .map(|p| Piece {
                    shape: p.shape.reversed(),
                    edge: p.edge,
                })
                .collect();
        }
        Ok(o)
    }

    /// Exact enclosed area (signed: positive once oriented).
    pub fn area(&self) -> f64 {
        self.pieces.iter().map(|p| p.shape.green()).sum()
    }

    pub fn length(&self, edge: Edge) -> f64 {
        self.pieces
            .iter()
            .filter(|p| p.edge == edge)
            .map(|p| p.shape.length())
            .sum()
    }

    /// Split every piece into max(1, round(L/h)) equal arc-length parts.
    /// Returns the nodes in order and, per node, the tag of the piece that
    /// starts there (a corner between a sutured and a free piece is
    /// sutured: it is sewn).
    pub fn discretise(&self, h: f64) -> (Vec<P2>, Vec<Edge>) {
        let mut pts = Vec::new();
        let mut tags = Vec::new();
        let n = self.pieces.len();
        for (i, p) in self.pieces.iter().enumerate() {
            let len = p.shape.length();
            let k = ((len / h).round() as usize).max(1);
            let prev = self.pieces[(i + n - 1) % n].edge;
            for j in 0..k {
                let tag = if j == 0 && (prev == Edge::Sutured || p.edge == Edge::Sutured) {
                    Edge::Sutured
                } else {
                    p.edge
                };
                pts.push(if j == 0 {
                    p.shape.start()
                } else {
                    p.shape.at(len * j as f64 / k as f64)
                });
                tags.push(tag);
            }
        }
        (pts, tags)
    }

    /// Interior angles at the corners, degrees (for validation messages).
    pub fn corner_angles_deg(&self) -> Vec<f64> {
        let n = self.pieces.len();
        (0..n)
            .map(|i| {
                let a = &self.pieces[(i + n - 1) % n].shape;
                let b = &self.pieces[i].shape;
                let la = a.length();
                let d_in = sub(a.end(), a.at(la - 1e-6 * la));
                let d_out = sub(b.at(1e-6 * b.length()), b.start());
                let turn = (d_in[0] * d_out[1] - d_in[1] * d_out[0])
                    .atan2(d_in[0] * d_out[0] + d_in[1] * d_out[1]);
                (PI - turn).to_degrees()
            })
            .collect()
    }
}

pub fn dist(a: P2, b: P2) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

pub fn sub(a: P2, b: P2) -> P2 {
    [a[0] - b[0], a[1] - b[1]]
}

pub fn lerp(a: P2, b: P2, t: f64) -> P2 {
    [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_disc_area_and_orientation() {
        // Clockwise input is turned counter-clockwise; area is exact.
        let o = Outline::new(vec![
            Piece {
                shape: Shape::Arc {
                    centre: [0.0, 0.0],
                    radius: 2.0,
                    start: PI,
                    sweep: -PI,
                },
                edge: Edge::Sutured,
            },
            Piece {
                shape: Shape::Segment {
                    a: [2.0, 0.0],
                    b: [-2.0, 0.0],
                },
                edge: Edge::Free,
            },
        ])
        .unwrap();
        assert!((o.area() - 2.0 * PI).abs() < 1e-12);
        assert!((o.length(Edge::Sutured) - 2.0 * PI).abs() < 1e-12);
        let ang = o.corner_angles_deg();
        assert!(ang.iter().all(|a| (a - 90.0).abs() < 1e-3), "{ang:?}");
        let (pts, tags) = o.discretise(0.5);
        assert_eq!(pts.len(), 13 + 8);
        assert_eq!(tags.iter().filter(|&&t| t == Edge::Sutured).count(), 13 + 1);
    }
}
