//! The leaflet mesh artifact (`leaflets.vtp` from `coapt leaflets`,
//! `closed.vtp` from `coapt close`): one reading of its arrays for every
//! stage, so a file is accepted or refused alike by close and report
//! (and so by design, which runs them; close once took `boundary` 7 and
//! `leaflet` 0 that the report refused).

use coapt_geom::TriMesh;

/// The arrays of a leaflet mesh, checked.
#[derive(Debug, Clone, PartialEq)]
pub struct LeafletArrays {
    /// Per point: 0 interior, 1 sutured, 2 free edge.
    pub boundary: Vec<u8>,
    /// Per triangle: its leaflet, from 0 (the file numbers them from 1).
    pub leaflet: Vec<u8>,
    /// How many leaflets (the largest number in the file).
    pub leaflets: usize,
    /// Per point: flat template coordinates (mm), when the file has them.
    pub ref_uv: Option<Vec<[f64; 2]>>,
    /// Per triangle: the two fibre directions, when the file has both.
    pub fibres: Option<Vec<[[f64; 3]; 2]>>,
    /// Per leaflet: the side the load acts on (+1 or −1), when given.
    pub pressure_sign: Option<Vec<f64>>,
}

/// Most leaflets a valve mesh may hold (a quadricuspid valve has 4).
pub const MAX_LEAFLETS: usize = 8;

/// Read and check the arrays; the error says which array and what is wrong.
pub fn arrays(m: &TriMesh) -> Result<LeafletArrays, String> {
    if m.triangles.is_empty() {
        return Err("has no triangles".into());
    }
    if let Some(i) = m
        .vertices
        .iter()
        .position(|p| !p.coords.iter().all(|c| c.is_finite()))
    {
        return Err(format!("point {i} has a non-finite position"));
    }
    let numbers = |a: Option<&coapt_geom::attributes::DataArray>, what: &str| {
        a.filter(|a| a.components == 1)
            .and_then(|a| a.values.to_f64())
            .ok_or_else(|| what.to_string())
    };
    let boundary = numbers(
        m.point_data.get("boundary"),
        "no point data 'boundary' (one number per point: 0 interior, 1 sutured, 2 free edge)",
    )?;
    if let Some(i) = boundary
        .iter()
        .position(|&b| !(b == 0.0 || b == 1.0 || b == 2.0))
    {
        return Err(format!(
            "point data 'boundary' of point {i} is {}: it must be 0 (interior), 1 (sutured) or 2 (free edge)",
            boundary[i]
        ));
    }
    let leaflet = numbers(
        m.cell_data.get("leaflet"),
        "no cell data 'leaflet' (one number per triangle: 1, 2, 3)",
    )?;
    if let Some(t) = leaflet
        .iter()
        .position(|&k| !(1.0..=MAX_LEAFLETS as f64).contains(&k) || k.fract() != 0.0)
    {
        return Err(format!(
            "cell data 'leaflet' of triangle {t} is {}: leaflets are numbered 1 to {MAX_LEAFLETS}",
            leaflet[t]
        ));
    }
    let leaflet: Vec<u8> = leaflet.iter().map(|&k| k as u8 - 1).collect();
    let leaflets = *leaflet.iter().max().expect("triangles checked above") as usize + 1;
    let ref_uv = match m.point_data.get("ref_uv") {
        None => None,
        Some(a) if a.components == 2 => {
            let v = a
                .values
                .to_f64()
                .ok_or("point data 'ref_uv' is not numeric")?;
            if v.iter().any(|x| !x.is_finite()) {
                return Err("point data 'ref_uv' holds a non-finite coordinate".into());
            }
            Some(v.chunks(2).map(|c| [c[0], c[1]]).collect())
        }
        Some(a) => {
            return Err(format!(
                "point data 'ref_uv' has {} components: it must have 2 (u, v in mm)",
                a.components
            ));
        }
    };
    let fibres = match (m.cell_data.get("fiber1"), m.cell_data.get("fiber2")) {
        (None, None) => None,
        (Some(a), Some(b)) if a.components == 3 && b.components == 3 => {
            let (a, b) = (a.values.to_f64(), b.values.to_f64());
            let (Some(a), Some(b)) = (a, b) else {
                return Err("cell data 'fiber1'/'fiber2' are not numeric".into());
            };
            if a.iter().chain(&b).any(|x| !x.is_finite()) {
                return Err("cell data 'fiber1'/'fiber2' hold a non-finite direction".into());
            }
            Some(
                a.chunks(3)
                    .zip(b.chunks(3))
                    .map(|(a, b)| [[a[0], a[1], a[2]], [b[0], b[1], b[2]]])
                    .collect(),
            )
        }
        _ => {
            return Err("cell data 'fiber1' and 'fiber2' come together, 3 components each".into());
        }
    };
    let pressure_sign = match m.field_data.get("pressure_sign").map(|a| a.values.to_f64()) {
        None => None,
        Some(Some(v)) if v.len() == leaflets && v.iter().all(|s| *s == 1.0 || *s == -1.0) => {
            Some(v)
        }
        Some(_) => {
            return Err(format!(
                "field data 'pressure_sign' must hold +1 or −1 for each of the {leaflets} leaflets"
            ));
        }
    };
    Ok(LeafletArrays {
        boundary: boundary.iter().map(|&b| b as u8).collect(),
        leaflet,
        leaflets,
        ref_uv,
        fibres,
        pressure_sign,
    })
}

/// Write `a` into `m` as the artifact carries it, the inverse of
/// [`arrays`]: point data `ref_uv` (when given) and `boundary`, cell data
/// `leaflet` (numbered from 1) and `fiber1`, `fiber2` (when given), field
/// data `pressure_sign` (when given). One writer for `coapt leaflets` and
/// for the leaflets the mechanics builds itself.
pub fn insert_arrays(m: &mut TriMesh, a: &LeafletArrays) {
    use coapt_geom::attributes::{DataArray, DataValues};
    if let Some(uv) = &a.ref_uv {
        m.point_data.insert(DataArray::new(
            "ref_uv",
            2,
            DataValues::F64(uv.iter().flat_map(|p| [p[0], p[1]]).collect()),
        ));
    }
    m.point_data.insert(DataArray::new(
        "boundary",
        1,
        DataValues::U8(a.boundary.clone()),
    ));
    m.cell_data.insert(DataArray::new(
        "leaflet",
        1,
        DataValues::I32(a.leaflet.iter().map(|&k| i32::from(k) + 1).collect()),
    ));
    if let Some(f) = &a.fibres {
        for (k, name) in ["fiber1", "fiber2"].into_iter().enumerate() {
            let v: Vec<[f64; 3]> = f.iter().map(|d| d[k]).collect();
            m.cell_data.insert(DataArray::vectors_f64(name, &v));
        }
    }
    if let Some(s) = &a.pressure_sign {
        m.field_data
            .insert(DataArray::scalars_f64("pressure_sign", s.clone()));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use coapt_geom::Point3;
    use coapt_geom::attributes::{DataArray, DataValues};

    /// Two triangles of leaflets 1 and 2 with every array right.
    fn mesh() -> TriMesh {
        let p = |x: f64, y: f64| Point3::new(x, y, 0.0);
        let mut m = TriMesh::new(
            vec![p(0.0, 0.0), p(1.0, 0.0), p(0.0, 1.0), p(1.0, 1.0)],
            vec![[0, 1, 2], [1, 3, 2]],
        );
        m.point_data
            .insert(DataArray::scalars_f64("boundary", vec![1.0, 0.0, 2.0, 1.0]));
        m.point_data.insert(DataArray::new(
            "ref_uv",
            2,
            DataValues::F64(vec![0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 1.0]),
        ));
        m.cell_data
            .insert(DataArray::scalars_f64("leaflet", vec![1.0, 2.0]));
        m.cell_data
            .insert(DataArray::vectors_f64("fiber1", &[[1.0, 0.0, 0.0]; 2]));
        m.cell_data
            .insert(DataArray::vectors_f64("fiber2", &[[0.0, 1.0, 0.0]; 2]));
        m.field_data
            .insert(DataArray::scalars_f64("pressure_sign", vec![1.0, -1.0]));
        m
    }

    /// What [`insert_arrays`] writes, [`arrays`] reads back.
    #[test]
    fn written_arrays_read_back() {
        let a = arrays(&mesh()).unwrap();
        let mut m = TriMesh::new(mesh().vertices, mesh().triangles);
        insert_arrays(&mut m, &a);
        assert_eq!(arrays(&m).unwrap(), a);
        let bare = LeafletArrays {
            ref_uv: None,
            fibres: None,
            pressure_sign: None,
            ..a
        };
        let mut m = TriMesh::new(mesh().vertices, mesh().triangles);
        insert_arrays(&mut m, &bare);
        assert_eq!(arrays(&m).unwrap(), bare);
    }

    #[test]
    fn a_right_mesh_reads_with_leaflets_from_zero() {
        let a = arrays(&mesh()).unwrap();
        assert_eq!(a.boundary, vec![1, 0, 2, 1]);
        assert_eq!(a.leaflet, vec![0, 1]);
        assert_eq!(a.leaflets, 2);
        assert_eq!(a.ref_uv.unwrap()[3], [1.0, 1.0]);
        assert_eq!(a.fibres.unwrap()[1], [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        assert_eq!(a.pressure_sign, Some(vec![1.0, -1.0]));
    }

    /// Each way an array can be wrong is refused, naming the array.
    #[test]
    fn every_wrong_array_is_refused_by_name() {
        type Break = fn(&mut TriMesh);
        let cases: [(Break, &str); 9] = [
            (|m| m.vertices[2].x = f64::NAN, "point 2 has a non-finite"),
            (
                |m| {
                    m.point_data
                        .insert(DataArray::scalars_f64("boundary", vec![1.0, 7.0, 2.0, 1.0]))
                },
                "'boundary' of point 1 is 7",
            ),
            (
                |m| {
                    m.point_data
                        .insert(DataArray::scalars_f64("boundary", vec![1.0, 0.5, 2.0, 1.0]))
                },
                "'boundary' of point 1 is 0.5",
            ),
            (
                |m| {
                    m.cell_data
                        .insert(DataArray::scalars_f64("leaflet", vec![0.0, 2.0]))
                },
                "'leaflet' of triangle 0 is 0",
            ),
            (
                |m| {
                    m.cell_data
                        .insert(DataArray::scalars_f64("leaflet", vec![1.0, 9.0]))
                },
                "numbered 1 to 8",
            ),
            (
                |m| {
                    m.cell_data = coapt_geom::attributes::Attributes::new();
                },
                "no cell data 'leaflet'",
            ),
            (
                |m| {
                    m.point_data
                        .insert(DataArray::new("ref_uv", 3, DataValues::F64(vec![0.0; 12])))
                },
                "'ref_uv' has 3 components",
            ),
            (
                |m| {
                    m.field_data
                        .insert(DataArray::scalars_f64("pressure_sign", vec![1.0]))
                },
                "each of the 2 leaflets",
            ),
            (
                |m| {
                    m.cell_data.insert(DataArray::vectors_f64(
                        "fiber2",
                        &[[f64::INFINITY, 0.0, 0.0]; 2],
                    ))
                },
                "non-finite direction",
            ),
        ];
        for (f, words) in cases {
            let mut m = mesh();
            f(&mut m);
            let e = arrays(&m).unwrap_err();
            assert!(e.contains(words), "expected {words:?} in {e}");
        }
    }
}
