//! Voxel data described by a text header (NRRD, MetaImage): where the bytes
//! are, how they are stored, and the checks every such format shares.
//!
//! A header parser produces a [`Layout`]; [`Layout::validate`] applies the
//! same rules as the NIfTI reader (sizes, byte limit, voxel spacing, a usable
//! affine) before anything is allocated; [`read`] then streams the bytes into
//! the output, refusing data that is shorter or longer than the header says:
//! a size or type mismatch would otherwise silently scramble the volume.

use std::fs::File;
use std::io::{self, BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use flate2::bufread::{MultiGzDecoder, ZlibDecoder};
use nalgebra::Matrix4;

use super::nifti::{
    DataType, Endian, MAX_AXIS, NiftiRead, ReadOptions, SPACING_MM, as_bytes_mut, decode_voxels,
    human_bytes, read_full,
};
use coapt_base::{Error, Result};
use coapt_geom::Volume;

/// Bytes converted per step when the stored type differs from the output.
const CHUNK_BYTES: usize = 4 << 20;

/// How the voxel bytes are encoded in their file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    Raw,
    /// gzip members (NRRD `encoding: gzip`).
    Gzip,
    /// A zlib stream (MetaImage `CompressedData = True`).
    Zlib,
}

impl Encoding {
    pub fn name(self) -> &'static str {
        match self {
            Encoding::Raw => "raw",
            Encoding::Gzip => "gzip",
            Encoding::Zlib => "zlib",
        }
    }
}

/// Where the voxel data starts in its file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Start {
    /// This many bytes into the file (into the decompressed stream for
    /// compressed data).
    At(u64),
    /// The data are the last bytes of the file (NRRD `byte skip: -1`,
    /// MetaImage `HeaderSize = -1`); raw encoding only.
    FromEnd,
}

/// Everything needed to read the voxels, as a header describes them.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// Name of the format, for messages and `coapt info` ("NRRD", "MetaImage").
    pub format: &'static str,
    pub dims: [usize; 3],
    pub datatype: DataType,
    pub endian: Endian,
    /// Voxel index → world LPS millimetres.
    pub affine_lps: Matrix4<f64>,
    /// The file's own world frame, as it names it ("RAS", "LPS", …).
    pub file_space: String,
    /// The file holding the voxels (the header itself when attached).
    pub data_file: PathBuf,
    pub start: Start,
    pub encoding: Encoding,
}

impl Layout {
    pub fn voxel_count(&self) -> u64 {
        self.dims.iter().map(|&d| d as u64).product()
    }

    /// Bytes of voxel data as stored (decompressed).
    pub fn data_bytes(&self) -> u64 {
        self.voxel_count() * self.datatype.bytes() as u64
    }

    /// Whether the voxels live in a file other than the header.
    pub fn detached(&self, header: &Path) -> bool {
        self.data_file != header
    }

    /// The NIfTI reader's rules: each axis 1..=MAX_AXIS voxels, stored data
    /// within `max_bytes`, spacing within [`SPACING_MM`], an invertible
    /// finite affine. Problems are returned as text; the caller names the file.
    pub fn validate(&self, max_bytes: u64) -> std::result::Result<(), String> {
        let [ni, nj, nk] = self.dims;
        if let Some(a) = (0..3).find(|&a| self.dims[a] < 1) {
            return Err(format!(
                "size along axis {} is 0 ({ni}×{nj}×{nk}); every size must be ≥ 1",
                a + 1
            ));
        }
        if let Some(a) = (0..3).find(|&a| self.dims[a] as u64 > MAX_AXIS) {
            return Err(format!(
                "the volume {ni}×{nj}×{nk} claims {} voxels along axis {}, more than the \
                 {MAX_AXIS} a real scan can have: the header is corrupt",
                self.dims[a],
                a + 1
            ));
        }
        let bytes = self.data_bytes();
        if bytes > max_bytes {
            return Err(format!(
                "volume {ni}×{nj}×{nk} {} needs {bytes} bytes ({}) of voxel data, above the \
                 limit of {max_bytes} bytes ({}); if the volume is genuine, raise the limit \
                 with the environment variable {}=<bytes>",
                self.datatype.name(),
                human_bytes(bytes as u128),
                human_bytes(max_bytes as u128),
                super::nifti::MAX_BYTES_ENV
            ));
        }
        coapt_geom::volume::check_affine(&self.affine_lps)
            .map_err(|e| format!("{e}; fix the header's orientation and spacing"))?;
        for c in 0..3 {
            let d = self.affine_lps.fixed_view::<3, 1>(0, c).norm();
            if !(SPACING_MM.0..=SPACING_MM.1).contains(&d) {
                return Err(format!(
                    "voxel spacing along axis {} is {d:e} mm; a CT's lies in {}–{} mm: fix the \
                     header's spacing or its units",
                    c + 1,
                    SPACING_MM.0,
                    SPACING_MM.1
                ));
            }
        }
        if self.encoding != Encoding::Raw && self.start == Start::FromEnd {
            return Err(format!(
                "data at the end of the file (skip -1) is only possible for raw data, not {}",
                self.encoding.name()
            ));
        }
        Ok(())
    }
}

/// The decompressed byte stream of the data file.
enum Source {
    Plain(File),
    Gzip(Box<MultiGzDecoder<BufReader<File>>>),
    Zlib(Box<ZlibDecoder<BufReader<File>>>),
}

impl Read for Source {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match self {
            Source::Plain(f) => f.read(buf),
            Source::Gzip(g) => g.read(buf),
            Source::Zlib(z) => z.read(buf),
        }
    }
}

/// Read the voxels `layout` describes as `T`, `header` being the file the
/// user named. `layout` must have passed [`Layout::validate`].
pub fn read<T: NiftiRead>(header: &Path, layout: &Layout, opts: &ReadOptions) -> Result<Volume<T>> {
    let data_path = &layout.data_file;
    let bad = |p: String| data_error(header, layout, p);
    let n = layout.voxel_count();
    let out_bytes = n.checked_mul(std::mem::size_of::<T>() as u64);
    if out_bytes.is_none_or(|b| b > opts.max_bytes) {
        let [ni, nj, nk] = layout.dims;
        return Err(Error::bad_input(
            header,
            format!(
                "volume {ni}×{nj}×{nk} as {} would take {} bytes, above the limit of {} bytes; \
                 raise it with the environment variable {}=<bytes> if the volume is genuine",
                T::DATATYPE.name(),
                n as u128 * std::mem::size_of::<T>() as u128,
                opts.max_bytes,
                super::nifti::MAX_BYTES_ENV
            ),
        ));
    }
    let mut file = open_data(header, layout)?;
    let len = file
        .metadata()
        .map_err(|e| Error::read(data_path, e))?
        .len();
    let mut src = match layout.encoding {
        Encoding::Raw => {
            let start = raw_start(header, layout, len)?;
            file.seek(SeekFrom::Start(start))
                .map_err(|e| Error::read(data_path, e))?;
            Source::Plain(file)
        }
        enc => {
            let Start::At(start) = layout.start else {
                return Err(bad(format!(
                    "data at the end of the file (skip -1) is only possible for raw data, not {}",
                    enc.name()
                )));
            };
            // Attached data: the compressed stream begins after the header.
            let header_end = if layout.detached(header) { 0 } else { start };
            file.seek(SeekFrom::Start(header_end))
                .map_err(|e| Error::read(data_path, e))?;
            let mut buf = BufReader::with_capacity(1 << 18, file);
            // MetaIO inflates zlib and gzip streams alike; so does coapt.
            let gzip_magic = io::BufRead::fill_buf(&mut buf)
                .map_err(|e| Error::read(data_path, e))?
                .starts_with(&[0x1f, 0x8b]);
            let mut s = if enc == Encoding::Gzip || gzip_magic {
                Source::Gzip(Box::new(MultiGzDecoder::new(buf)))
            } else {
                Source::Zlib(Box::new(ZlibDecoder::new(buf)))
            };
            // A detached compressed file's skip counts decompressed bytes.
            if layout.detached(header) && start > 0 {
                let skipped = io::copy(&mut (&mut s).take(start), &mut io::sink())
                    .map_err(|e| stream_err(&bad, enc, e))?;
                if skipped < start {
                    return Err(bad(format!(
                        "the decompressed data ends before the {start} bytes the header says \
                         to skip"
                    )));
                }
            }
            s
        }
    };
    let total = layout.data_bytes();
    let data = read_values::<T>(&mut src, layout, &bad)?;
    if layout.encoding != Encoding::Raw {
        // More decompressed data than the header accounts for means the
        // header does not describe it; reading on to the end also makes the
        // decoder verify the stream's checksum.
        let mut probe = [0u8; 1];
        let extra =
            read_full(&mut src, &mut probe).map_err(|e| stream_err(&bad, layout.encoding, e))?;
        if extra > 0 {
            return Err(bad(format!(
                "the decompressed data is longer than the {total} bytes the header's sizes and \
                 type ({}×{}×{} {}) need: the header does not describe this data",
                layout.dims[0],
                layout.dims[1],
                layout.dims[2],
                layout.datatype.name()
            )));
        }
    }
    Volume::from_fortran_vec(layout.dims, layout.affine_lps, data).map_err(|e| e.in_file(header))
}

/// An error about the voxel data: a separate data file is named, and
/// whose data it is.
fn data_error(header: &Path, layout: &Layout, problem: String) -> Error {
    if layout.detached(header) {
        Error::bad_input(
            &layout.data_file,
            format!("{problem} (voxel data of {})", header.display()),
        )
    } else {
        Error::bad_input(header, problem)
    }
}

fn open_data(header: &Path, layout: &Layout) -> Result<File> {
    File::open(&layout.data_file).map_err(|e| {
        if layout.detached(header) && e.kind() == io::ErrorKind::NotFound {
            Error::bad_input(
                header,
                format!(
                    "its voxel data file {} does not exist; keep the header and its data file \
                     together",
                    layout.data_file.display()
                ),
            )
        } else {
            Error::read(&layout.data_file, e)
        }
    })
}

/// Where raw voxel data start in a file of `len` bytes. The size is known
/// before anything is allocated: short data is a truncated file, long data
/// a header whose sizes or type do not match the data.
fn raw_start(header: &Path, layout: &Layout, len: u64) -> Result<u64> {
    let total = layout.data_bytes();
    let start = match layout.start {
        Start::At(s) => s,
        Start::FromEnd => len.saturating_sub(total),
    };
    let found = len.saturating_sub(start);
    if start > len || found < total {
        return Err(data_error(header, layout, truncated_msg(total, found)));
    }
    if found > total {
        return Err(data_error(
            header,
            layout,
            format!(
                "holds {found} bytes of voxel data where the header's sizes and type \
                 ({}×{}×{} {}) need {total}: the header does not describe this data",
                layout.dims[0],
                layout.dims[1],
                layout.dims[2],
                layout.datatype.name()
            ),
        ));
    }
    Ok(start)
}

/// The data file exists and, for raw data, holds exactly the voxel bytes
/// (compressed data can only be checked by decompressing it all).
pub fn check_data(header: &Path, layout: &Layout) -> Result<()> {
    let file = open_data(header, layout)?;
    if layout.encoding == Encoding::Raw {
        let len = file
            .metadata()
            .map_err(|e| Error::read(&layout.data_file, e))?
            .len();
        raw_start(header, layout, len)?;
    }
    Ok(())
}

fn truncated_msg(expected: u64, found: u64) -> String {
    format!(
        "truncated: expected {expected} bytes of voxel data, found {found}; the file is \
         incomplete (interrupted copy or download?), fetch it again"
    )
}

/// A decoder error means bad content (bad input).
fn stream_err(bad: &impl Fn(String) -> Error, enc: Encoding, e: io::Error) -> Error {
    bad(format!("corrupt or truncated {} stream: {e}", enc.name()))
}

fn read_values<T: NiftiRead>(
    src: &mut Source,
    layout: &Layout,
    bad: &impl Fn(String) -> Error,
) -> Result<Vec<T>> {
    let n = layout.voxel_count() as usize;
    let total = layout.data_bytes();
    let mut out = vec![T::default(); n];
    let fill = |src: &mut Source, buf: &mut [u8], done: u64| -> Result<()> {
        match read_full(src, buf) {
            Ok(k) if k == buf.len() => Ok(()),
            Ok(k) if layout.encoding == Encoding::Raw => {
                Err(bad(truncated_msg(total, done + k as u64)))
            }
            Ok(k) => Err(bad(format!(
                "corrupt or truncated {} stream: {}",
                layout.encoding.name(),
                truncated_msg(total, done + k as u64)
            ))),
            Err(e) => Err(stream_err(bad, layout.encoding, e)),
        }
    };
    let native = if cfg!(target_endian = "little") {
        Endian::Little
    } else {
        Endian::Big
    };
    if layout.datatype == T::DATATYPE {
        // Stored type is the output type: decode straight into the output.
        fill(src, as_bytes_mut(&mut out), 0)?;
        if layout.endian != native {
            out.iter_mut()
                .for_each(|x| *x = super::nifti::Element::swap_bytes(*x));
        }
        return Ok(out);
    }
    let bpv = layout.datatype.bytes();
    let per_chunk = (CHUNK_BYTES / bpv).max(1);
    let mut scratch = vec![0u8; per_chunk.min(n) * bpv];
    for (ci, dst) in out.chunks_mut(per_chunk).enumerate() {
        let raw = &mut scratch[..dst.len() * bpv];
        fill(src, raw, (ci * per_chunk * bpv) as u64)?;
        decode_voxels(layout.datatype, layout.endian, raw, dst, None).map_err(|(k, v)| {
            let idx = ci * per_chunk + k;
            let [ni, nj, _] = layout.dims;
            bad(format!(
                "voxel [{}, {}, {}] is {v} ({} data), but reading as {} needs {}",
                idx % ni,
                (idx / ni) % nj,
                idx / (ni * nj),
                layout.datatype.name(),
                T::DATATYPE.name(),
                T::RANGE
            ))
        })?;
    }
    Ok(out)
}

/// The text lines of a header that ends at the line `last` accepts (or at
/// an empty line when `blank_ends` is set), and the byte offset just past it.
/// Reads at most [`MAX_HEADER_BYTES`], so a binary file mistaken for a header
/// costs nothing.
pub fn header_lines(
    path: &Path,
    blank_ends: bool,
    last: impl Fn(&str) -> bool,
) -> Result<(Vec<String>, u64)> {
    let file = File::open(path).map_err(|e| Error::read(path, e))?;
    let mut r = BufReader::new(file).take(MAX_HEADER_BYTES);
    let mut lines = Vec::new();
    let mut offset = 0u64;
    let mut buf = Vec::new();
    loop {
        buf.clear();
        let k =
            io::BufRead::read_until(&mut r, b'\n', &mut buf).map_err(|e| Error::read(path, e))?;
        if k == 0 {
            // End of file (or of the limit) without a terminator.
            if offset >= MAX_HEADER_BYTES {
                return Err(Error::bad_input(
                    path,
                    format!(
                        "no end of the header within its first {MAX_HEADER_BYTES} bytes: \
                         corrupt, or not a text header"
                    ),
                ));
            }
            return Ok((lines, offset));
        }
        offset += k as u64;
        let text = std::str::from_utf8(&buf).map_err(|_| {
            Error::bad_input(
                path,
                format!(
                    "header line {} is not text (UTF-8); the header is corrupt or the file is \
                     not what its name says",
                    lines.len() + 1
                ),
            )
        })?;
        let line = text.trim_end_matches(['\n', '\r']).to_string();
        if blank_ends && line.is_empty() {
            return Ok((lines, offset));
        }
        let done = last(&line);
        lines.push(line);
        if done {
            return Ok((lines, offset));
        }
    }
}

/// Header text larger than this is not a header.
pub const MAX_HEADER_BYTES: u64 = 1 << 20;

/// A detached data file named `name` by the header's `key` (NRRD's `data
/// file`, MetaImage's `ElementDataFile`), its data `skip` bytes in (-1: the
/// last bytes of the file). A list or pattern of files (one per slice) is
/// refused: coapt reads a volume stored in one file.
pub fn detached(
    header: &Path,
    key: &str,
    name: &str,
    skip: i64,
) -> std::result::Result<(PathBuf, Start), String> {
    if name.starts_with("LIST") || name.contains('%') || name.split_whitespace().count() > 1 {
        return Err(format!(
            "{key} \"{name}\" names several files (one per slice); coapt reads a volume stored \
             in one file"
        ));
    }
    let start = if skip == -1 {
        Start::FromEnd
    } else {
        Start::At(skip as u64)
    };
    Ok((beside(header, name), start))
}

/// `name` resolved beside the header (data file names are relative to it).
pub fn beside(header: &Path, name: &str) -> PathBuf {
    let p = Path::new(name);
    if p.is_absolute() {
        p.to_path_buf()
    } else {
        header.parent().unwrap_or(Path::new("")).join(p)
    }
}
