//! DICOM on arbitrary bytes: one file read as a multi-frame image, or the
//! bytes cut into up to four files of one folder read as a series. A reader
//! may refuse; it may not panic, hang or allocate what a header claims
//! without checking it against the bytes there are.
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "scratch.rs"]
mod scratch;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let dir = scratch::dir("dicom");
    if mode % 2 == 0 {
        let p = dir.join("one.dcm");
        std::fs::write(&p, rest).expect("scratch file");
        let _ = coapt::io::volume_file::read_ct(&p);
        return;
    }
    // Files of one folder: each preceded by its length (u16, little endian).
    let mut bytes = rest;
    for i in 0..4 {
        if bytes.len() < 2 {
            break;
        }
        let n = (u16::from_le_bytes([bytes[0], bytes[1]]) as usize).min(bytes.len() - 2);
        std::fs::write(dir.join(format!("IM{i}")), &bytes[2..2 + n]).expect("scratch file");
        bytes = &bytes[2 + n..];
    }
    let _ = coapt::io::volume_file::read_header(&dir, &Default::default());
    let _ = coapt::io::volume_file::read_ct(&dir);
});
