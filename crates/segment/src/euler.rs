//! Euler characteristic of a voxel set: the union of its closed unit cubes,
//! V − E + F − C over the vertices, edges, faces and cubes it holds. A ball
//! has 1; each tunnel (handle) takes one away, each enclosed cavity adds
//! one, and the boundary surface has twice the value (2 for a sphere).

/// χ of the voxels set in `mask` (Fortran order, `dims`).
pub fn euler_characteristic(mask: &[bool], dims: [usize; 3]) -> i64 {
    let [ni, nj, nk] = dims;
    let at = |i: i64, j: i64, k: i64| -> bool {
        i >= 0
            && j >= 0
            && k >= 0
            && (i as usize) < ni
            && (j as usize) < nj
            && (k as usize) < nk
            && mask[i as usize + ni * (j as usize + nj * k as usize)]
    };
    let (mut v, mut e, mut f, mut c) = (0i64, 0i64, 0i64, 0i64);
    // Lattice point (i, j, k) is the corner shared by voxels (i−1..i, …);
    // each cell of the dual lattice is counted once, when any voxel around
    // it is set.
    for k in 0..=nk as i64 {
        for j in 0..=nj as i64 {
            for i in 0..=ni as i64 {
                let any = |di: &[i64], dj: &[i64], dk: &[i64]| {
                    di.iter().any(|&a| {
                        dj.iter()
                            .any(|&b| dk.iter().any(|&d| at(i + a, j + b, k + d)))
                    })
                };
                v += any(&[-1, 0], &[-1, 0], &[-1, 0]) as i64;
                // Edges from this point along +i, +j, +k.
                e += any(&[0], &[-1, 0], &[-1, 0]) as i64;
                e += any(&[-1, 0], &[0], &[-1, 0]) as i64;
                e += any(&[-1, 0], &[-1, 0], &[0]) as i64;
                // Faces spanned from this point: normal i, j, k.
                f += any(&[-1, 0], &[0], &[0]) as i64;
                f += any(&[0], &[-1, 0], &[0]) as i64;
                f += any(&[0], &[0], &[-1, 0]) as i64;
                c += at(i, j, k) as i64;
            }
        }
    }
    v - e + f - c
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(n: usize, f: impl Fn(i64, i64, i64) -> bool) -> (Vec<bool>, [usize; 3]) {
        let mut m = vec![false; n * n * n];
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    m[i + n * (j + n * k)] = f(i as i64, j as i64, k as i64);
                }
            }
        }
        (m, [n, n, n])
    }

    #[test]
    fn ball_torus_and_hollow_ball() {
        let (ball, d) = grid(16, |i, j, k| {
            (i - 8).pow(2) + (j - 8).pow(2) + (k - 8).pow(2) <= 36
        });
        assert_eq!(euler_characteristic(&ball, d), 1);
        // A square ring: one tunnel.
        let (ring, d) = grid(12, |i, j, k| {
            (2..10).contains(&i)
                && (2..10).contains(&j)
                && (4..7).contains(&k)
                && !((4..8).contains(&i) && (4..8).contains(&j))
        });
        assert_eq!(euler_characteristic(&ring, d), 0);
        // Two rings joined: two tunnels.
        let (two, d) = grid(12, |i, j, k| {
            (1..11).contains(&i)
                && (2..10).contains(&j)
                && (4..7).contains(&k)
                && !((3..5).contains(&i) && (4..8).contains(&j))
                && !((7..9).contains(&i) && (4..8).contains(&j))
        });
        assert_eq!(euler_characteristic(&two, d), -1);
        // A hollow cube: one cavity.
        let (hollow, d) = grid(10, |i, j, k| {
            let inside = |x: i64| (2..8).contains(&x);
            let core = |x: i64| (4..6).contains(&x);
            inside(i) && inside(j) && inside(k) && !(core(i) && core(j) && core(k))
        });
        assert_eq!(euler_characteristic(&hollow, d), 2);
        assert_eq!(euler_characteristic(&vec![false; 27], [3, 3, 3]), 0);
    }
}
