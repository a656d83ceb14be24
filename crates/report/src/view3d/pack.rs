//! The scene as compact text for the page: positions rounded to a quantum
//! (10 µm, doubled until every coordinate fits an Int16), then positions
//! and triangle indices each stored as the differences between successive
//! values (coordinates: to the same coordinate of the previous vertex), as
//! zigzag LEB128 varints in base64, inside a small JSON object. Meshes
//! number their vertices along the surface, so most differences take one
//! or two bytes. Only integers are formatted, so the bytes depend on
//! nothing but the scene.

use std::fmt::Write as _;

use base64::{Engine as _, engine::general_purpose::STANDARD as BASE64};

use super::scene::{Part, Scene};
use crate::figures::palette::{PAIR, TRIPLE, leaflet_tint};
use crate::raster::Rgb8;

/// Version of the payload the viewer script reads.
pub const FORMAT: &str = "coapt-view3d/1";

/// The finest quantum, mm: far below a leaflet's 0.5 mm thickness and the
/// meshes' millimetre edges, so the view shows the computed shape.
pub const BASE_QUANTUM_MM: f64 = 0.01;

/// Colour of the translucent wall.
pub const WALL: Rgb8 = [196, 92, 92];

/// Quantum `BASE_QUANTUM_MM × 2^exp` (exact: a power of two) and the
/// rounded coordinates, x y z per vertex.
#[derive(Debug, Clone, PartialEq)]
pub struct Quantised {
    pub exp: u32,
    pub xyz: Vec<i16>,
}

pub fn quantum_mm(exp: u32) -> f64 {
    BASE_QUANTUM_MM * 2f64.powi(exp as i32)
}

/// Round finite `positions` to the smallest quantum at which they all fit.
pub fn quantise(positions: &[[f64; 3]]) -> Quantised {
    let max = positions
        .iter()
        .flatten()
        .fold(0.0f64, |m, c| m.max(c.abs()));
    let mut exp = 0;
    while (max / quantum_mm(exp)).round() > i16::MAX as f64 {
        exp += 1;
    }
    let q = quantum_mm(exp);
    let xyz = positions
        .iter()
        .flatten()
        .map(|c| (c / q).round() as i16)
        .collect();
    Quantised { exp, xyz }
}

/// Each value minus the one `stride` before it (the first `stride` values
/// as they are), zigzag-mapped (0, −1, 1, −2, … → 0, 1, 2, 3, …) and written
/// 7 bits a byte, low bits first, the high bit set on all but a value's
/// last byte.
pub fn delta_varint(values: &[i64], stride: usize) -> Vec<u8> {
    let mut out = Vec::with_capacity(values.len() * 2);
    for (k, &v) in values.iter().enumerate() {
        let prev = if k >= stride { values[k - stride] } else { 0 };
        let d = v.wrapping_sub(prev);
        let mut z = ((d << 1) ^ (d >> 63)) as u64;
        while z >= 0x80 {
            out.push((z as u8 & 0x7f) | 0x80);
            z >>= 7;
        }
        out.push(z as u8);
    }
    out
}

fn part_json(h: &mut String, name: &str, p: &Part) {
    let q = quantise(&p.positions);
    let xyz: Vec<i64> = q.xyz.iter().map(|&c| c as i64).collect();
    let ids: Vec<i64> = p.triangles.iter().flatten().map(|&i| i as i64).collect();
    let _ = write!(
        h,
        "\"{name}\":{{\"vertices\":{},\"triangles\":{},\"quantum_exp\":{},\"positions\":\"{}\",\"indices\":\"{}\"",
        p.positions.len(),
        p.triangles.len(),
        q.exp,
        BASE64.encode(delta_varint(&xyz, 3)),
        BASE64.encode(delta_varint(&ids, 1)),
    );
}

fn rgb(c: Rgb8) -> String {
    format!("[{},{},{}]", c[0], c[1], c[2])
}

/// The payload: a JSON object with no `<`, so it can sit in a `<script>`
/// element of the page as it is.
pub fn payload(s: &Scene) -> String {
    let mut h = String::new();
    let tints: Vec<String> = (0..s.leaflet_count).map(|j| rgb(leaflet_tint(j))).collect();
    let _ = write!(
        h,
        "{{\"format\":\"{FORMAT}\",\"base_quantum_um\":{},\"colours\":{{\"leaflets\":[{}],\"pair\":{},\"triple\":{},\"wall\":{}}},",
        (BASE_QUANTUM_MM * 1000.0).round() as u32,
        tints.join(","),
        rgb(PAIR),
        rgb(TRIPLE),
        rgb(WALL),
    );
    part_json(&mut h, "leaflets", &s.leaflets);
    let _ = write!(h, ",\"codes\":\"{}\"}}", BASE64.encode(&s.codes));
    if let Some((w, _)) = &s.wall {
        h.push(',');
        part_json(&mut h, "wall", w);
        h.push('}');
    }
    h.push('}');
    h
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::figures::test_valve::synthetic_valve;
    use crate::view3d::scene::build;
    use crate::view3d::scene::tests::tube;
    use serde_json::Value;

    /// The inverse of [`delta_varint`], as the viewer decodes; `None` on a
    /// truncated varint.
    pub(crate) fn undelta_varint(bytes: &[u8], stride: usize) -> Option<Vec<i64>> {
        let mut out: Vec<i64> = Vec::new();
        let (mut z, mut shift) = (0u64, 0);
        for &b in bytes {
            z |= ((b & 0x7f) as u64) << shift;
            shift += 7;
            if b & 0x80 == 0 {
                let d = (z >> 1) as i64 ^ -((z & 1) as i64);
                let k = out.len();
                out.push(if k >= stride {
                    out[k - stride].wrapping_add(d)
                } else {
                    d
                });
                (z, shift) = (0, 0);
            }
        }
        (shift == 0).then_some(out)
    }

    /// A part read back from the payload as the viewer reads it.
    pub(crate) fn decode_part(v: &Value) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let q = quantum_mm(v["quantum_exp"].as_u64().unwrap() as u32);
        let field = |k: &str, stride| {
            undelta_varint(&BASE64.decode(v[k].as_str().unwrap()).unwrap(), stride).unwrap()
        };
        let xyz = field("positions", 3);
        let ids = field("indices", 1);
        assert_eq!(xyz.len(), 3 * v["vertices"].as_u64().unwrap() as usize);
        assert_eq!(ids.len(), 3 * v["triangles"].as_u64().unwrap() as usize);
        assert!(xyz.iter().all(|&c| i16::try_from(c).is_ok()));
        (
            xyz.chunks_exact(3)
                .map(|c| [c[0] as f64 * q, c[1] as f64 * q, c[2] as f64 * q])
                .collect(),
            ids.chunks_exact(3)
                .map(|c| [c[0], c[1], c[2]].map(|i| u32::try_from(i).unwrap()))
                .collect(),
        )
    }

    fn assert_round_trip(v: &Value, p: &Part) {
        let (xyz, tris) = decode_part(v);
        let q = quantum_mm(v["quantum_exp"].as_u64().unwrap() as u32);
        assert_eq!(xyz.len(), p.positions.len());
        for (a, b) in xyz.iter().zip(&p.positions) {
            for k in 0..3 {
                assert!((a[k] - b[k]).abs() <= 0.5 * q + 1e-12, "{a:?} vs {b:?}");
            }
        }
        assert_eq!(tris, p.triangles);
        assert!(tris.iter().flatten().all(|&i| (i as usize) < xyz.len()));
    }

    #[test]
    fn payload_decodes_to_the_scene_within_the_quantum() {
        let (v, contact) = synthetic_valve(9);
        let s = build(&v, &contact, None).unwrap();
        let text = payload(&s);
        assert!(!text.contains('<'));
        let j: Value = serde_json::from_str(&text).unwrap();
        assert_eq!(j["format"], FORMAT);
        assert_eq!(j["leaflets"]["quantum_exp"], 0, "a 12 mm valve fits 10 µm");
        assert_round_trip(&j["leaflets"], &s.leaflets);
        let codes = BASE64
            .decode(j["leaflets"]["codes"].as_str().unwrap())
            .unwrap();
        assert_eq!(codes, s.codes);
        assert_eq!(j["colours"]["leaflets"].as_array().unwrap().len(), 3);
        assert!(j.get("wall").is_none());
        // With a wall: its part decodes as well.
        let s = build(&v, &contact, Some(&tube(&v))).unwrap();
        let j: Value = serde_json::from_str(&payload(&s)).unwrap();
        assert_round_trip(&j["wall"], &s.wall.as_ref().unwrap().0);
        assert_round_trip(&j["leaflets"], &s.leaflets);
    }

    #[test]
    fn large_coordinates_coarsen_the_quantum_and_still_fit() {
        let p = [[327.66, -0.004, 0.0], [-1000.0, 5.0, 0.125]];
        let q = quantise(&p);
        assert_eq!(q.exp, 2, "1000 mm needs 40 µm");
        for (c, r) in p.iter().flatten().zip(&q.xyz) {
            assert!((*r as f64 * quantum_mm(q.exp) - c).abs() <= 0.5 * quantum_mm(q.exp));
        }
        assert_eq!(quantise(&[[327.67, 0.0, 0.0]]).exp, 0);
        assert_eq!(quantise(&[[327.68, 0.0, 0.0]]).exp, 1);
        assert_eq!(quantise(&[]).exp, 0);
    }

    #[test]
    fn varints_round_trip_small_and_extreme_differences() {
        let v = [
            0,
            1,
            -1,
            63,
            -64,
            64,
            1 << 20,
            -(1 << 40),
            i64::MAX,
            i64::MIN,
            7,
            7,
        ];
        for stride in [1, 3] {
            let b = delta_varint(&v, stride);
            assert_eq!(undelta_varint(&b, stride).unwrap(), v);
        }
        // Small steps take one byte each; zigzag keeps −64..=63 in one.
        assert_eq!(delta_varint(&[5, 6, 4, 67, 3], 1), [10, 2, 3, 126, 127]);
        assert_eq!(delta_varint(&[64], 1), [0x80, 0x01]);
        let b = delta_varint(&[1 << 30], 1);
        assert!(undelta_varint(&b[..b.len() - 1], 1).is_none());
        // Indices past 65 536 (Uint32 in the viewer) survive.
        let n = 70_000u32;
        let part = Part {
            positions: (0..n).map(|i| [i as f64 * 1e-3, 0.0, 0.0]).collect(),
            triangles: vec![[0, n / 2, n - 1], [1, 2, 3]],
        };
        let mut h = String::from("{");
        part_json(&mut h, "p", &part);
        h.push_str("}}");
        let j: Value = serde_json::from_str(&h).unwrap();
        assert_round_trip(&j["p"], &part);
    }

    #[test]
    fn same_scene_same_bytes_whatever_the_threads() {
        let (v, contact) = synthetic_valve(10);
        let a = payload(&build(&v, &contact, None).unwrap());
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap();
        let b = pool.install(|| payload(&build(&v, &contact, None).unwrap()));
        assert_eq!(a, b);
        // A change of one node by more than the quantum changes the bytes.
        let mut w = v.clone();
        w.x[5] += w.frame.axis * 0.02;
        assert_ne!(a, payload(&build(&w, &contact, None).unwrap()));
    }
}
