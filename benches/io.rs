//! `cargo bench --bench io`: throughput of the file formats on realistic
//! sizes: a 512×512×300 int16 CT (as a `full` phantom) and a 2-million-
//! triangle mesh. Best of three; numbers go in the closing notes and
//! docs/results.md ("Speed").

use std::time::Instant;

use coapt::geom::{DataArray, Matrix4, Point3, TriMesh, Volume};
use coapt::io::{nifti, vtp};
use coapt::rng::hash_normal;

fn best(mut f: impl FnMut()) -> f64 {
    (0..3)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

fn ct() -> Volume<i16> {
    let d = [512usize, 512, 300];
    let n = d[0] * d[1] * d[2];
    // Air outside a body ellipse, soft tissue inside, 25 HU noise: compresses like a CT.
    let vals: Vec<i16> = (0..n)
        .map(|k| {
            let (i, j) = ((k % 512) as f64 - 256.0, ((k / 512) % 512) as f64 - 256.0);
            let base = if (i / 230.0).powi(2) + (j / 170.0).powi(2) < 1.0 {
                40.0
            } else {
                -1000.0
            };
            (base + 25.0 * hash_normal(1, k as u64)).round() as i16
        })
        .collect();
    Volume::from_fortran_vec(d, Matrix4::identity(), vals).unwrap()
}

fn grid(n: usize) -> TriMesh {
    let mut v = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            let (x, y) = (i as f64 * 0.3, j as f64 * 0.3);
            v.push(Point3::new(x, y, (x * 0.1).sin() + (y * 0.07).cos()));
        }
    }
    let mut t = Vec::with_capacity(2 * (n - 1) * (n - 1));
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = (j * n + i) as u32;
            t.push([a, a + 1, a + n as u32 + 1]);
            t.push([a, a + n as u32 + 1, a + n as u32]);
        }
    }
    let mut m = TriMesh::new(v, t);
    let h: Vec<f64> = m.vertices.iter().map(|p| p.z).collect();
    m.point_data.insert(DataArray::scalars_f64("height", h));
    m
}

fn main() {
    let work = coapt::bench::work_dir::WorkDir::new(None, "io");
    let dir = work.path();
    std::fs::create_dir_all(dir).unwrap();
    let vol = ct();
    let mb = vol.len() as f64 * 2.0 / 1e6;
    println!("NIfTI, 512×512×300 int16 ({mb:.0} MB raw)");
    for name in ["ct.nii", "ct.nii.gz"] {
        let p = dir.join(name);
        let w = best(|| nifti::write(&p, &vol).unwrap());
        let r = best(|| drop(nifti::read_i16(&p).unwrap()));
        let size = std::fs::metadata(&p).unwrap().len() as f64 / 1e6;
        println!(
            "  {name:<10} write {w:.2} s ({:.0} MB/s)  read {r:.2} s ({:.0} MB/s)  file {size:.1} MB",
            mb / w,
            mb / r
        );
    }
    let mesh = grid(1001);
    println!(
        "VTP, {} points, {} triangles",
        mesh.vertices.len(),
        mesh.triangles.len()
    );
    for compress in [false, true] {
        let p = dir.join("m.vtp");
        let pd = mesh.to_polydata();
        let opts = vtp::WriteOptions { compress };
        let w = best(|| vtp::write(&p, &pd, &opts).unwrap());
        let r = best(|| drop(vtp::read(&p).unwrap()));
        let size = std::fs::metadata(&p).unwrap().len() as f64 / 1e6;
        println!("  zlib={compress:<5} write {w:.2} s  read {r:.2} s  file {size:.1} MB");
    }
}
