//! Binary morphology on a grid: flood fill, opening with a ball in mm (by
//! distance transforms, so the element is a true ball on anisotropic grids),
//! hole filling. All 6-connected, the connectivity of the IDT lattice.

use super::edt::{distance_sq_to, inside_distance};

/// The 6 face neighbours of linear index `v`, skipping the grid border.
#[inline]
pub fn neighbours6(v: usize, dims: [usize; 3], mut f: impl FnMut(usize)) {
    let [ni, nj, nk] = dims;
    let plane = ni * nj;
    let i = v % ni;
    let j = (v / ni) % nj;
    let k = v / plane;
    if i > 0 {
        f(v - 1);
    }
    if i + 1 < ni {
        f(v + 1);
    }
    if j > 0 {
        f(v - ni);
    }
    if j + 1 < nj {
        f(v + ni);
    }
    if k > 0 {
        f(v - plane);
    }
    if k + 1 < nk {
        f(v + plane);
    }
}

/// Voxels 6-connected to `seed` through voxels where `inside` holds.
pub fn flood_fill(inside: &[bool], dims: [usize; 3], seed: usize) -> Vec<bool> {
    let mut out = vec![false; inside.len()];
    if !inside[seed] {
        return out;
    }
    let mut stack = vec![seed];
    out[seed] = true;
    while let Some(v) = stack.pop() {
        neighbours6(v, dims, |u| {
            if inside[u] && !out[u] {
                out[u] = true;
                stack.push(u);
            }
        });
    }
    out
}

/// Opening with a ball of radius `r_mm`: erosion (inside distance > r) then
/// dilation (distance to the eroded set ≤ r). Removes every part thinner
/// than the ball (coronaries, small branches, noise spurs).
pub fn open_ball(inside: &[bool], dims: [usize; 3], spacing: [f64; 3], r_mm: f64) -> Vec<bool> {
    let dt = inside_distance(inside, dims, spacing);
    let r = r_mm as f32;
    let eroded: Vec<bool> = dt.iter().map(|&d| d > r).collect();
    let d2 = distance_sq_to(&eroded, dims, spacing);
    let r2 = r * r;
    d2.iter().zip(inside).map(|(&d, &m)| m && d <= r2).collect()
}

/// Closing with a ball of radius `r_mm`: dilation (distance to the set ≤ r)
/// then erosion (inside distance of the dilated set > r). Fills every gap
/// narrower than the ball (thin dark sheets inside a bright lumen); voxels
/// within r of the grid border see the border as background.
pub fn close_ball(inside: &[bool], dims: [usize; 3], spacing: [f64; 3], r_mm: f64) -> Vec<bool> {
    let r = r_mm as f32;
    let d2 = distance_sq_to(inside, dims, spacing);
    let dilated: Vec<bool> = d2.iter().map(|&d| d <= r * r).collect();
    drop(d2);
    let dt = inside_distance(&dilated, dims, spacing);
    dt.iter().zip(inside).map(|(&d, &m)| m || d > r).collect()
}

/// Fill every background component that does not touch the grid border.
pub fn fill_holes(inside: &[bool], dims: [usize; 3]) -> Vec<bool> {
    let [ni, nj, nk] = dims;
    let mut outside = vec![false; inside.len()];
    let mut stack = Vec::new();
    for k in 0..nk {
        for j in 0..nj {
            for i in 0..ni {
                let border =
                    i == 0 || j == 0 || k == 0 || i + 1 == ni || j + 1 == nj || k + 1 == nk;
                let v = i + ni * (j + nj * k);
                if border && !inside[v] && !outside[v] {
                    outside[v] = true;
                    stack.push(v);
                }
            }
        }
    }
    while let Some(v) = stack.pop() {
        neighbours6(v, dims, |u| {
            if !inside[u] && !outside[u] {
                outside[u] = true;
                stack.push(u);
            }
        });
    }
    outside.iter().map(|&o| !o).collect()
}

/// A sub-box `lo..hi` of a grid.
#[derive(Debug, Clone, Copy)]
pub struct SubBox {
    pub lo: [usize; 3],
    pub hi: [usize; 3],
}

impl SubBox {
    /// Bounding box of `mask`, grown by `pad` voxels per axis (clamped).
    pub fn around(mask: &[bool], dims: [usize; 3], pad: [usize; 3]) -> SubBox {
        let mut lo = dims;
        let mut hi = [0; 3];
        for (v, _) in mask.iter().enumerate().filter(|(_, m)| **m) {
            let q = [
                v % dims[0],
                (v / dims[0]) % dims[1],
                v / (dims[0] * dims[1]),
            ];
            for a in 0..3 {
                lo[a] = lo[a].min(q[a]);
                hi[a] = hi[a].max(q[a] + 1);
            }
        }
        for a in 0..3 {
            lo[a] = lo[a].min(hi[a]).saturating_sub(pad[a]);
            hi[a] = (hi[a] + pad[a]).min(dims[a]).max(lo[a] + 1);
        }
        SubBox { lo, hi }
    }

    pub fn dims(&self) -> [usize; 3] {
        [0, 1, 2].map(|a| self.hi[a] - self.lo[a])
    }

    /// Grid index of sub-box index `v`.
    pub fn to_outer(&self, v: usize, outer: [usize; 3]) -> usize {
        let d = self.dims();
        let (i, j, k) = (v % d[0], (v / d[0]) % d[1], v / (d[0] * d[1]));
        (i + self.lo[0]) + outer[0] * ((j + self.lo[1]) + outer[1] * (k + self.lo[2]))
    }

    /// Sub-box index of grid index `v`, if inside.
    pub fn to_inner(&self, v: usize, outer: [usize; 3]) -> Option<usize> {
        let q = [
            v % outer[0],
            (v / outer[0]) % outer[1],
            v / (outer[0] * outer[1]),
        ];
        let d = self.dims();
        (0..3)
            .all(|a| q[a] >= self.lo[a] && q[a] < self.hi[a])
            .then(|| {
                (q[0] - self.lo[0]) + d[0] * ((q[1] - self.lo[1]) + d[1] * (q[2] - self.lo[2]))
            })
    }

    /// Grid index of the first voxel of each sub-box row, in sub-box order.
    fn rows(&self, outer: [usize; 3]) -> impl Iterator<Item = usize> + '_ {
        (self.lo[2]..self.hi[2]).flat_map(move |k| {
            (self.lo[1]..self.hi[1]).map(move |j| self.lo[0] + outer[0] * (j + outer[1] * k))
        })
    }

    /// The sub-box's values of `data` (a grid of `outer` dims), row by row.
    pub fn extract<T: Copy>(&self, data: &[T], outer: [usize; 3]) -> Vec<T> {
        let w = self.hi[0] - self.lo[0];
        let mut out = Vec::with_capacity(self.dims().iter().product::<usize>());
        for o in self.rows(outer) {
            out.extend_from_slice(&data[o..o + w]);
        }
        out
    }

    /// Write sub-box values `local` back into `data` (a grid of `outer` dims).
    pub fn scatter<T: Copy>(&self, local: &[T], data: &mut [T], outer: [usize; 3]) {
        let w = self.hi[0] - self.lo[0];
        for (o, src) in self.rows(outer).zip(local.chunks_exact(w)) {
            data[o..o + w].copy_from_slice(src);
        }
    }
}
