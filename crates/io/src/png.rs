//! A minimal PNG writer (8-bit RGB, zlib via flate2, chunk CRCs via
//! crc32fast): debug slices and the report's figures, without pulling an
//! image-codec crate into the build. The report embeds these bytes, so they
//! must not drift: the `png` crate (0.18, level 1, no filter) writes the same
//! bytes today but reserves the right to change what its levels mean in
//! semver-compatible releases.

use std::io::Write;

/// An RGB image.
pub struct Rgb {
    pub w: usize,
    pub h: usize,
    pub px: Vec<[u8; 3]>,
}

/// One chunk: length, type, data, and the CRC-32 of type and data.
fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
    let mut crc = crc32fast::Hasher::new();
    crc.update(kind);
    crc.update(data);
    out.extend((data.len() as u32).to_be_bytes());
    out.extend_from_slice(kind);
    out.extend_from_slice(data);
    out.extend(crc.finalize().to_be_bytes());
}

/// Encode as PNG bytes.
pub fn encode(img: &Rgb) -> Vec<u8> {
    let mut raw = Vec::with_capacity(img.h * (1 + 3 * img.w));
    for y in 0..img.h {
        raw.push(0);
        for x in 0..img.w {
            raw.extend(img.px[x + y * img.w]);
        }
    }
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::fast());
    z.write_all(&raw).expect("in-memory write");
    let idat = z.finish().expect("in-memory write");
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = Vec::new();
    ihdr.extend((img.w as u32).to_be_bytes());
    ihdr.extend((img.h as u32).to_be_bytes());
    ihdr.extend([8, 2, 0, 0, 0]);
    chunk(&mut out, b"IHDR", &ihdr);
    chunk(&mut out, b"IDAT", &idat);
    chunk(&mut out, b"IEND", &[]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 1×1 RGB image: the IHDR and IEND chunks, CRCs included, are the
    /// well-known bytes every such PNG carries; the pixel survives zlib.
    #[test]
    fn one_pixel_png_has_the_known_chunks() {
        let png = encode(&Rgb {
            w: 1,
            h: 1,
            px: vec![[200, 100, 50]],
        });
        assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
        assert_eq!(
            &png[8..33],
            b"\0\0\0\x0dIHDR\0\0\0\x01\0\0\0\x01\x08\x02\0\0\0\x90\x77\x53\xde"
        );
        assert_eq!(&png[png.len() - 12..], b"\0\0\0\0IEND\xae\x42\x60\x82");
        let len = u32::from_be_bytes(png[33..37].try_into().unwrap()) as usize;
        assert_eq!(&png[37..41], b"IDAT");
        assert_eq!(png.len(), 41 + len + 4 + 12);
        let idat = &png[41..41 + len];
        let mut raw = Vec::new();
        std::io::Read::read_to_end(&mut flate2::read::ZlibDecoder::new(idat), &mut raw).unwrap();
        assert_eq!(raw, [0, 200, 100, 50]);
        let mut crc = crc32fast::Hasher::new();
        crc.update(&png[37..41 + len]);
        assert_eq!(png[41 + len..45 + len], crc.finalize().to_be_bytes());
    }
}
