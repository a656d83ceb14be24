//! Sampling volumes on an oblique plane in world coordinates, and the
//! contour of a binary image: the pieces of the CT check figure.

use coapt_geom::{Point3, Volume};

/// A volume prepared for many lookups: its voxels as one slice, fetched once.
pub struct Sampler<'a, T> {
    vol: &'a Volume<T>,
    data: &'a [T],
    dims: [usize; 3],
}

impl<'a, T: Copy> Sampler<'a, T> {
    pub fn new(vol: &'a Volume<T>) -> Self {
        Self {
            vol,
            data: vol.as_slice(),
            dims: vol.dims(),
        }
    }
}

impl Sampler<'_, i16> {
    /// Trilinear value at a world point, through the volume's affine; `None`
    /// outside the grid (more than half a voxel beyond the outer centres),
    /// for an empty volume, or a non-finite point.
    pub fn trilinear(&self, p: &Point3) -> Option<f64> {
        let d = self.dims;
        if d.contains(&0) {
            return None;
        }
        let idx = self.vol.world_to_index(p);
        let mut base = [0usize; 3];
        let mut frac = [0f64; 3];
        for a in 0..3 {
            let n = d[a] as f64;
            let x = idx[a];
            if !(x >= -0.5 && x <= n - 0.5) {
                return None;
            }
            let x = x.clamp(0.0, n - 1.0);
            let i0 = (x as usize).min(d[a].saturating_sub(2));
            base[a] = i0;
            frac[a] = if d[a] == 1 { 0.0 } else { x - i0 as f64 };
        }
        let s = self.data;
        let at = |i: usize, j: usize, k: usize| s[i + d[0] * (j + d[1] * k)] as f64;
        let step = |a: usize| usize::from(d[a] > 1);
        let (i, j, k) = (base[0], base[1], base[2]);
        let (di, dj, dk) = (step(0), step(1), step(2));
        let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
        let c00 = lerp(at(i, j, k), at(i + di, j, k), frac[0]);
        let c10 = lerp(at(i, j + dj, k), at(i + di, j + dj, k), frac[0]);
        let c01 = lerp(at(i, j, k + dk), at(i + di, j, k + dk), frac[0]);
        let c11 = lerp(at(i, j + dj, k + dk), at(i + di, j + dj, k + dk), frac[0]);
        Some(lerp(
            lerp(c00, c10, frac[1]),
            lerp(c01, c11, frac[1]),
            frac[2],
        ))
    }
}

impl Sampler<'_, u8> {
    /// Value of the voxel containing a world point (nearest centre); `None`
    /// outside the grid.
    pub fn nearest(&self, p: &Point3) -> Option<u8> {
        let d = self.dims;
        let idx = self.vol.world_to_index(p);
        let mut ijk = [0usize; 3];
        for a in 0..3 {
            let r = (idx[a] + 0.5).floor();
            if !(r >= 0.0 && r < d[a] as f64) {
                return None;
            }
            ijk[a] = r as usize;
        }
        Some(self.data[ijk[0] + d[0] * (ijk[1] + d[1] * ijk[2])])
    }
}

/// [`Sampler::trilinear`] for a single lookup.
pub fn trilinear(vol: &Volume<i16>, p: &Point3) -> Option<f64> {
    Sampler::new(vol).trilinear(p)
}

/// [`Sampler::nearest`] for a single lookup.
pub fn nearest(vol: &Volume<u8>, p: &Point3) -> Option<u8> {
    Sampler::new(vol).nearest(p)
}

/// Grey level of a value in a display window [lo, hi].
pub fn window(v: f64, lo: f64, hi: f64) -> u8 {
    if hi <= lo || hi.is_nan() || lo.is_nan() || v.is_nan() {
        return 0;
    }
    ((v - lo) / (hi - lo) * 255.0).round().clamp(0.0, 255.0) as u8
}

/// Iso-contour of a binary grid (row-major, `nx`×`ny`, sample (i, j) at
/// position (i, j)) as segments between edge midpoints (marching squares;
/// saddles split so that diagonal inside cells stay separate).
pub fn contour(inside: &[bool], nx: usize, ny: usize) -> Vec<[[f64; 2]; 2]> {
    let mut out = Vec::new();
    if nx < 2 || ny < 2 || inside.len() < nx * ny {
        return out;
    }
    let at = |i: usize, j: usize| inside[i + j * nx];
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            let (x, y) = (i as f64, j as f64);
            // Corners: 0 (i,j), 1 (i+1,j), 2 (i+1,j+1), 3 (i,j+1).
            let c = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
            let code = c
                .iter()
                .enumerate()
                .fold(0u8, |m, (k, &b)| m | ((b as u8) << k));
            // Edge midpoints: 0 bottom (0–1), 1 right (1–2), 2 top (2–3), 3 left (3–0).
            let mid = [
                [x + 0.5, y],
                [x + 1.0, y + 0.5],
                [x + 0.5, y + 1.0],
                [x, y + 0.5],
            ];
            let pairs: &[(usize, usize)] = match code {
                0 | 15 => &[],
                1 | 14 => &[(3, 0)],
                2 | 13 => &[(0, 1)],
                3 | 12 => &[(3, 1)],
                4 | 11 => &[(1, 2)],
                6 | 9 => &[(0, 2)],
                7 | 8 => &[(2, 3)],
                5 => &[(3, 0), (1, 2)],
                10 => &[(0, 1), (2, 3)],
                _ => &[],
            };
            for &(a, b) in pairs {
                out.push([mid[a], mid[b]]);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use coapt_geom::{Matrix3, Vector3, volume::affine_from_parts};

    fn ramp() -> Volume<i16> {
        // Value = 10·i + 100·j + 1000·k on an oblique, anisotropic grid.
        let rot = nalgebra::Rotation3::from_axis_angle(
            &nalgebra::Unit::new_normalize(Vector3::new(1.0, 2.0, 3.0)),
            0.4,
        );
        let aff = affine_from_parts(
            [0.5, 0.7, 1.2],
            &Matrix3::from(rot),
            Point3::new(-3.0, 4.0, 10.0),
        );
        let dims = [6, 5, 4];
        let mut vals = Vec::new();
        for k in 0..4 {
            for j in 0..5 {
                for i in 0..6 {
                    vals.push((10 * i + 100 * j + 1000 * k) as i16);
                }
            }
        }
        Volume::from_fortran_vec(dims, aff, vals).unwrap()
    }

    #[test]
    fn trilinear_reproduces_a_linear_field_through_the_affine() {
        let v = ramp();
        for ijk in [
            [0.0, 0.0, 0.0],
            [2.3, 1.7, 0.4],
            [5.0, 4.0, 3.0],
            [4.9, 0.1, 2.5],
        ] {
            let p = v.index_to_world(ijk);
            let want = 10.0 * ijk[0] + 100.0 * ijk[1] + 1000.0 * ijk[2];
            let got = trilinear(&v, &p).unwrap();
            assert!((got - want).abs() < 1e-6, "{ijk:?}: {got} vs {want}");
        }
        // Half a voxel out is clamped to the edge value; beyond is outside.
        let edge = trilinear(&v, &v.index_to_world([-0.4, 0.0, 0.0])).unwrap();
        assert!(edge.abs() < 1e-9);
        assert_eq!(trilinear(&v, &v.index_to_world([-0.6, 0.0, 0.0])), None);
        assert_eq!(trilinear(&v, &Point3::new(f64::NAN, 0.0, 0.0)), None);
    }

    #[test]
    fn nearest_rounds_to_the_voxel_centre() {
        let aff = affine_from_parts(
            [2.0, 2.0, 2.0],
            &Matrix3::identity(),
            Point3::new(10.0, 0.0, 0.0),
        );
        let mut vals = vec![0u8; 27];
        vals[1 + 3 * (1 + 3)] = 7;
        let m = Volume::from_fortran_vec([3, 3, 3], aff, vals).unwrap();
        assert_eq!(nearest(&m, &Point3::new(12.9, 2.5, 1.1)), Some(7));
        assert_eq!(nearest(&m, &Point3::new(13.1, 2.5, 1.1)), Some(0));
        assert_eq!(nearest(&m, &Point3::new(8.0, 0.0, 0.0)), None);
        // A one-voxel-thick volume samples in its plane.
        let thin = Volume::from_fortran_vec([2, 2, 1], aff, vec![0i16, 100, 200, 300]).unwrap();
        assert_eq!(
            trilinear(&thin, &thin.index_to_world([0.5, 0.5, 0.0])),
            Some(150.0)
        );
    }

    #[test]
    fn window_maps_ends_and_clamps() {
        assert_eq!(window(-200.0, -200.0, 600.0), 0);
        assert_eq!(window(600.0, -200.0, 600.0), 255);
        assert_eq!(window(200.0, -200.0, 600.0), 128);
        assert_eq!(window(5000.0, -200.0, 600.0), 255);
        assert_eq!(window(f64::NAN, -200.0, 600.0), 0);
    }

    #[test]
    fn contour_of_a_square_is_a_closed_loop_around_it() {
        // A 3×3 block of inside samples in a 7×7 grid.
        let n = 7;
        let inside: Vec<bool> = (0..n * n)
            .map(|k| (2..5).contains(&(k % n)) && (2..5).contains(&(k / n)))
            .collect();
        let segs = contour(&inside, n, n);
        // The ring of 12 mixed cells around the block: 2 per side and 4 corners.
        assert_eq!(segs.len(), 12);
        for s in &segs {
            for p in s {
                assert!(
                    p[0] >= 1.5 && p[0] <= 4.5 && p[1] >= 1.5 && p[1] <= 4.5,
                    "{p:?}"
                );
            }
        }
        // Every endpoint is shared by exactly two segments: a closed loop.
        let mut ends: Vec<[i64; 2]> = segs
            .iter()
            .flatten()
            .map(|p| [(p[0] * 2.0) as i64, (p[1] * 2.0) as i64])
            .collect();
        ends.sort();
        assert!(ends.chunks(2).all(|c| c.len() == 2 && c[0] == c[1]));
        assert!(contour(&inside, 1, 49).is_empty());
    }
}
