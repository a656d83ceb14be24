//! CT readers on arbitrary bytes: NIfTI-1/2 (plain and gzip), NRRD and
//! MetaImage, chosen by the first byte. A reader may refuse the file; it
//! may not panic, hang or allocate what the header claims without checking.
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "scratch.rs"]
mod scratch;

fuzz_target!(|data: &[u8]| {
    let Some((&pick, bytes)) = data.split_first() else {
        return;
    };
    let name = match pick % 5 {
        0 => "ct.nii",
        1 => "ct.nii.gz",
        2 => "ct.nrrd",
        3 => "ct.mha",
        _ => "ct.mhd",
    };
    let p = scratch::file(name, bytes);
    let _ = coapt::io::volume_file::read_ct(&p);
    let _ = coapt::io::nifti::read_u8(&p);
});
