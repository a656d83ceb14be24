//! The ideal cylindrical root: a built-in wall for benchmarks and tests.
//! Axis +z through the origin, commissure k at angle 2πk/3 and height 0.

use std::f64::consts::PI;

use coapt_geom::{DataArray, DataValues, Point3, TriMesh};

/// Closed cylinder of radius `r` from z0 to z1: `n` facets around, rows
/// every ≈ `dz`; caps are fans (`region` 0 wall, 1 bottom cap, 2 top cap).
pub fn mesh(r: f64, z0: f64, z1: f64, n: usize, dz: f64) -> TriMesh {
    let rows = ((z1 - z0) / dz).ceil().max(1.0) as usize;
    let mut v = Vec::new();
    for j in 0..=rows {
        let z = z0 + (z1 - z0) * j as f64 / rows as f64;
        for i in 0..n {
            let a = 2.0 * PI * i as f64 / n as f64;
            v.push(Point3::new(r * a.cos(), r * a.sin(), z));
        }
    }
    let mut t = Vec::new();
    let mut region = Vec::new();
    let id = |j: usize, i: usize| (j * n + i % n) as u32;
    for j in 0..rows {
        for i in 0..n {
            // Outward normals (counter-clockwise seen from outside).
            t.push([id(j, i), id(j, i + 1), id(j + 1, i + 1)]);
            t.push([id(j, i), id(j + 1, i + 1), id(j + 1, i)]);
            region.extend([0, 0]);
        }
    }
    let bottom = v.len() as u32;
    v.push(Point3::new(0.0, 0.0, z0));
    let top = v.len() as u32;
    v.push(Point3::new(0.0, 0.0, z1));
    for i in 0..n {
        t.push([bottom, id(0, i + 1), id(0, i)]);
        region.push(1);
        t.push([top, id(rows, i), id(rows, i + 1)]);
        region.push(2);
    }
    let mut m = TriMesh::new(v, t);
    m.cell_data
        .insert(DataArray::new("region", 1, DataValues::I32(region)));
    m
}

/// Commissures at height 0 and nadirs midway between them at −(hc + hb).
pub fn landmarks(r: f64, hc: f64, hb: f64) -> ([Point3; 3], [Point3; 3]) {
    let at = |a: f64, z: f64| Point3::new(r * a.cos(), r * a.sin(), z);
    let c = [0, 1, 2].map(|k| at(2.0 * PI * k as f64 / 3.0, 0.0));
    let n = [0, 1, 2].map(|k| at(2.0 * PI * (k as f64 + 0.5) / 3.0, -(hc + hb)));
    (c, n)
}
