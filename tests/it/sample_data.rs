//! The committed sample is exactly what its README says regenerates it.

use crate::common::*;

#[test]
fn sample_data_regenerates_bit_identically() {
    let d = tmpdir("sample");
    sample_phantom(&d, &["--seed", "1"]);
    let committed = repo().join("sample_data");
    for f in [
        "ct.nii.gz",
        "truth_mask.nii.gz",
        "landmarks.mrk.json",
        "truth.json",
        "truth_surface.vtp",
    ] {
        let a = std::fs::read(committed.join(f)).unwrap();
        let b = std::fs::read(d.join(f)).unwrap();
        assert!(
            a == b,
            "sample_data/{f} differs from a fresh `coapt phantom --preset sample --seed 1`; regenerate it (see sample_data/README.md)"
        );
    }
}

#[test]
fn sample_data_is_small() {
    let total: u64 = std::fs::read_dir(repo().join("sample_data"))
        .unwrap()
        .map(|e| e.unwrap().metadata().unwrap().len())
        .sum();
    assert!(total <= 5 * 1024 * 1024, "sample_data is {total} bytes");
}
