//! Completing a unit vector to a right-handed orthonormal frame, for the
//! searches that sweep directions or rays about an axis or a normal.

use super::Vector3;

/// Unit vectors (u, v) with (u, v, n) right-handed and orthonormal, for a
/// unit `n` (not normalised here: callers hold unit vectors already).
///
/// u is n × x, or n × y when n lies within about 26° of x, where n × x
/// would be short and lose digits. The arithmetic is the one every caller
/// had in its own copy; the directions they sweep, and so their outputs,
/// depend on it to the last bit.
pub fn orthonormal_pair(n: &Vector3) -> (Vector3, Vector3) {
    let helper = if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let u = n.cross(&helper).normalize();
    (u, n.cross(&u))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn completes_a_right_handed_frame() {
        for n in [
            Vector3::x(),
            -Vector3::x(),
            Vector3::y(),
            Vector3::z(),
            Vector3::new(0.95, 0.1, -0.2).normalize(),
            Vector3::new(-0.3, 0.4, 0.8).normalize(),
        ] {
            let (u, v) = orthonormal_pair(&n);
            assert!((u.norm() - 1.0).abs() < 1e-15 && (v.norm() - 1.0).abs() < 1e-15);
            assert!(u.dot(&n).abs() < 1e-15 && v.dot(&n).abs() < 1e-15 && u.dot(&v).abs() < 1e-15);
            assert!((u.cross(&v) - n).norm() < 1e-15, "{n:?}");
        }
    }
}
