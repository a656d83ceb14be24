//! The annulus (VAJ) plane the detector starts from: the one `segment`
//! found and recorded in `segment.json` (`vaj.plane`), or else the lowest
//! flat cut cap of the wall surface (cell data `region` 1), which is where
//! a mask cut at the VAJ ends.

use std::path::Path;

use super::detect::AnnulusPlane;
use coapt_base::{Error, Result};
use coapt_geom::{Point3, TriMesh, Vector3};

/// `vaj.plane` of a `segment.json`; `Ok(None)` when the report has none
/// (a segmentation that stopped at the end of its region).
pub fn from_segment_report(path: &Path) -> Result<Option<AnnulusPlane>> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::read(path, e))?;
    let j: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| Error::bad_input(path, format!("not JSON: {e}")))?;
    let plane = &j["vaj"]["plane"];
    if plane.is_null() {
        return Ok(None);
    }
    let vec3 = |key: &str| -> Result<[f64; 3]> {
        let a = plane[key]
            .as_array()
            .filter(|a| a.len() == 3)
            .ok_or_else(|| {
                Error::bad_input(path, format!("vaj.plane.{key} is not three numbers"))
            })?;
        let mut out = [0.0; 3];
        for (o, x) in out.iter_mut().zip(a) {
            *o = x.as_f64().filter(|v| v.is_finite()).ok_or_else(|| {
                Error::bad_input(path, format!("vaj.plane.{key} holds a non-number"))
            })?;
        }
        Ok(out)
    };
    let p = vec3("point_mm")?;
    let n = Vector3::from(vec3("normal")?);
    let normal = n
        .try_normalize(1e-12)
        .ok_or_else(|| Error::bad_input(path, "vaj.plane.normal is zero"))?;
    Ok(Some(AnnulusPlane {
        point_mm: Point3::from(p),
        normal,
    }))
}

/// The lowest (least z, LPS: toward the feet) connected group of cut-cap
/// triangles: its area-weighted centroid and inward normal.
pub fn from_surface_caps(mesh: &TriMesh) -> Option<AnnulusPlane> {
    let region = mesh
        .cell_data
        .get("region")
        .and_then(|a| a.values.to_f64())
        .filter(|r| r.len() == mesh.triangles.len())?;
    let caps: Vec<usize> = (0..mesh.triangles.len())
        .filter(|&t| region[t] == 1.0)
        .collect();
    if caps.is_empty() {
        return None;
    }
    // Union–find over cap triangles sharing a vertex.
    let mut parent: Vec<usize> = (0..caps.len()).collect();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    let mut owner = std::collections::BTreeMap::new();
    for (ci, &t) in caps.iter().enumerate() {
        for &v in &mesh.triangles[t] {
            match owner.get(&v) {
                Some(&cj) => {
                    let (a, b) = (find(&mut parent, ci), find(&mut parent, cj));
                    if a != b {
                        parent[a.max(b)] = a.min(b);
                    }
                }
                None => {
                    owner.insert(v, ci);
                }
            }
        }
    }
    let mut groups: std::collections::BTreeMap<usize, (Vector3, Vector3, f64)> =
        std::collections::BTreeMap::new();
    for (ci, &t) in caps.iter().enumerate() {
        let g = find(&mut parent, ci);
        let [a, b, c] = mesh.corners(t);
        let av = mesh.area_vector(t);
        let area = av.norm();
        let e = groups
            .entry(g)
            .or_insert((Vector3::zeros(), Vector3::zeros(), 0.0));
        e.0 += (a.coords + b.coords + c.coords) / 3.0 * area;
        e.1 += av;
        e.2 += area;
    }
    groups
        .values()
        .filter(|(_, _, a)| *a > 0.0)
        .map(|(s, nv, a)| (Point3::from(s / *a), -nv))
        .filter_map(|(p, n)| n.try_normalize(1e-12).map(|n| (p, n)))
        .min_by(|x, y| x.0.z.total_cmp(&y.0.z))
        .map(|(p, n)| AnnulusPlane {
            point_mm: p,
            normal: n,
        })
}
