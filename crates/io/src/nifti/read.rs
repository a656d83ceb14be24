//! Reading: open and sniff, validate the header, walk the extensions, then
//! stream the voxel data into the preallocated output.

use std::fs::File;
use std::io::{self, BufReader, Read, Seek, SeekFrom};
use std::path::Path;

use flate2::bufread::MultiGzDecoder;

use super::header::{self, DataType, Endian, HDR2_SIZE, Header};
use super::{Element, NiftiRead, ReadOptions, as_bytes_mut};
use coapt_base::{Error, Result};
use coapt_geom::Volume;

/// Voxel bytes converted per step when the stored type differs from the
/// output type: large enough to amortise I/O calls, small enough for cache.
const CHUNK_BYTES: usize = 4 << 20;

/// The (decompressed) byte stream of a NIfTI file.
enum Source {
    Plain(File),
    Gzip(Box<MultiGzDecoder<BufReader<File>>>),
}

impl Read for Source {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match self {
            Source::Plain(f) => f.read(buf),
            Source::Gzip(g) => g.read(buf),
        }
    }
}

/// An open file positioned at its voxel data, with its validated header.
struct Opened {
    header: Header,
    src: Source,
    gzip: bool,
}

/// Read and validate the header (and extensions) only; no voxel allocation.
pub fn read_header(path: &Path) -> Result<Header> {
    read_header_with(path, &ReadOptions::default())
}

/// [`read_header`] with explicit limits.
pub fn read_header_with(path: &Path, opts: &ReadOptions) -> Result<Header> {
    open(path, opts).map(|o| o.header)
}

/// Read a volume as `T`, converting from any stored numeric type (scaled by
/// scl_slope / scl_inter). Integer targets need exact, in-range values.
pub fn read_with<T: NiftiRead>(path: &Path, opts: &ReadOptions) -> Result<Volume<T>> {
    let Opened {
        header: hdr,
        mut src,
        gzip,
    } = open(path, opts)?;
    // The header check covered the stored size; the output may be wider.
    let out_bytes = hdr
        .voxel_count()
        .checked_mul(std::mem::size_of::<T>() as u64);
    if out_bytes.is_none_or(|b| b > opts.max_bytes) {
        return Err(Error::bad_input(
            path,
            format!(
                "volume {}×{}×{} as {} would take {} bytes, above the limit of {} bytes; \
                 raise it with the environment variable {}=<bytes> if the volume is genuine",
                hdr.dims[0],
                hdr.dims[1],
                hdr.dims[2],
                T::DATATYPE.name(),
                hdr.voxel_count() as u128 * std::mem::size_of::<T>() as u128,
                opts.max_bytes,
                super::MAX_BYTES_ENV
            ),
        ));
    }
    let data = read_voxels::<T>(&mut src, &hdr, gzip, path)?;
    if gzip {
        // Reading on to the end makes flate2 verify the CRC and length of
        // every member, so silent corruption of the voxel data is caught.
        io::copy(&mut src, &mut io::sink()).map_err(|e| {
            Error::bad_input(
                path,
                format!(
                    "corrupt or truncated gzip stream after the voxel data (bad checksum or \
                     trailing garbage): {e}"
                ),
            )
        })?;
    }
    Volume::from_fortran_vec(hdr.dims, hdr.affine_lps, data).map_err(|e| e.in_file(path))
}

fn open(path: &Path, opts: &ReadOptions) -> Result<Opened> {
    let mut file = File::open(path).map_err(|e| Error::read(path, e))?;
    let file_len = file.metadata().map_err(|e| Error::read(path, e))?.len();
    if file_len == 0 {
        return Err(Error::bad_input(
            path,
            "empty file (0 bytes): not a NIfTI volume",
        ));
    }
    let mut magic = [0u8; 2];
    let n = read_full(&mut file, &mut magic).map_err(|e| Error::read(path, e))?;
    file.seek(SeekFrom::Start(0))
        .map_err(|e| Error::read(path, e))?;
    // The content decides, not the name: misnamed .nii/.nii.gz files are common.
    let gzip = n == 2 && magic == [0x1f, 0x8b];
    let mut src = if gzip {
        Source::Gzip(Box::new(MultiGzDecoder::new(BufReader::with_capacity(
            1 << 18,
            file,
        ))))
    } else {
        Source::Plain(file)
    };
    let header = match read_and_validate(&mut src, gzip, path, opts) {
        Ok(h) => h,
        Err(e) if gzip => return Err(blame_gzip_if_corrupt(&mut src, path, e)),
        Err(e) => return Err(e),
    };
    let plain_len = (!gzip).then_some(file_len);
    skip_extensions(&mut src, &header, gzip, plain_len, path)?;
    Ok(Opened { header, src, gzip })
}

/// A header that fails validation inside a gzip stream may be garbage from
/// a corrupt stream: if the stream fails its checksum, say that instead,
/// since fixing the header would be the wrong advice.
fn blame_gzip_if_corrupt(src: &mut Source, path: &Path, header_err: Error) -> Error {
    let Error::BadInput { problem, .. } = &header_err else {
        return header_err;
    };
    let problem = problem.clone();
    match io::copy(src, &mut io::sink()) {
        Err(e) => Error::bad_input(
            path,
            format!(
                "corrupt or truncated gzip stream ({e}); its header therefore reads as garbage: {problem}"
            ),
        ),
        Ok(_) => header_err,
    }
}

fn read_and_validate(
    src: &mut Source,
    gzip: bool,
    path: &Path,
    opts: &ReadOptions,
) -> Result<Header> {
    let mut buf = [0u8; HDR2_SIZE];
    let got =
        read_full(src, &mut buf[..4]).map_err(|e| stream_err(path, gzip, e, "in the header"))?;
    if got < 4 {
        return Err(too_short(path, got, 4, gzip));
    }
    let (version, endian) = header::detect(buf[..4].try_into().expect("4 bytes"))
        .map_err(|p| Error::bad_input(path, p))?;
    let size = if version == 1 {
        header::HDR1_SIZE
    } else {
        HDR2_SIZE
    };
    let got = 4 + read_full(src, &mut buf[4..size])
        .map_err(|e| stream_err(path, gzip, e, "in the header"))?;
    if got < size {
        return Err(too_short(path, got, size, gzip));
    }
    let raw = if version == 1 {
        header::parse_v1(&buf[..size], endian)
    } else {
        header::parse_v2(&buf[..size], endian)
    }
    .map_err(|p| Error::bad_input(path, p))?;
    header::validate(&raw, opts.max_bytes).map_err(|p| Error::bad_input(path, p))
}

fn too_short(path: &Path, got: usize, need: usize, gzip: bool) -> Error {
    let after = if gzip {
        " after gzip decompression"
    } else {
        ""
    };
    Error::bad_input(
        path,
        format!(
            "too short for a NIfTI header: {got} bytes{after}, a header needs {need}; not a NIfTI volume"
        ),
    )
}

/// Walk the extension list (bounds only; coapt uses no extension) and stop
/// at vox_offset. For plain files, also check the data is all there before
/// anything is allocated for it.
fn skip_extensions(
    src: &mut Source,
    hdr: &Header,
    gzip: bool,
    plain_len: Option<u64>,
    path: &Path,
) -> Result<()> {
    let bad = |p: String| Error::bad_input(path, p);
    let vox = hdr.vox_offset;
    if let Some(len) = plain_len {
        if vox > len {
            return Err(bad(format!(
                "vox_offset {vox} is beyond the end of the file ({len} bytes); the header is \
                 corrupt or the file truncated"
            )));
        }
        let found = len - vox;
        if found < hdr.data_bytes {
            return Err(bad(truncated_msg(hdr.data_bytes, found)));
        }
    }
    let mut pos = hdr.header_size as u64;
    let ioerr = |e| stream_err(path, gzip, e, "in the header extensions");
    if vox >= pos + 4 {
        let mut flag = [0u8; 4];
        expect_bytes(src, &mut flag, hdr, gzip, path)?;
        pos += 4;
        if flag[0] != 0 {
            while pos + 8 <= vox {
                let mut eh = [0u8; 8];
                expect_bytes(src, &mut eh, hdr, gzip, path)?;
                let mut esize: [u8; 4] = eh[..4].try_into().expect("4 bytes");
                if hdr.endian == Endian::Big {
                    esize.reverse();
                }
                let esize = i32::from_le_bytes(esize);
                if esize < 8 || pos + esize as u64 > vox {
                    return Err(bad(format!(
                        "header extension at byte {pos} has size {esize}, which runs past \
                         vox_offset {vox} (or is < 8); the header is corrupt"
                    )));
                }
                skip(src, esize as u64 - 8).map_err(ioerr)?;
                pos += esize as u64;
            }
        }
    }
    let rest = vox - pos.min(vox);
    if skip(src, rest).map_err(ioerr)? < rest {
        return Err(bad(format!(
            "the file ends inside the header or its extensions (before vox_offset {vox}); \
             it is truncated"
        )));
    }
    Ok(())
}

fn expect_bytes(
    src: &mut Source,
    buf: &mut [u8],
    hdr: &Header,
    gzip: bool,
    path: &Path,
) -> Result<()> {
    let got =
        read_full(src, buf).map_err(|e| stream_err(path, gzip, e, "in the header extensions"))?;
    if got < buf.len() {
        return Err(Error::bad_input(
            path,
            format!(
                "the file ends inside the header extensions (before vox_offset {}); it is truncated",
                hdr.vox_offset
            ),
        ));
    }
    Ok(())
}

fn skip(src: &mut Source, n: u64) -> io::Result<u64> {
    io::copy(&mut src.take(n), &mut io::sink())
}

fn truncated_msg(expected: u64, found: u64) -> String {
    format!(
        "truncated: expected {expected} bytes of voxel data, found {found}; the file is \
         incomplete (interrupted copy or download?), fetch it again"
    )
}

/// Read until `buf` is full or the stream ends; returns the bytes read.
pub(crate) fn read_full(r: &mut impl Read, buf: &mut [u8]) -> io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

/// A decoder error means bad content (bad input), anything else a failed read.
fn stream_err(path: &Path, gzip: bool, e: io::Error, where_: &str) -> Error {
    use io::ErrorKind::*;
    if gzip && matches!(e.kind(), InvalidInput | InvalidData | UnexpectedEof) {
        Error::bad_input(
            path,
            format!("corrupt or truncated gzip stream ({where_}): {e}"),
        )
    } else {
        Error::read(path, e)
    }
}

/// Fill `buf` with the next voxel bytes; `done` bytes were read before.
fn fill_voxels(
    src: &mut Source,
    buf: &mut [u8],
    done: u64,
    total: u64,
    gzip: bool,
    path: &Path,
) -> Result<()> {
    match read_full(src, buf) {
        Ok(n) if n == buf.len() => Ok(()),
        Ok(n) => {
            let msg = truncated_msg(total, done + n as u64);
            Err(Error::bad_input(
                path,
                if gzip {
                    format!("corrupt or truncated gzip stream: {msg}")
                } else {
                    msg
                },
            ))
        }
        Err(e) => {
            let where_ = format!("after {} of {total} bytes of voxel data", done);
            Err(stream_err(path, gzip, e, &where_))
        }
    }
}

fn read_voxels<T: NiftiRead>(
    src: &mut Source,
    hdr: &Header,
    gzip: bool,
    path: &Path,
) -> Result<Vec<T>> {
    let n = hdr.voxel_count() as usize;
    let total = hdr.data_bytes;
    let mut out = vec![T::default(); n];
    // Our own files store slope 1, intercept 0: that is no scaling at all.
    let scaling = hdr.scaling().filter(|&s| s != (1.0, 0.0));
    let native = if cfg!(target_endian = "little") {
        Endian::Little
    } else {
        Endian::Big
    };
    if hdr.datatype == T::DATATYPE && scaling.is_none() {
        // Stored type is the output type: decode straight into the output.
        fill_voxels(src, as_bytes_mut(&mut out), 0, total, gzip, path)?;
        if hdr.endian != native {
            out.iter_mut().for_each(|x| *x = Element::swap_bytes(*x));
        }
        return Ok(out);
    }
    let bpv = hdr.bytes_per_voxel;
    let per_chunk = (CHUNK_BYTES / bpv).max(1);
    let mut scratch = vec![0u8; per_chunk.min(n) * bpv];
    for (ci, dst) in out.chunks_mut(per_chunk).enumerate() {
        let raw = &mut scratch[..dst.len() * bpv];
        let done = (ci * per_chunk * bpv) as u64;
        fill_voxels(src, raw, done, total, gzip, path)?;
        convert(hdr.datatype, hdr.endian, raw, dst, scaling).map_err(|(k, v)| {
            value_error::<T>(hdr, ci * per_chunk + k, v, scaling.is_some(), path)
        })?;
    }
    Ok(out)
}

fn value_error<T: NiftiRead>(hdr: &Header, idx: usize, v: f64, scaled: bool, path: &Path) -> Error {
    let [ni, nj, _] = hdr.dims;
    let (i, j, k) = (idx % ni, (idx / ni) % nj, idx / (ni * nj));
    let what = if scaled {
        "after scl_slope/scl_inter scaling"
    } else {
        "as stored"
    };
    Error::bad_input(
        path,
        format!(
            "voxel [{i}, {j}, {k}] is {v} {what} ({} data), but reading as {} needs {}; \
             read the volume as float (read_f32) instead",
            hdr.datatype.name(),
            T::DATATYPE.name(),
            T::RANGE
        ),
    )
}

/// A stored voxel type, decoded from its bytes as f64 (exact for every
/// type but 64-bit integers beyond 2^53, which no CT holds).
trait Stored: Copy {
    const N: usize;
    fn get<const BIG: bool>(b: &[u8]) -> f64;
}

macro_rules! stored {
    ($($t:ty),*) => {$(
        impl Stored for $t {
            const N: usize = std::mem::size_of::<$t>();
            #[inline(always)]
            fn get<const BIG: bool>(b: &[u8]) -> f64 {
                let a = b[..Self::N].try_into().expect("chunk of N bytes");
                (if BIG { <$t>::from_be_bytes(a) } else { <$t>::from_le_bytes(a) }) as f64
            }
        }
    )*};
}
stored!(u8, i8, i16, u16, i32, u32, i64, u64, f32, f64);

/// Convert `raw` (stored bytes) into `out`; on failure, the offending voxel's
/// index within `out` and its value.
pub(crate) fn convert<T: NiftiRead>(
    dt: DataType,
    endian: Endian,
    raw: &[u8],
    out: &mut [T],
    scaling: Option<(f64, f64)>,
) -> std::result::Result<(), (usize, f64)> {
    macro_rules! go {
        ($s:ty) => {
            match endian {
                Endian::Little => convert_typed::<$s, T, false>(raw, out, scaling),
                Endian::Big => convert_typed::<$s, T, true>(raw, out, scaling),
            }
        };
    }
    match dt {
        DataType::U8 => go!(u8),
        DataType::I8 => go!(i8),
        DataType::I16 => go!(i16),
        DataType::U16 => go!(u16),
        DataType::I32 => go!(i32),
        DataType::U32 => go!(u32),
        DataType::I64 => go!(i64),
        DataType::U64 => go!(u64),
        DataType::F32 => go!(f32),
        DataType::F64 => go!(f64),
    }
}

/// The hot loop, monomorphised per (stored type, output type, byte order)
/// so it has no branch but the range check.
fn convert_typed<S: Stored, T: NiftiRead, const BIG: bool>(
    raw: &[u8],
    out: &mut [T],
    scaling: Option<(f64, f64)>,
) -> std::result::Result<(), (usize, f64)> {
    let pairs = raw.chunks_exact(S::N).zip(out.iter_mut()).enumerate();
    match scaling {
        None => {
            for (k, (b, o)) in pairs {
                let v = S::get::<BIG>(b);
                *o = T::from_f64(v).ok_or((k, v))?;
            }
        }
        Some((m, c)) => {
            for (k, (b, o)) in pairs {
                let v = S::get::<BIG>(b) * m + c;
                *o = T::from_f64(v).ok_or((k, v))?;
            }
        }
    }
    Ok(())
}
