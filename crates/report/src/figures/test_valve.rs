//! A synthetic closed valve for the figures' tests: three leaflets, each a
//! grid over a 120° sector that rises towards the centre, with contact along
//! the sector sides (coaptation) and near the axis (central zone).

use crate::ClosedValve;
use coapt_geom::{Point3, ValveFrame, Vector3};

/// `n`×`n` nodes per leaflet; returns the valve and its contact bitmasks.
pub fn synthetic_valve(n: usize) -> (ClosedValve, Vec<u8>) {
    let n = n.max(2);
    let radius = 12.0;
    let origin = Point3::new(10.0, -20.0, 30.0);
    // A tilted axis, so that nothing relies on the frame being the world's.
    let axis = Vector3::new(0.2, 0.1, 1.0).normalize();
    let frame0 = ValveFrame::new(
        origin,
        axis,
        [origin + Vector3::x() * 5.0 + axis * 15.0; 3],
        None,
    )
    .expect("valid frame");
    let c = |k: usize| frame0.from_cylindrical(15.0, (120.0 * k as f64).to_radians(), radius);
    let frame = ValveFrame::new(origin, axis, [c(0), c(1), c(2)], None).expect("valid frame");
    let (mut x, mut tris, mut tri_leaflet, mut boundary, mut uv, mut contact) =
        (vec![], vec![], vec![], vec![], vec![], vec![]);
    for j in 0..3usize {
        let base = x.len() as u32;
        let mid = (60.0 + 120.0 * j as f64).to_radians();
        for a in 0..n {
            let s = 0.08 + 0.92 * a as f64 / (n - 1) as f64;
            for b in 0..n {
                let t = b as f64 / (n - 1) as f64;
                let ang = mid + (t - 0.5) * 116f64.to_radians();
                let h = 4.0 + 9.0 * (1.0 - s) * (1.0 - s);
                x.push(frame.from_cylindrical(h, ang, radius * s));
                uv.push([24.0 * (t - 0.5) * (0.4 + s), 14.0 * s]);
                boundary.push(if a == n - 1 {
                    1
                } else if b == 0 || b == n - 1 {
                    2
                } else {
                    0
                });
                let mut m = 0u8;
                if t < 0.2 {
                    m |= 1 << ((j + 2) % 3);
                }
                if t > 0.8 {
                    m |= 1 << ((j + 1) % 3);
                }
                if s < 0.25 {
                    m |= (1 << ((j + 1) % 3)) | (1 << ((j + 2) % 3));
                }
                contact.push(m);
            }
        }
        for a in 0..n - 1 {
            for b in 0..n - 1 {
                let i = base + (a * n + b) as u32;
                let nn = n as u32;
                tris.push([i, i + 1, i + nn + 1]);
                tris.push([i, i + nn + 1, i + nn]);
                tri_leaflet.extend([j as u8; 2]);
            }
        }
    }
    let v = ClosedValve {
        x0: x.clone(),
        x,
        tris,
        tri_leaflet,
        boundary,
        ref_uv: Some(uv),
        frame,
        leaflets: 3,
    };
    (v, contact)
}

/// Count pixels of exactly `colour` in a decoded image.
pub fn count(img: &coapt_io::png::Rgb, colour: [u8; 3]) -> usize {
    img.px.iter().filter(|p| **p == colour).count()
}

/// Decode a PNG written by `io::png::encode` (one IDAT, filter 0, RGB8).
pub fn decode(png: &[u8]) -> coapt_io::png::Rgb {
    use std::io::Read;
    let be = |b: &[u8]| u32::from_be_bytes([b[0], b[1], b[2], b[3]]) as usize;
    let (w, h) = (be(&png[16..20]), be(&png[20..24]));
    let mut pos = 8;
    let mut idat = Vec::new();
    while pos + 8 <= png.len() {
        let len = be(&png[pos..]);
        if &png[pos + 4..pos + 8] == b"IDAT" {
            idat.extend_from_slice(&png[pos + 8..pos + 8 + len]);
        }
        pos += 12 + len;
    }
    let mut raw = Vec::new();
    flate2::read::ZlibDecoder::new(&idat[..])
        .read_to_end(&mut raw)
        .expect("zlib");
    let mut px = Vec::with_capacity(w * h);
    for y in 0..h {
        let row = &raw[y * (1 + 3 * w) + 1..(y + 1) * (1 + 3 * w)];
        px.extend(row.chunks(3).map(|c| [c[0], c[1], c[2]]));
    }
    coapt_io::png::Rgb { w, h, px }
}
