//! Writing: little-endian NIfTI-1, one transform stored as both sform and
//! qform, optionally gzipped, deterministic byte for byte.

use std::io::{self, Write};
use std::path::Path;

use std::borrow::Cow;

use flate2::{Compress, Compression, Crc, FlushCompress, Status};
use nalgebra::{Matrix4, Vector4};
use rayon::prelude::*;

use super::header::HDR1_SIZE;
use super::transform::qform_from_affine;
use super::{Element, NiftiWrite, as_bytes};
use crate::write_atomic;
use coapt_base::Result;
use coapt_geom::Volume;

/// gzip level for .nii.gz. Measured on a noisy 512×512×300 int16 CT
/// (157 MB): level 1 gives 60 % of the raw size at ~100 MB/s per core,
/// level 2 57 % at 41 MB/s, 3 54 % at 22 MB/s, 6 54 % at 6 MB/s: beyond 1 the
/// few per cent saved cost several times the time.
pub const GZIP_LEVEL: u32 = 1;

/// Header (348 bytes) + 4-byte empty extension flag.
const VOX_OFFSET: usize = HDR1_SIZE + 4;

/// NIfTI-1 stores dimensions as int16.
const MAX_DIM_V1: usize = i16::MAX as usize;

/// Write `vol` atomically; gzip iff the file name ends in `.gz`.
pub fn write<T: NiftiWrite>(path: &Path, vol: &Volume<T>) -> Result<()> {
    let gzip = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("gz"));
    write_atomic(path, |w| encode(w, vol, gzip))
}

/// Encode `vol` as a complete NIfTI-1 file into `w` (for multi-file
/// [`crate::Transaction`]s).
pub fn encode<T: NiftiWrite>(w: &mut impl Write, vol: &Volume<T>, gzip: bool) -> io::Result<()> {
    encode_level(w, vol, gzip.then_some(GZIP_LEVEL))
}

/// [`encode`] with an explicit gzip level (`None`: uncompressed).
pub(super) fn encode_level<T: NiftiWrite>(
    w: &mut impl Write,
    vol: &Volume<T>,
    level: Option<u32>,
) -> io::Result<()> {
    let hdr = header_bytes(vol)?;
    let data = le_bytes(vol.as_slice());
    match level {
        Some(l) => write_gzip(w, &[&hdr, &data], l, GZ_BLOCK),
        None => {
            w.write_all(&hdr)?;
            w.write_all(&data)
        }
    }
}

/// The voxels as little-endian bytes (borrowed on little-endian hosts).
pub(super) fn le_bytes<T: Element>(data: &[T]) -> Cow<'_, [u8]> {
    if cfg!(target_endian = "little") {
        Cow::Borrowed(as_bytes(data))
    } else {
        let swapped: Vec<T> = data.iter().map(|x| x.swap_bytes()).collect();
        Cow::Owned(as_bytes(&swapped).to_vec())
    }
}

/// Uncompressed bytes per independently deflated block.
const GZ_BLOCK: usize = 4 << 20;

/// One gzip member whose deflate stream is made of blocks compressed in
/// parallel, each ended by a sync flush (as pigz does), so any gzip reader
/// sees one ordinary stream. Block boundaries depend only on the input, so
/// the bytes are the same whatever the number of threads.
pub(super) fn write_gzip(
    w: &mut impl Write,
    parts: &[&[u8]],
    level: u32,
    block: usize,
) -> io::Result<()> {
    let blocks: Vec<&[u8]> = parts
        .iter()
        .flat_map(|p| p.chunks(block))
        .filter(|b| !b.is_empty())
        .collect();
    let total: u64 = parts.iter().map(|p| p.len() as u64).sum();
    // Fixed gzip header: no name, mtime 0, OS unknown, XFL as flate2 sets it.
    let xfl = if level >= 9 {
        2
    } else if level <= 1 {
        4
    } else {
        0
    };
    w.write_all(&[0x1f, 0x8b, 8, 0, 0, 0, 0, 0, xfl, 255])?;
    let mut crc = Crc::new();
    let last = blocks.len().saturating_sub(1);
    // Bounded batches keep at most a few compressed blocks in memory.
    let batch = 2 * rayon::current_num_threads().max(1);
    for (bi, group) in blocks.chunks(batch).enumerate() {
        let done: Vec<io::Result<(Vec<u8>, Crc)>> = group
            .par_iter()
            .enumerate()
            .map(|(k, b)| {
                let mut c = Crc::new();
                c.update(b);
                Ok((deflate_block(b, level, bi * batch + k == last)?, c))
            })
            .collect();
        for r in done {
            let (z, c) = r?;
            w.write_all(&z)?;
            crc.combine(&c);
        }
    }
    if blocks.is_empty() {
        w.write_all(&deflate_block(&[], level, true)?)?;
    }
    w.write_all(&crc.sum().to_le_bytes())?;
    w.write_all(&(total as u32).to_le_bytes()) // ISIZE is the length mod 2^32
}

/// Raw deflate of one block: sync-flushed (byte-aligned, not final) unless
/// it is the last block of the stream.
fn deflate_block(input: &[u8], level: u32, last: bool) -> io::Result<Vec<u8>> {
    let mut c = Compress::new(Compression::new(level), false);
    let flush = if last {
        FlushCompress::Finish
    } else {
        FlushCompress::Sync
    };
    let mut out = Vec::with_capacity(input.len() + input.len() / 8 + 64);
    loop {
        let used = c.total_in() as usize;
        let status = c
            .compress_vec(&input[used..], &mut out, flush)
            .map_err(io::Error::other)?;
        let finished = if last {
            status == Status::StreamEnd
        } else {
            c.total_in() as usize == input.len() && out.len() < out.capacity()
        };
        if finished {
            return Ok(out);
        }
        out.reserve(out.capacity().max(4096));
    }
}

/// The 352 bytes before the voxel data.
pub(super) fn header_bytes<T: Element>(vol: &Volume<T>) -> io::Result<Vec<u8>> {
    let d = vol.dims();
    if let Some(&big) = d.iter().find(|&&n| n > MAX_DIM_V1) {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "dimension {big} exceeds NIfTI-1's limit of {MAX_DIM_V1} voxels per axis; crop or \
                 resample the volume"
            ),
        ));
    }
    let flip = Matrix4::from_diagonal(&Vector4::new(-1.0, -1.0, 1.0, 1.0));
    let ras = flip * vol.affine();
    let q = qform_from_affine(&ras);
    let dt = T::DATATYPE;

    let mut h = vec![0u8; VOX_OFFSET];
    let mut put = |off: usize, bytes: &[u8]| h[off..off + bytes.len()].copy_from_slice(bytes);
    put(0, &(HDR1_SIZE as i32).to_le_bytes());
    let dim = [3, d[0], d[1], d[2], 1, 1, 1, 1];
    for (i, &n) in dim.iter().enumerate() {
        put(40 + 2 * i, &(n as i16).to_le_bytes());
    }
    put(70, &dt.code().to_le_bytes());
    put(72, &(8 * dt.bytes() as i16).to_le_bytes());
    let pixdim = [
        q.qfac,
        q.spacing[0],
        q.spacing[1],
        q.spacing[2],
        1.0,
        1.0,
        1.0,
        1.0,
    ];
    for (i, p) in pixdim.iter().enumerate() {
        put(76 + 4 * i, &p.to_le_bytes());
    }
    put(108, &(VOX_OFFSET as f32).to_le_bytes());
    put(112, &1f32.to_le_bytes()); // scl_slope
    put(116, &0f32.to_le_bytes()); // scl_inter
    put(123, &[2]); // xyzt_units: millimetres
    let descrip = format!("coapt {}", env!("CARGO_PKG_VERSION"));
    put(148, &descrip.as_bytes()[..descrip.len().min(79)]);
    put(252, &1i16.to_le_bytes()); // qform_code: scanner anatomical
    put(254, &1i16.to_le_bytes()); // sform_code: scanner anatomical
    for i in 0..3 {
        put(256 + 4 * i, &q.quatern[i].to_le_bytes());
        put(268 + 4 * i, &q.offset[i].to_le_bytes());
    }
    for r in 0..3 {
        for c in 0..4 {
            put(280 + 16 * r + 4 * c, &(ras[(r, c)] as f32).to_le_bytes());
        }
    }
    put(344, b"n+1\0");
    Ok(h)
}
