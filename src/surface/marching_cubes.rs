//! Marching cubes in flying-edges passes over x-rows.
//!
//! The volume is seen through a one-node frame of "outside" around the
//! bounding box of its inside samples (the padding that closes surfaces
//! touching the grid border). Over that box:
//! 1. bounding box of the samples above iso (one read of the volume);
//! 2. per node row: inside bits and the first/last inside node (trimming);
//! 3. per row: cut x/y/z edges of each node and vertex count; cases of the
//!    cell row and triangle count;
//! 4. prefix sums give every row its exact slice of the output arrays;
//! 5. per row: vertices in node order (x, y, z edge), then triangles, whose
//!    vertex ids follow from running counts along the four node rows of the
//!    cell row. No hash map, no welding: an edge's vertex is made once, by
//!    the row that owns the edge's lower node.
//!
//! Rows are independent, so passes 2, 3 and 5 run in parallel with rayon and
//! the output does not depend on the thread count.

use rayon::prelude::*;

use super::tables::{EDGE_CORNERS, table};
use crate::geom::{Matrix4, Point3, Volume};

/// Sample types the extractor reads.
pub trait Sample: Copy + Send + Sync {
    fn value(self) -> f64;
}

impl Sample for u8 {
    #[inline]
    fn value(self) -> f64 {
        self as f64
    }
}

impl Sample for f32 {
    #[inline]
    fn value(self) -> f64 {
        self as f64
    }
}

impl Sample for i16 {
    #[inline]
    fn value(self) -> f64 {
        self as f64
    }
}

/// The raw isosurface: world vertices, outward triangles, and for each vertex
/// whether its edge reaches into the padding (the mask was cut by the border).
#[derive(Debug, Clone, Default)]
pub struct Isosurface {
    pub vertices: Vec<Point3>,
    pub triangles: Vec<[u32; 3]>,
    pub on_border: Vec<bool>,
}

/// Node box [lo, hi] (inclusive, volume index, may reach −1 and dims) of the
/// padded bounding box of samples above `iso`; `None` when there are none.
fn padded_box<T: Sample>(vol: &Volume<T>, iso: f64) -> Option<([i64; 3], [i64; 3])> {
    let [nx, ny, _] = vol.dims();
    let slice = vol.as_slice();
    if slice.is_empty() {
        return None;
    }
    let per_slice: Vec<Option<([usize; 3], [usize; 3])>> = slice
        .par_chunks(nx * ny)
        .enumerate()
        .map(|(k, s)| {
            let mut b: Option<([usize; 3], [usize; 3])> = None;
            for (j, row) in s.chunks_exact(nx).enumerate() {
                let first = row.iter().position(|v| v.value() > iso);
                if let Some(f) = first {
                    let l = nx - 1 - row.iter().rev().position(|v| v.value() > iso).unwrap();
                    let bb = b.get_or_insert(([f, j, k], [l, j, k]));
                    bb.0[0] = bb.0[0].min(f);
                    bb.1[0] = bb.1[0].max(l);
                    bb.1[1] = j;
                }
            }
            b
        })
        .collect();
    let mut out: Option<([usize; 3], [usize; 3])> = None;
    for (lo, hi) in per_slice.into_iter().flatten() {
        let b = out.get_or_insert((lo, hi));
        for a in 0..3 {
            b.0[a] = b.0[a].min(lo[a]);
            b.1[a] = b.1[a].max(hi[a]);
        }
    }
    out.map(|(lo, hi)| {
        (
            lo.map(|v| v as i64 - 1),
            [hi[0] as i64 + 1, hi[1] as i64 + 1, hi[2] as i64 + 1],
        )
    })
}

/// Extract the `iso` surface of `vol` (inside: value > iso) in world
/// coordinates, closed at the grid border, outward-facing.
pub fn extract<T: Sample>(vol: &Volume<T>, iso: f64) -> Isosurface {
    let Some((lo, hi)) = padded_box(vol, iso) else {
        return Isosurface::default();
    };
    let dims = vol.dims();
    let n = [0, 1, 2].map(|a| (hi[a] - lo[a] + 1) as usize);
    let rows = n[1] * n[2];
    let data = vol.as_slice();
    let at = |i: i64, j: i64, k: i64| -> Option<T> {
        if i < 0
            || j < 0
            || k < 0
            || i >= dims[0] as i64
            || j >= dims[1] as i64
            || k >= dims[2] as i64
        {
            None
        } else {
            Some(data[i as usize + dims[0] * (j as usize + dims[1] * k as usize)])
        }
    };

    // Pass 2: inside bits per node and the trimmed extent [first, last+1) of each row.
    let mut ins = vec![0u8; n[0] * rows];
    let trim: Vec<(usize, usize)> = ins
        .par_chunks_mut(n[0])
        .enumerate()
        .map(|(r, row)| {
            let (j, k) = (lo[1] + (r % n[1]) as i64, lo[2] + (r / n[1]) as i64);
            let (mut first, mut last) = (usize::MAX, 0);
            if j >= 0 && k >= 0 && j < dims[1] as i64 && k < dims[2] as i64 {
                let base = dims[0] * (j as usize + dims[1] * k as usize);
                // Nodes 1..n-1 map to volume i = lo+1 .. hi-1, always in range.
                let src = &data[base + (lo[0] + 1) as usize..base + hi[0] as usize];
                for (a, v) in src.iter().enumerate() {
                    if v.value() > iso {
                        row[a + 1] = 1;
                        first = first.min(a + 1);
                        last = a + 1;
                    }
                }
            }
            if first == usize::MAX {
                (0, 0)
            } else {
                (first, last + 1)
            }
        })
        .collect();

    // Pass 3: edge bits per node (bit 0 x, 1 y, 2 z), vertex and triangle counts per row.
    let tab = table();
    let mut ebits = vec![0u8; n[0] * rows];
    let counts: Vec<(u32, u32, usize)> = ebits
        .par_chunks_mut(n[0])
        .enumerate()
        .map(|(r, eb)| {
            let (j, k) = (r % n[1], r / n[1]);
            let row = |dj: usize, dk: usize| -> Option<(&[u8], (usize, usize))> {
                (j + dj < n[1] && k + dk < n[2]).then(|| {
                    let rr = (j + dj) + n[1] * (k + dk);
                    (&ins[rr * n[0]..(rr + 1) * n[0]], trim[rr])
                })
            };
            let r00 = row(0, 0).unwrap();
            let (r10, r01, r11) = (row(1, 0), row(0, 1), row(1, 1));
            let span = |rs: &[Option<(&[u8], (usize, usize))>]| {
                let mut s = (usize::MAX, 0);
                for (_, t) in rs.iter().flatten() {
                    if t.1 > t.0 {
                        s = (s.0.min(t.0), s.1.max(t.1));
                    }
                }
                s
            };
            let mut nv = 0u32;
            let (e0, e1) = span(&[Some(r00), r10, r01]);
            let estart = e0.saturating_sub(1);
            if e0 < e1 {
                // A node's edges can be cut from one node before the first inside one.
                for a in e0.saturating_sub(1)..e1.min(n[0]) {
                    let v = r00.0[a];
                    let mut b = 0u8;
                    if a + 1 < n[0] && r00.0[a + 1] != v {
                        b |= 1;
                    }
                    if r10.is_some_and(|r| r.0[a] != v) {
                        b |= 2;
                    }
                    if r01.is_some_and(|r| r.0[a] != v) {
                        b |= 4;
                    }
                    eb[a] = b;
                    nv += b.count_ones();
                }
            }
            let mut nt = 0u32;
            if let (Some(r10), Some(r01), Some(r11)) = (r10, r01, r11) {
                let (c0, c1) = span(&[Some(r00), Some(r10), Some(r01), Some(r11)]);
                if c0 < c1 {
                    for a in c0.saturating_sub(1)..c1.min(n[0] - 1) {
                        nt += tab.count(case_at(a, r00.0, r10.0, r01.0, r11.0));
                    }
                }
            }
            (nv, nt, estart)
        })
        .collect();

    // Pass 4: prefix sums → exact output sizes and each row's offsets.
    let mut voff = Vec::with_capacity(rows + 1);
    let mut toff = Vec::with_capacity(rows + 1);
    let (mut sv, mut st) = (0usize, 0usize);
    for &(v, t, _) in &counts {
        voff.push(sv);
        toff.push(st);
        sv += v as usize;
        st += t as usize;
    }
    voff.push(sv);
    toff.push(st);
    assert!(sv <= u32::MAX as usize, "more than 2³² vertices");

    let mut vertices = vec![Point3::origin(); sv];
    let mut on_border = vec![false; sv];
    let mut triangles = vec![[0u32; 3]; st];
    let mut vslices = Vec::with_capacity(rows);
    let mut bslices = Vec::with_capacity(rows);
    let mut tslices = Vec::with_capacity(rows);
    {
        let (mut vrest, mut brest, mut trest) =
            (&mut vertices[..], &mut on_border[..], &mut triangles[..]);
        for &(v, t, _) in &counts {
            let (a, b) = vrest.split_at_mut(v as usize);
            vslices.push(a);
            vrest = b;
            let (a, b) = brest.split_at_mut(v as usize);
            bslices.push(a);
            brest = b;
            let (a, b) = trest.split_at_mut(t as usize);
            tslices.push(a);
            trest = b;
        }
    }

    let m: &Matrix4 = vol.affine();
    // A mirroring affine turns outward index-space triangles inward.
    let flip = m.fixed_view::<3, 3>(0, 0).determinant() < 0.0;
    let world = |p: [f64; 3]| {
        Point3::new(
            m[(0, 0)] * p[0] + m[(0, 1)] * p[1] + m[(0, 2)] * p[2] + m[(0, 3)],
            m[(1, 0)] * p[0] + m[(1, 1)] * p[1] + m[(1, 2)] * p[2] + m[(1, 3)],
            m[(2, 0)] * p[0] + m[(2, 1)] * p[1] + m[(2, 2)] * p[2] + m[(2, 3)],
        )
    };

    // Pass 5: emit.
    vslices
        .into_par_iter()
        .zip(bslices)
        .zip(tslices)
        .enumerate()
        .for_each(|(r, ((vs, bs), ts))| {
            let (j, k) = (r % n[1], r / n[1]);
            let eb = &ebits[r * n[0]..(r + 1) * n[0]];
            if !vs.is_empty() {
                let (vj, vk) = (lo[1] + j as i64, lo[2] + k as i64);
                let mut w = 0;
                for (a, &b) in eb.iter().enumerate() {
                    if b == 0 {
                        continue;
                    }
                    let vi = lo[0] + a as i64;
                    let f0 = at(vi, vj, vk);
                    for (axis, d) in [(0usize, [1i64, 0, 0]), (1, [0, 1, 0]), (2, [0, 0, 1])] {
                        if b >> axis & 1 == 0 {
                            continue;
                        }
                        let f1 = at(vi + d[0], vj + d[1], vk + d[2]);
                        // A padding node sits just outside: the vertex goes
                        // half-way, as if the mask continued to the border.
                        let t = match (f0, f1) {
                            (Some(x), Some(y)) => {
                                let (x, y) = (x.value(), y.value());
                                (iso - x) / (y - x)
                            }
                            _ => 0.5,
                        };
                        let mut p = [vi as f64, vj as f64, vk as f64];
                        p[axis] += t;
                        vs[w] = world(p);
                        bs[w] = f0.is_none() || f1.is_none();
                        w += 1;
                    }
                }
                debug_assert_eq!(w, vs.len());
            }
            if !ts.is_empty() {
                let rr = |dj: usize, dk: usize| (j + dj) + n[1] * (k + dk);
                let ids = [rr(0, 0), rr(1, 0), rr(0, 1), rr(1, 1)];
                let ins_row = |q: usize| &ins[ids[q] * n[0]..(ids[q] + 1) * n[0]];
                let eb_row = |q: usize| &ebits[ids[q] * n[0]..(ids[q] + 1) * n[0]];
                let (i00, i10, i01, i11) = (ins_row(0), ins_row(1), ins_row(2), ins_row(3));
                let ebs = [eb_row(0), eb_row(1), eb_row(2), eb_row(3)];
                // Trim to the cells that can have a corner inside.
                let (mut c0, mut c1) = (usize::MAX, 0);
                for &id in &ids {
                    if trim[id].1 > trim[id].0 {
                        c0 = c0.min(trim[id].0);
                        c1 = c1.max(trim[id].1);
                    }
                }
                let start = c0.saturating_sub(1);
                // Running vertex id of node a in each of the four node rows:
                // the row's first id plus the cut edges before node a.
                let mut base = [0usize; 4];
                for q in 0..4 {
                    let from = counts[ids[q]].2.min(start);
                    base[q] = voff[ids[q]]
                        + ebs[q][from..start]
                            .iter()
                            .map(|b| b.count_ones() as usize)
                            .sum::<usize>();
                }
                let mut w = 0;
                for a in start..c1.min(n[0] - 1) {
                    let case = case_at(a, i00, i10, i01, i11);
                    let tris = tab.triangles(case);
                    if !tris.is_empty() {
                        let id = |q: usize, node: usize, axis: u32| -> u32 {
                            let mut v = base[q];
                            let b = ebs[q][a];
                            if node == 1 {
                                v += b.count_ones() as usize;
                            }
                            let bb = ebs[q][a + node];
                            (v + (bb & ((1u8 << axis) - 1)).count_ones() as usize) as u32
                        };
                        let edge_id = |e: u8| -> u32 {
                            let [c0, _] = EDGE_CORNERS[e as usize];
                            let (dx, dy, dz) = (
                                (c0 & 1) as usize,
                                (c0 >> 1 & 1) as usize,
                                (c0 >> 2) as usize,
                            );
                            id(dy + 2 * dz, dx, e as u32 / 4)
                        };
                        for t in tris {
                            let v = [edge_id(t[0]), edge_id(t[1]), edge_id(t[2])];
                            ts[w] = if flip { [v[0], v[2], v[1]] } else { v };
                            w += 1;
                        }
                    }
                    for q in 0..4 {
                        base[q] += ebs[q][a].count_ones() as usize;
                    }
                }
                debug_assert_eq!(w, ts.len());
            }
        });

    Isosurface {
        vertices,
        triangles,
        on_border,
    }
}

#[inline]
fn case_at(a: usize, r00: &[u8], r10: &[u8], r01: &[u8], r11: &[u8]) -> u8 {
    r00[a]
        | r00[a + 1] << 1
        | r10[a] << 2
        | r10[a + 1] << 3
        | r01[a] << 4
        | r01[a + 1] << 5
        | r11[a] << 6
        | r11[a + 1] << 7
}
