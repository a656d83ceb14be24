//! Exact Euclidean distance transform in millimetres (Felzenszwalb &
//! Huttenlocher's lower envelope of parabolas, one axis at a time), with
//! anisotropic spacing. Voxels outside the grid are not features: a set that
//! touches the grid border is treated as continuing beyond it, which is what
//! a cropped region of interest needs (the aorta leaves through the top).

use rayon::prelude::*;

/// Squared distance (mm²) from every voxel to the nearest voxel where
/// `feature` is true; `f32::INFINITY` when there is none.
pub fn distance_sq_to(feature: &[bool], dims: [usize; 3], spacing: [f64; 3]) -> Vec<f32> {
    let [ni, nj, nk] = dims;
    assert_eq!(feature.len(), ni * nj * nk);
    let mut d: Vec<f32> = feature
        .iter()
        .map(|&f| if f { 0.0 } else { f32::INFINITY })
        .collect();
    let plane = ni * nj;
    // Axes 0 and 1 stay inside one k-slice: parallel over slices.
    d.par_chunks_mut(plane).for_each(|slice| {
        let mut s = Scratch::new(ni.max(nj));
        let mut line = vec![0f32; ni.max(nj)];
        for j in 0..nj {
            binary_transform(&mut slice[j * ni..(j + 1) * ni], spacing[0]);
        }
        for i in 0..ni {
            for j in 0..nj {
                line[j] = slice[i + j * ni];
            }
            let mut out = vec![0f32; nj];
            s.transform(&line[..nj], spacing[1], &mut out);
            for j in 0..nj {
                slice[i + j * ni] = out[j];
            }
        }
    });
    // Axis 2: parallel over j rows; each worker returns its columns, then
    // they are scattered back in a fixed order.
    let cols: Vec<Vec<f32>> = (0..nj)
        .into_par_iter()
        .map(|j| {
            let mut s = Scratch::new(nk);
            let mut line = vec![0f32; nk];
            let mut out = vec![0f32; ni * nk];
            for i in 0..ni {
                for k in 0..nk {
                    line[k] = d[i + j * ni + k * plane];
                }
                s.transform(&line, spacing[2], &mut out[i * nk..(i + 1) * nk]);
            }
            out
        })
        .collect();
    for (j, out) in cols.iter().enumerate() {
        for i in 0..ni {
            for k in 0..nk {
                d[i + j * ni + k * plane] = out[i * nk + k];
            }
        }
    }
    d
}

/// Distance (mm) from each voxel of `inside` to the nearest voxel outside it
/// (0 outside).
pub fn inside_distance(inside: &[bool], dims: [usize; 3], spacing: [f64; 3]) -> Vec<f32> {
    let bg: Vec<bool> = inside.iter().map(|&v| !v).collect();
    distance_sq_to(&bg, dims, spacing)
        .into_iter()
        .map(|v| if v.is_finite() { v.sqrt() } else { f32::MAX })
        .collect()
}

/// The first axis, where every value is 0 (feature) or ∞: in place, the
/// lower envelope of the feature parabolas without building it. Between
/// consecutive features L < R the envelope switches from L to R at the
/// intersection s the general transform computes (same f64 expression),
/// and a sample takes R only where s < x, as there; so the values are the
/// general transform's, bit for bit, in one pass with a division per gap
/// instead of per feature.
fn binary_transform(row: &mut [f32], h: f64) {
    let n = row.len();
    let Some(first) = row.iter().position(|&x| x == 0.0) else {
        return; // no feature: ∞ stays
    };
    let sq = |q: usize, r: usize| {
        let dx = q as f64 * h - r as f64 * h;
        (dx * dx) as f32
    };
    for (q, x) in row[..first].iter_mut().enumerate() {
        *x = sq(q, first);
    }
    let mut l = first;
    while l < n {
        // The next feature after l, if any.
        let Some(r) = row[l + 1..]
            .iter()
            .position(|&x| x == 0.0)
            .map(|o| l + 1 + o)
        else {
            for (q, x) in row.iter_mut().enumerate().skip(l + 1) {
                *x = sq(q, l);
            }
            return;
        };
        if r > l + 1 {
            let (pl, pr) = (l as f64 * h, r as f64 * h);
            let s = (pr * pr - pl * pl) / (2.0 * (pr - pl));
            for (q, v) in row.iter_mut().enumerate().take(r).skip(l + 1) {
                let x = q as f64 * h;
                *v = if s < x { sq(q, r) } else { sq(q, l) };
            }
        }
        l = r;
    }
}

struct Scratch {
    v: Vec<usize>,
    z: Vec<f64>,
}

impl Scratch {
    fn new(n: usize) -> Self {
        Scratch {
            v: vec![0; n],
            z: vec![0.0; n + 1],
        }
    }

    /// 1-D squared-distance transform of sampled function `f` (spacing `h`).
    fn transform(&mut self, f: &[f32], h: f64, out: &mut [f32]) {
        let n = f.len();
        // All zero (inside a feature run): every sample is its own nearest
        // point, which the envelope below gives as exactly 0 too.
        if f.iter().all(|&x| x == 0.0) {
            out.fill(0.0);
            return;
        }
        let (v, z) = (&mut self.v, &mut self.z);
        let mut k: isize = -1;
        for q in 0..n {
            let fq = f[q] as f64;
            if !fq.is_finite() {
                continue;
            }
            let pq = q as f64 * h;
            loop {
                if k < 0 {
                    k = 0;
                    v[0] = q;
                    z[0] = f64::NEG_INFINITY;
                    z[1] = f64::INFINITY;
                    break;
                }
                let r = v[k as usize];
                let pr = r as f64 * h;
                let s = ((fq + pq * pq) - (f[r] as f64 + pr * pr)) / (2.0 * (pq - pr));
                if s <= z[k as usize] {
                    k -= 1;
                    continue;
                }
                k += 1;
                v[k as usize] = q;
                z[k as usize] = s;
                z[k as usize + 1] = f64::INFINITY;
                break;
            }
        }
        if k < 0 {
            out.iter_mut().for_each(|o| *o = f32::INFINITY);
            return;
        }
        let mut m = 0usize;
        for (q, o) in out.iter_mut().enumerate() {
            let x = q as f64 * h;
            while z[m + 1] < x {
                m += 1;
            }
            let r = v[m];
            let dx = x - r as f64 * h;
            *o = (dx * dx + f[r] as f64) as f32;
        }
    }
}
