//! Which nadir belongs to which leaflet, by geometry rather than by label.
//!
//! Leaflet k is sutured between commissures C_k and C_k+1, so its nadir is
//! the one that lies between them around the valve. A user's file (or a
//! Slicer session) may number the nadirs in another order than the
//! commissures; the labels are only names. Angles are taken about the
//! normal of the commissures' plane through their centroid, turning the
//! way C1 → C2 → C3 turns, so neither the scan's orientation nor the
//! root's tilt matters.

use super::{Point3, Vector3};

/// For each leaflet k (between C_k and C_k+1), the index of its nadir in
/// `n`. Refused, naming the sectors, when the nadirs do not lie one in
/// each sector.
pub fn nadir_sectors(c: &[Point3; 3], n: &[Point3; 3]) -> Result<[usize; 3], String> {
    let g = Point3::from((c[0].coords + c[1].coords + c[2].coords) / 3.0);
    let normal = (c[1] - c[0]).cross(&(c[2] - c[0]));
    let normal = normal
        .try_normalize(1e-12)
        .ok_or("the three commissures are collinear")?;
    let e1 = (c[0] - g) - normal * (c[0] - g).dot(&normal);
    let e1 = e1
        .try_normalize(1e-12)
        .ok_or("C1 lies on the valve's centre")?;
    let e2 = normal.cross(&e1);
    // Angle in [0, 2π) from C1, turning C1 → C2 → C3.
    let angle = |p: &Point3| {
        let d: Vector3 = p - g;
        let a = d.dot(&e2).atan2(d.dot(&e1));
        a.rem_euclid(std::f64::consts::TAU)
    };
    let ca = [0.0, angle(&c[1]), angle(&c[2])];
    let sector = |p: &Point3| {
        let a = angle(p);
        if a < ca[1] {
            0
        } else if a < ca[2] {
            1
        } else {
            2
        }
    };
    let mut of = [usize::MAX; 3];
    for (i, p) in n.iter().enumerate() {
        let k = sector(p);
        if of[k] != usize::MAX {
            return Err(format!(
                "N{} and N{} both lie between C{} and C{}: each pair of neighbouring commissures needs one nadir between them",
                of[k] + 1,
                i + 1,
                k + 1,
                (k + 1) % 3 + 1
            ));
        }
        of[k] = i;
    }
    Ok(of)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ring;

    #[test]
    fn nadirs_go_to_the_sector_they_lie_in_whatever_their_labels() {
        let c = [
            ring(13.0, 0.0, 18.0),
            ring(13.0, 120.0, 18.0),
            ring(13.0, 240.0, 18.0),
        ];
        let n = |degs: [f64; 3]| degs.map(|d| ring(12.0, d, 2.0));
        assert_eq!(nadir_sectors(&c, &n([60.0, 180.0, 300.0])), Ok([0, 1, 2]));
        // A file whose N1 lies between C3 and C1, N2 between C1 and C2, …
        assert_eq!(nadir_sectors(&c, &n([300.0, 60.0, 180.0])), Ok([1, 2, 0]));
        // The commissures numbered the other way round the valve.
        let cr = [c[0], c[2], c[1]];
        assert_eq!(nadir_sectors(&cr, &n([300.0, 180.0, 60.0])), Ok([0, 1, 2]));
        // A tilted, shifted root: the same answer.
        let rot = nalgebra::Rotation3::from_euler_angles(0.4, -0.3, 1.1);
        let t = Vector3::new(-40.0, 12.0, 300.0);
        let m = |p: Point3| rot * p + t;
        let ct = c.map(m);
        assert_eq!(
            nadir_sectors(&ct, &n([300.0, 60.0, 180.0]).map(m)),
            Ok([1, 2, 0])
        );
        let e = nadir_sectors(&c, &n([50.0, 70.0, 180.0])).unwrap_err();
        assert!(e.starts_with("N1 and N2 both lie between C1 and C2"), "{e}");
        assert!(nadir_sectors(&[c[0], c[0], c[1]], &n([60.0, 180.0, 300.0])).is_err());
    }
}
