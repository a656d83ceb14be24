//! The marching-cubes case table, generated from one face rule instead of
//! being copied from Lorensen–Cline's 15 classes.
//!
//! Cube corners are numbered `c = dx + 2·dy + 4·dz`. Edges 0–3 run along x at
//! (dy, dz) = (0,0), (1,0), (0,1), (1,1); edges 4–7 along y at (dx, dz); edges
//! 8–11 along z at (dx, dy).
//!
//! Why the table is crack-free and manifold by construction:
//! * On every cube face the iso-curve segments depend only on the face's four
//!   corner states. An ambiguous face (diagonal corners equal, the other two
//!   opposite) is always split the same way: each inside corner is cut off on
//!   its own (inside is 6-connected, outside 18-connected). Both cells sharing
//!   a face therefore draw the same segments on it, so every segment is a mesh
//!   edge of exactly one polygon on each side: no cracks, no open edges.
//! * Each cut cube edge lies on two faces of the cube and carries one segment
//!   endpoint on each, so the segments of a cube form disjoint closed cycles;
//!   each cycle is triangulated as a fan.
//! * A fan diagonal joins two cut edges that share no cube face, so no other
//!   cube holds both endpoints and the diagonal borders exactly the two
//!   triangles of its own fan. The fan apex is chosen to make this so.
//! * Segments are oriented so that the inside part of each face lies on their
//!   left seen from outside the cube; the cycles inherit one orientation, which
//!   gives every triangle the same outward winding.
//!
//! The unit tests check all of this exhaustively over the 256 cases (and pairs
//! of cases sharing a face), and the random-noise tests check it on volumes.

use std::sync::OnceLock;

/// Corners (lower, upper) of each edge.
pub const EDGE_CORNERS: [[u8; 2]; 12] = {
    let mut t = [[0u8; 2]; 12];
    let mut e = 0;
    while e < 12 {
        let m = (e % 4) as u8;
        let (c0, step) = match e / 4 {
            0 => (2 * (m & 1) + 4 * (m >> 1), 1),
            1 => ((m & 1) + 4 * (m >> 1), 2),
            _ => ((m & 1) + 2 * (m >> 1), 4),
        };
        t[e] = [c0, c0 + step];
        e += 1;
    }
    t
};

/// The six faces, each as its four corners in cyclic order, with the outward
/// axis and side.
pub fn faces() -> [([u8; 4], usize, u8); 6] {
    let mut out = [([0u8; 4], 0usize, 0u8); 6];
    for a in 0..3 {
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        for s in 0..2u8 {
            let corner = |ub: u8, uc: u8| (s << a) | (ub << b) | (uc << c);
            out[2 * a + s as usize] = (
                [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)],
                a,
                s,
            );
        }
    }
    out
}

pub fn edge_of(c0: u8, c1: u8) -> usize {
    let (lo, hi) = (c0.min(c1), c0.max(c1));
    EDGE_CORNERS
        .iter()
        .position(|e| e[0] == lo && e[1] == hi)
        .expect("corners are adjacent")
}

fn corner_pos(c: u8) -> [f64; 3] {
    [(c & 1) as f64, ((c >> 1) & 1) as f64, ((c >> 2) & 1) as f64]
}

fn edge_mid(e: usize) -> [f64; 3] {
    let [a, b] = EDGE_CORNERS[e].map(corner_pos);
    [0, 1, 2].map(|k| 0.5 * (a[k] + b[k]))
}

/// Bit mask of the faces each edge lies on.
fn edge_faces() -> [u8; 12] {
    let mut m = [0u8; 12];
    for (f, (q, _, _)) in faces().iter().enumerate() {
        for k in 0..4 {
            m[edge_of(q[k], q[(k + 1) % 4])] |= 1 << f;
        }
    }
    m
}

/// Directed iso-curve segments (from edge, to edge) on the faces of a cube
/// whose inside corners are the set bits of `case`.
pub fn face_segments(case: u8) -> Vec<(usize, usize)> {
    let inside = |c: u8| case >> c & 1 == 1;
    let mut segs = Vec::new();
    for (q, axis, side) in faces() {
        let e: [usize; 4] = [0, 1, 2, 3].map(|k| edge_of(q[k], q[(k + 1) % 4]));
        let cut: Vec<usize> = (0..4)
            .filter(|&k| inside(q[k]) != inside(q[(k + 1) % 4]))
            .collect();
        // (edge a, edge b, a point on the inside side of the segment)
        let mut raw: Vec<(usize, usize, [f64; 3])> = Vec::new();
        match cut.len() {
            0 => {}
            2 => {
                let (k0, k1) = (cut[0], cut[1]);
                let reference = if (k1 + 4 - k0) % 4 == 2 {
                    // Opposite edges: two inside corners side by side.
                    corner_pos(*q.iter().find(|&&c| inside(c)).unwrap())
                } else {
                    // Adjacent edges cut off the corner between them.
                    let shared = if k1 == k0 + 1 { q[k1] } else { q[k0] };
                    let lone = if inside(shared) {
                        shared
                    } else {
                        q[(q.iter().position(|&c| c == shared).unwrap() + 2) % 4]
                    };
                    corner_pos(lone)
                };
                raw.push((e[k0], e[k1], reference));
            }
            4 => {
                // Ambiguous face: cut off each inside corner separately.
                for k in 0..4 {
                    if inside(q[k]) {
                        raw.push((e[(k + 3) % 4], e[k], corner_pos(q[k])));
                    }
                }
            }
            _ => unreachable!("a face has an even number of cut edges"),
        }
        let mut normal = [0.0; 3];
        normal[axis] = if side == 1 { 1.0 } else { -1.0 };
        for (a, b, r) in raw {
            let (pa, pb) = (edge_mid(a), edge_mid(b));
            let u = [0, 1, 2].map(|k| pb[k] - pa[k]);
            let w = [0, 1, 2].map(|k| r[k] - pa[k]);
            let cross = [
                u[1] * w[2] - u[2] * w[1],
                u[2] * w[0] - u[0] * w[2],
                u[0] * w[1] - u[1] * w[0],
            ];
            let dot: f64 = (0..3).map(|k| cross[k] * normal[k]).sum();
            segs.push(if dot > 0.0 { (a, b) } else { (b, a) });
        }
    }
    segs
}

/// Closed cycles of cut edges of one case, each in segment direction.
pub fn cycles(case: u8) -> Vec<Vec<usize>> {
    let mut next = [usize::MAX; 12];
    for (a, b) in face_segments(case) {
        assert_eq!(next[a], usize::MAX, "edge {a} starts two segments");
        next[a] = b;
    }
    let mut seen = [false; 12];
    let mut out = Vec::new();
    for start in 0..12 {
        if next[start] == usize::MAX || seen[start] {
            continue;
        }
        let mut cyc = Vec::new();
        let mut e = start;
        while !seen[e] {
            seen[e] = true;
            cyc.push(e);
            e = next[e];
        }
        assert_eq!(e, start, "segments of case {case} do not close");
        out.push(cyc);
    }
    out
}

/// Triangles (as edge triples, outward winding) of one case.
pub fn triangulate(case: u8) -> Vec<[u8; 3]> {
    let ef = edge_faces();
    let mut tris = Vec::new();
    for cyc in cycles(case) {
        let n = cyc.len();
        // Apex whose diagonals never join two edges of one cube face.
        let apex = (0..n)
            .find(|&s| (2..n - 1).all(|m| ef[cyc[s]] & ef[cyc[(s + m) % n]] == 0))
            .unwrap_or_else(|| panic!("case {case}: no fan apex without face diagonals"));
        for m in 1..n - 1 {
            let (a, b, c) = (cyc[apex], cyc[(apex + m) % n], cyc[(apex + m + 1) % n]);
            // Cycles run clockwise around the outward normal (inside on the
            // left of each face segment seen from outside the cube), so
            // reverse them for counter-clockwise outward triangles.
            tris.push([a as u8, c as u8, b as u8]);
        }
    }
    tris
}

/// The table in the flat form the hot loop reads.
pub struct CaseTable {
    /// Triangles of case `c` are `tris[start[c]..start[c + 1]]`.
    pub start: [u16; 257],
    pub tris: Vec<[u8; 3]>,
}

impl CaseTable {
    #[inline]
    pub fn triangles(&self, case: u8) -> &[[u8; 3]] {
        &self.tris[self.start[case as usize] as usize..self.start[case as usize + 1] as usize]
    }

    #[inline]
    pub fn count(&self, case: u8) -> u32 {
        (self.start[case as usize + 1] - self.start[case as usize]) as u32
    }
}

pub fn table() -> &'static CaseTable {
    static T: OnceLock<CaseTable> = OnceLock::new();
    T.get_or_init(|| {
        let mut start = [0u16; 257];
        let mut tris = Vec::new();
        for c in 0..256usize {
            tris.extend(triangulate(c as u8));
            start[c + 1] = tris.len() as u16;
        }
        CaseTable { start, tris }
    })
}
