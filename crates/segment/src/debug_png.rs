//! Debug images for `--debug-dir`: CT slices (window −200…600 HU) with the
//! mask contour in red, and the top slice's circleness map with the found
//! circles, so a person can see what the stage did.

use std::path::Path;

use super::Segmentation;
use coapt_base::{Error, Result};
use coapt_geom::Volume;
use coapt_io::png::{Rgb, encode};

fn grey(hu: f64) -> u8 {
    (((hu + 200.0) / 800.0).clamp(0.0, 1.0) * 255.0) as u8
}

/// A plane of the mask's grid: axis `a` fixed at index `at`; the image's x
/// and y run along the other two axes (y flipped for k so superior is up).
fn plane(ct: &Volume<i16>, mask: &Volume<u8>, a: usize, at: usize) -> Rgb {
    let md = mask.dims();
    let (ax, ay) = match a {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    };
    let (w, h) = (md[ax], md[ay]);
    let o = ct
        .world_to_index(&mask.index_to_world([0.0; 3]))
        .map(|x| x.round() as i64);
    let at_ijk = |x: usize, y: usize| {
        let mut q = [0usize; 3];
        q[a] = at;
        q[ax] = x;
        q[ay] = if ay == 2 { h - 1 - y } else { y };
        q
    };
    let m = |q: [usize; 3]| mask.as_slice()[mask.linear_index(q[0], q[1], q[2])] != 0;
    let mut px = vec![[0u8; 3]; w * h];
    for y in 0..h {
        for x in 0..w {
            let q = at_ijk(x, y);
            let c = [0, 1, 2].map(|d| (q[d] as i64 + o[d]) as usize);
            let g = grey(ct.as_slice()[ct.linear_index(c[0], c[1], c[2])] as f64);
            let inside = m(q);
            let edge = inside
                && [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)]
                    .iter()
                    .any(|&(dx, dy)| {
                        let (xx, yy) = (x as i64 + dx, y as i64 + dy);
                        xx < 0
                            || yy < 0
                            || xx >= w as i64
                            || yy >= h as i64
                            || !m(at_ijk(xx as usize, yy as usize))
                    });
            px[x + y * w] = if edge { [255, 40, 40] } else { [g, g, g] };
        }
    }
    Rgb { w, h, px }
}

/// The circleness map of the top slice (grey = C), circles found in green.
fn circleness(seg: &Segmentation, ct: &Volume<i16>) -> Rgb {
    let map = &seg.top_circleness;
    let (w, h) = (map.ni, map.nj);
    let mut px: Vec<[u8; 3]> = map
        .c
        .iter()
        .map(|&c| {
            let g = (c.clamp(0.0, 1.0) * 255.0) as u8;
            [g, g, g]
        })
        .collect();
    let sp = ct.spacing();
    for c in &seg.report.candidates {
        let q = ct.world_to_index(&coapt_geom::Point3::from(c.centre_mm));
        let colour = if c.verdict.starts_with("ascending") {
            [40, 255, 40]
        } else {
            [40, 120, 255]
        };
        for t in 0..720 {
            let th = t as f64 * std::f64::consts::PI / 360.0;
            let x = (q[0] + c.r_mm * th.cos() / sp[0]).round() as i64;
            let y = (q[1] + c.r_mm * th.sin() / sp[1]).round() as i64;
            if x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < h {
                px[x as usize + y as usize * w] = colour;
            }
        }
    }
    Rgb { w, h, px }
}

/// Write the debug images into `dir`.
pub fn write_all(dir: &Path, ct: &Volume<i16>, seg: &Segmentation) -> Result<Vec<String>> {
    std::fs::create_dir_all(dir).map_err(|e| Error::write(dir, e))?;
    let md = seg.mask.dims();
    let seed = seg
        .mask
        .world_to_index(&coapt_geom::Point3::from(seg.report.seed_mm))
        .map(|x| x.round().max(0.0) as usize);
    let mut images: Vec<(String, Rgb)> = vec![("circleness_top.png".into(), circleness(seg, ct))];
    for f in [0.1, 0.3, 0.5, 0.7, 0.9] {
        let k = ((md[2] - 1) as f64 * f) as usize;
        images.push((format!("axial_k{k:03}.png"), plane(ct, &seg.mask, 2, k)));
    }
    images.push((
        "sagittal_seed.png".into(),
        plane(ct, &seg.mask, 0, seed[0].min(md[0] - 1)),
    ));
    images.push((
        "coronal_seed.png".into(),
        plane(ct, &seg.mask, 1, seed[1].min(md[1] - 1)),
    ));
    let mut names = Vec::new();
    for (name, img) in images {
        let p = dir.join(&name);
        std::fs::write(&p, encode(&img)).map_err(|e| Error::write(&p, e))?;
        names.push(name);
    }
    Ok(names)
}
