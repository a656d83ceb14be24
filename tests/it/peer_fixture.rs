//! The mechanics crate tests itself on the peer leaflet read from
//! `crates/mech/tests/data/` (it cannot build it: that needs the leaflet
//! stage's mesher). These files must be exactly what `coapt bench close`
//! builds, bit for bit; `COAPT_WRITE_FIXTURES=1 cargo test --release
//! peer_fixture` writes them anew after a change to the mesher or the
//! placement.

use std::path::Path;

use coapt::bench::close::ozaki_cylinder;
use coapt::mech::model::{leaflets_from_mesh, leaflets_to_mesh};
use coapt::mech::peer::fixture_path;

#[test]
fn the_mechanics_peer_leaflets_are_what_the_benchmark_builds() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("crates/mech");
    for h in [0.7, 1.0, 2.0] {
        let (built, _axis) = ozaki_cylinder(h).unwrap();
        let path = fixture_path(&dir, h);
        if std::env::var_os("COAPT_WRITE_FIXTURES").is_some() {
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            coapt::io::vtp::write_mesh(&path, &leaflets_to_mesh(&built)).unwrap();
        }
        let kept = coapt::io::vtp::read_mesh(&path)
            .unwrap_or_else(|e| panic!("{e}: write it with COAPT_WRITE_FIXTURES=1"));
        let kept = leaflets_from_mesh(&kept).unwrap();
        let stale = format!(
            "{} is not what the benchmark builds at h {h} mm: write it anew with COAPT_WRITE_FIXTURES=1",
            path.display()
        );
        assert_eq!(kept.x, built.x, "{stale}");
        assert_eq!(kept.tris, built.tris, "{stale}");
        assert_eq!(kept.boundary, built.boundary, "{stale}");
        assert_eq!(kept.leaflet, built.leaflet, "{stale}");
        assert_eq!(kept.ref_uv, built.ref_uv, "{stale}");
        assert_eq!(kept.fibers, built.fibers, "{stale}");
        assert_eq!(kept.pressure_side, built.pressure_side, "{stale}");
        assert!(kept.x.len() > 50 && kept.boundary.contains(&1) && kept.boundary.contains(&2));
    }
}
