//! One image's (or frame's) stored samples, decoded. Uncompressed and
//! deflated pixel data go through dicom-pixeldata; RLE and JPEG lossless do
//! not: dicom-rs's RLE and JPEG adapters index past their buffers on damaged
//! data (a flipped byte in an RLE segment or a JPEG frame header panicked
//! `coapt convert` in 16 of 300 and 10 of 400 random damages). RLE is
//! decoded here (DICOM PS3.5 Annex G), JPEG by jpeg-decoder directly, and
//! every size is checked against the header before a byte is placed.

use std::borrow::Cow;
use std::io::Cursor;

use dicom_dictionary_std::tags;
use dicom_object::DefaultDicomObject;
use dicom_pixeldata::{PixelDecoder, PixelRepresentation};
use jpeg_decoder::{CodingProcess, PixelFormat};

use super::scan::Slice;

/// Stored values as read, before Bits Stored and Rescale are applied.
pub struct Samples {
    /// One value per pixel, row after row, in its allocated low bits.
    pub raw: Vec<u64>,
    /// Bits Stored, within 1…the bits allocated.
    pub bits_stored: u32,
    pub signed: bool,
}

const RLE: &str = "1.2.840.10008.1.2.5";
const JPEG_LOSSLESS: [&str; 2] = ["1.2.840.10008.1.2.4.57", "1.2.840.10008.1.2.4.70"];

/// The samples of `sl` (its frame, for a multi-frame file) in `obj`,
/// whose transfer syntax is `ts`.
pub fn decode(obj: &DefaultDicomObject, sl: &Slice, ts: &str) -> Result<Samples, String> {
    if ts != RLE && !JPEG_LOSSLESS.contains(&ts) {
        return native(obj, sl);
    }
    let int = |tag, name: &str, default: Option<u32>| -> Result<u32, String> {
        match obj.get(tag) {
            None => default.ok_or_else(|| format!("{name} is missing")),
            Some(e) => e
                .to_int::<u32>()
                .map_err(|_| format!("{name} is not a whole number")),
        }
    };
    let allocated = int(tags::BITS_ALLOCATED, "Bits Allocated", None)?;
    let stored = int(tags::BITS_STORED, "Bits Stored", Some(allocated))?;
    let signed = int(tags::PIXEL_REPRESENTATION, "Pixel Representation", Some(0))? == 1;
    let spp = int(tags::SAMPLES_PER_PIXEL, "Samples per Pixel", Some(1))?;
    if spp != 1 {
        return Err(format!(
            "{spp} samples per pixel; coapt needs greyscale (1)"
        ));
    }
    let bytes = match allocated {
        8 => 1,
        16 => 2,
        32 => 4,
        b => return Err(format!("{b} bits allocated per pixel is not supported")),
    };
    let n = sl.rows as usize * sl.columns as usize;
    let data = fragments_of(obj, sl.frame)?;
    let raw = if ts == RLE {
        rle(&data, n, bytes)?
    } else {
        jpeg(&data, sl, bytes)?
    };
    Ok(Samples {
        raw,
        bits_stored: stored.clamp(1, 8 * bytes as u32),
        signed,
    })
}

/// Uncompressed or deflated pixel data, through dicom-pixeldata.
fn native(obj: &DefaultDicomObject, sl: &Slice) -> Result<Samples, String> {
    let px = match sl.frame {
        None => obj.decode_pixel_data(),
        Some(f) => obj.decode_pixel_data_frame(f),
    }
    .map_err(|e| e.to_string())?;
    if px.rows() != sl.rows || px.columns() != sl.columns || px.samples_per_pixel() != 1 {
        return Err(format!(
            "pixel data is {}×{} with {} samples per pixel; coapt needs {}×{} greyscale",
            px.columns(),
            px.rows(),
            px.samples_per_pixel(),
            sl.columns,
            sl.rows
        ));
    }
    let bytes = match px.bits_allocated() {
        8 => 1,
        16 => 2,
        32 => 4,
        b => return Err(format!("{b} bits allocated per pixel is not supported")),
    };
    let n = sl.rows as usize * sl.columns as usize;
    let data = px.data();
    if data.len() < n * bytes {
        return Err(format!(
            "pixel data holds {} bytes, {n} pixels of {bytes} bytes need {}: truncated",
            data.len(),
            n * bytes
        ));
    }
    // Decoded samples are in native byte order.
    let raw = data[..n * bytes]
        .chunks_exact(bytes)
        .map(|b| match bytes {
            1 => b[0] as u64,
            2 => u16::from_ne_bytes([b[0], b[1]]) as u64,
            _ => u32::from_ne_bytes([b[0], b[1], b[2], b[3]]) as u64,
        })
        .collect();
    Ok(Samples {
        raw,
        bits_stored: (px.bits_stored() as u32).clamp(1, 8 * bytes as u32),
        signed: px.pixel_representation() == PixelRepresentation::Signed,
    })
}

/// The encapsulated bytes of one frame: all fragments of a single-frame
/// image; for frame `f` of a multi-frame file its fragment when there is
/// one per frame, else the fragments the Basic Offset Table assigns it.
fn fragments_of(obj: &DefaultDicomObject, frame: Option<u32>) -> Result<Cow<'_, [u8]>, String> {
    let e = obj.get(tags::PIXEL_DATA).ok_or("Pixel Data is missing")?;
    let frags = e
        .value()
        .fragments()
        .ok_or("Pixel Data is not encapsulated, but the transfer syntax says it is compressed")?;
    let Some(f) = frame else {
        return Ok(match frags {
            [one] => Cow::Borrowed(one.as_slice()),
            _ => Cow::Owned(frags.concat()),
        });
    };
    let frames = obj
        .get(tags::NUMBER_OF_FRAMES)
        .and_then(|e| e.to_int::<u32>().ok())
        .unwrap_or(1) as usize;
    let f = f as usize;
    if frags.len() == frames {
        return Ok(Cow::Borrowed(frags[f].as_slice()));
    }
    let bot = e.value().offset_table().unwrap_or(&[]);
    if bot.len() != frames {
        return Err(format!(
            "{} fragments for {frames} frames and no Basic Offset Table to say which hold \
             frame {}",
            frags.len(),
            f + 1
        ));
    }
    let (start, end) = (
        bot[f] as u64,
        bot.get(f + 1).map_or(u64::MAX, |&o| o as u64),
    );
    let mut at = 0u64;
    let mut out = Vec::new();
    for frag in frags {
        if at >= start && at < end {
            out.extend_from_slice(frag);
        }
        // Each fragment's item header is 8 bytes.
        at += frag.len() as u64 + 8;
    }
    if out.is_empty() {
        return Err(format!(
            "the Basic Offset Table points frame {} at no fragment",
            f + 1
        ));
    }
    Ok(Cow::Owned(out))
}

/// DICOM RLE: a 64-byte header (segment count, 15 offsets), one PackBits
/// segment per byte of the sample, most significant first.
fn rle(data: &[u8], n: usize, bytes: usize) -> Result<Vec<u64>, String> {
    if data.len() < 64 {
        return Err(format!(
            "RLE data of {} bytes is shorter than its 64-byte header",
            data.len()
        ));
    }
    let word = |i: usize| u32::from_le_bytes([data[i], data[i + 1], data[i + 2], data[i + 3]]);
    let segments = word(0) as usize;
    if segments != bytes {
        return Err(format!(
            "RLE header lists {segments} segments; {}-bit greyscale needs {bytes}",
            8 * bytes
        ));
    }
    let offsets: Vec<usize> = (0..segments).map(|s| word(4 + 4 * s) as usize).collect();
    let mut raw = vec![0u64; n];
    for s in 0..segments {
        let start = offsets[s];
        let end = offsets.get(s + 1).copied().unwrap_or(data.len());
        if start < 64 || start > end || end > data.len() {
            return Err(format!(
                "RLE segment {} runs from byte {start} to {end} of {}: the header is corrupt",
                s + 1,
                data.len()
            ));
        }
        let seg =
            unpack_bits(&data[start..end], n).map_err(|p| format!("RLE segment {}: {p}", s + 1))?;
        for (r, b) in raw.iter_mut().zip(seg) {
            *r = (*r << 8) | b as u64;
        }
    }
    Ok(raw)
}

/// PackBits to exactly `n` bytes (a trailing pad byte may follow).
fn unpack_bits(seg: &[u8], n: usize) -> Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(n);
    let mut i = 0;
    while out.len() < n && i < seg.len() {
        let h = seg[i] as i8;
        i += 1;
        if h >= 0 {
            let count = h as usize + 1;
            let lit = seg
                .get(i..i + count)
                .ok_or("a literal run is cut off: the data are truncated")?;
            out.extend_from_slice(lit);
            i += count;
        } else if h != -128 {
            let b = *seg
                .get(i)
                .ok_or("a repeat run is cut off: the data are truncated")?;
            out.extend(std::iter::repeat_n(b, (1 - h as isize) as usize));
            i += 1;
        }
    }
    if out.len() != n {
        return Err(format!(
            "decodes to {} bytes where the image has {n} pixels",
            out.len()
        ));
    }
    Ok(out)
}

/// One lossless JPEG frame, checked to be the size and kind the header says.
fn jpeg(data: &[u8], sl: &Slice, bytes: usize) -> Result<Vec<u64>, String> {
    let mut dec = jpeg_decoder::Decoder::new(Cursor::new(data));
    let px = dec
        .decode()
        .map_err(|e| format!("its JPEG data do not decode: {e}"))?;
    let info = dec.info().ok_or("its JPEG data have no frame header")?;
    if info.coding_process != CodingProcess::Lossless {
        return Err(
            "its transfer syntax says JPEG lossless, but the JPEG data are DCT-coded (lossy)"
                .into(),
        );
    }
    if (info.width as u32, info.height as u32) != (sl.columns, sl.rows) {
        return Err(format!(
            "its JPEG frame is {}×{} where the header says {}×{}",
            info.width, info.height, sl.columns, sl.rows
        ));
    }
    let per = match info.pixel_format {
        PixelFormat::L8 => 1,
        PixelFormat::L16 => 2,
        f => return Err(format!("its JPEG frame is {f:?}; coapt needs greyscale")),
    };
    if per > bytes {
        return Err(format!(
            "its JPEG samples have more bits than the {} allocated",
            8 * bytes
        ));
    }
    let n = sl.rows as usize * sl.columns as usize;
    if px.len() != n * per {
        return Err(format!(
            "its JPEG frame decodes to {} bytes where {n} pixels need {}",
            px.len(),
            n * per
        ));
    }
    // jpeg-decoder gives 16-bit samples in native byte order.
    Ok(px
        .chunks_exact(per)
        .map(|b| match per {
            1 => b[0] as u64,
            _ => u16::from_ne_bytes([b[0], b[1]]) as u64,
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::{rle, unpack_bits};

    #[test]
    fn packbits_literals_repeats_and_no_ops_and_what_does_not_fit() {
        // 3 literals, a no-op, 4 repeats of 9, 1 literal; a pad byte after.
        let seg = [2, 1, 2, 3, 0x80, 0xFD, 9, 0, 7, 0];
        assert_eq!(unpack_bits(&seg, 8).unwrap(), [1, 2, 3, 9, 9, 9, 9, 7]);
        // One pixel more: the segment ends after 8 bytes, or its pad byte
        // reads as a literal header with nothing after it.
        assert!(unpack_bits(&seg[..9], 9).unwrap_err().contains("8 bytes"));
        assert!(unpack_bits(&seg, 9).unwrap_err().contains("cut off"));
        assert!(unpack_bits(&[5, 1, 2], 6).unwrap_err().contains("cut off"));
        assert!(unpack_bits(&[0xFD], 4).unwrap_err().contains("cut off"));
        // A run past the image is a mismatch, not a longer image.
        assert!(
            unpack_bits(&[0x81, 4], 3)
                .unwrap_err()
                .contains("128 bytes")
        );
    }

    #[test]
    fn rle_segments_combine_most_significant_first_and_a_bad_header_is_refused() {
        let mut d = vec![0u8; 64];
        d[0] = 2;
        d[4] = 64;
        d[8] = 66;
        d.extend_from_slice(&[0xFF, 0x12, 0x01, 0x34, 0x56]);
        assert_eq!(rle(&d, 2, 2).unwrap(), [0x1234, 0x1256]);
        assert!(rle(&d, 2, 1).unwrap_err().contains("2 segments"));
        d[8] = 200;
        assert!(rle(&d, 2, 2).unwrap_err().contains("corrupt"));
        assert!(rle(&d[..40], 2, 2).unwrap_err().contains("64-byte header"));
    }
}
