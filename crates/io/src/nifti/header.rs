//! NIfTI-1 / NIfTI-2 header parsing and validation.
//!
//! Parsing turns the on-disk bytes (either version, either byte order) into a
//! version-neutral [`RawHeader`]; validation turns that into a [`Header`] whose
//! every field is usable as is. Nothing here allocates in proportion to what
//! the header claims, so a hostile header costs nothing.

use nalgebra::Matrix4;

use super::transform;

/// Bytes of a NIfTI-1 header; the 4-byte extension flag follows.
pub const HDR1_SIZE: usize = 348;
/// Bytes of a NIfTI-2 header; the 4-byte extension flag follows.
pub const HDR2_SIZE: usize = 540;
/// Larger axes are not a CT or a mask: the header is corrupt.
pub const MAX_AXIS: u64 = 100_000;

/// Stored voxel type (the numeric NIfTI datatypes coapt reads).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DataType {
    U8,
    I8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

impl DataType {
    pub fn from_code(code: i16) -> Option<Self> {
        Some(match code {
            2 => Self::U8,
            256 => Self::I8,
            4 => Self::I16,
            512 => Self::U16,
            8 => Self::I32,
            768 => Self::U32,
            1024 => Self::I64,
            1280 => Self::U64,
            16 => Self::F32,
            64 => Self::F64,
            _ => return None,
        })
    }

    pub fn code(self) -> i16 {
        match self {
            Self::U8 => 2,
            Self::I8 => 256,
            Self::I16 => 4,
            Self::U16 => 512,
            Self::I32 => 8,
            Self::U32 => 768,
            Self::I64 => 1024,
            Self::U64 => 1280,
            Self::F32 => 16,
            Self::F64 => 64,
        }
    }

    pub fn bytes(self) -> usize {
        match self {
            Self::U8 | Self::I8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::I64 | Self::U64 | Self::F64 => 8,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Self::U8 => "uint8",
            Self::I8 => "int8",
            Self::I16 => "int16",
            Self::U16 => "uint16",
            Self::I32 => "int32",
            Self::U32 => "uint32",
            Self::I64 => "int64",
            Self::U64 => "uint64",
            Self::F32 => "float32",
            Self::F64 => "float64",
        }
    }
}

/// Names of the NIfTI datatypes that exist but are not scalar reals.
fn unsupported_datatype(code: i16) -> Option<&'static str> {
    Some(match code {
        1 => "binary (1 bit)",
        32 => "complex64",
        128 => "RGB24",
        1536 => "float128",
        1792 => "complex128",
        2048 => "complex256",
        2304 => "RGBA32",
        _ => return None,
    })
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Endian {
    Little,
    Big,
}

/// Which header fields the voxel→world affine came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TransformSource {
    Sform,
    Qform,
    Pixdim,
}

impl TransformSource {
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Sform => "sform",
            Self::Qform => "qform",
            Self::Pixdim => "pixdim",
        }
    }
}

impl std::fmt::Display for TransformSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A validated header: every field can be used without further checks.
#[derive(Debug, Clone, PartialEq)]
pub struct Header {
    /// 1 or 2.
    pub version: u8,
    pub endian: Endian,
    /// Voxels along i, j, k (trailing singleton dimensions folded away).
    pub dims: [usize; 3],
    pub datatype: DataType,
    pub bytes_per_voxel: usize,
    /// `None` when the file says "no scaling" (scl_slope 0 or NaN).
    pub scl_slope: Option<f64>,
    /// `None` when there is no scaling or the intercept is 0 / NaN.
    pub scl_inter: Option<f64>,
    /// Voxel index → world LPS millimetres.
    pub affine_lps: Matrix4<f64>,
    pub transform_source: TransformSource,
    pub sform_code: i32,
    pub qform_code: i32,
    /// pixdim[0..8] as stored (spacing in the file's spatial unit).
    pub pixdim: [f64; 8],
    /// Millimetres per stored spatial unit (xyzt_units: m, mm, µm; 1 if unknown).
    pub unit_to_mm: f64,
    pub description: String,
    /// Byte offset of the voxel data in the (decompressed) stream.
    pub vox_offset: u64,
    /// Bytes of voxel data: dims × bytes_per_voxel.
    pub data_bytes: u64,
    /// Header size (348 or 540); the extension flag follows it.
    pub header_size: usize,
}

impl Header {
    pub fn voxel_count(&self) -> u64 {
        self.dims.iter().map(|&d| d as u64).product()
    }

    /// `(slope, intercept)` to apply, if any.
    pub fn scaling(&self) -> Option<(f64, f64)> {
        self.scl_slope.map(|s| (s, self.scl_inter.unwrap_or(0.0)))
    }
}

/// Version-neutral header fields, as stored (no validation yet).
#[derive(Debug, Clone)]
pub struct RawHeader {
    pub version: u8,
    pub endian: Endian,
    pub dim: [i64; 8],
    pub datatype: i16,
    pub bitpix: i16,
    pub pixdim: [f64; 8],
    pub vox_offset: f64,
    pub scl_slope: f64,
    pub scl_inter: f64,
    pub xyzt_units: i32,
    pub descrip: String,
    pub qform_code: i32,
    pub sform_code: i32,
    pub quatern: [f64; 3],
    pub qoffset: [f64; 3],
    pub srow: [[f64; 4]; 3],
}

/// Little/big-endian field access into a header buffer.
struct Fields<'a> {
    b: &'a [u8],
    big: bool,
}

impl Fields<'_> {
    fn arr<const N: usize>(&self, off: usize) -> [u8; N] {
        let mut a: [u8; N] = self.b[off..off + N].try_into().expect("in bounds");
        if self.big {
            a.reverse();
        }
        a
    }
    fn i16(&self, off: usize) -> i16 {
        i16::from_le_bytes(self.arr(off))
    }
    fn i32(&self, off: usize) -> i32 {
        i32::from_le_bytes(self.arr(off))
    }
    fn i64(&self, off: usize) -> i64 {
        i64::from_le_bytes(self.arr(off))
    }
    fn f32(&self, off: usize) -> f64 {
        f32::from_le_bytes(self.arr(off)) as f64
    }
    fn f64(&self, off: usize) -> f64 {
        f64::from_le_bytes(self.arr(off))
    }
    fn text(&self, off: usize, len: usize) -> String {
        let s = &self.b[off..off + len];
        let end = s.iter().position(|&c| c == 0).unwrap_or(len);
        String::from_utf8_lossy(&s[..end]).trim_end().to_string()
    }
}

/// Decide version and byte order from the first four bytes (sizeof_hdr).
pub fn detect(first4: [u8; 4]) -> Result<(u8, Endian), String> {
    match (i32::from_le_bytes(first4), i32::from_be_bytes(first4)) {
        (348, _) => Ok((1, Endian::Little)),
        (_, 348) => Ok((1, Endian::Big)),
        (540, _) => Ok((2, Endian::Little)),
        (_, 540) => Ok((2, Endian::Big)),
        (le, _) => Err(format!(
            "not a NIfTI file: sizeof_hdr is {le} (bytes {first4:02x?}), expected 348 (NIfTI-1) \
             or 540 (NIfTI-2); coapt needs a single-file .nii or .nii.gz volume"
        )),
    }
}

fn show_magic(m: &[u8]) -> String {
    m.iter()
        .map(|b| std::ascii::escape_default(*b).to_string())
        .collect()
}

const PAIR_ADVICE: &str = "coapt needs a single-file .nii or .nii.gz; convert it, \
    e.g. with nibabel (nib.save(nib.load('x.hdr'), 'x.nii.gz')) or `fslchfiletype NIFTI_GZ x`";

/// Parse a 348-byte NIfTI-1 header.
pub fn parse_v1(b: &[u8], endian: Endian) -> Result<RawHeader, String> {
    let f = Fields {
        b,
        big: endian == Endian::Big,
    };
    let magic = &b[344..348];
    match magic {
        b"n+1\0" => {}
        b"ni1\0" => {
            return Err(format!(
                "this is the header of a NIfTI-1 .hdr/.img pair (magic \"ni1\"); {PAIR_ADVICE}"
            ));
        }
        [0, 0, 0, 0] => {
            return Err(format!(
                "this is an Analyze 7.5 header (no NIfTI magic), which has no reliable \
                 orientation; {PAIR_ADVICE}"
            ));
        }
        _ => {
            return Err(format!(
                "wrong magic \"{}\" at byte 344 (expected \"n+1\\0\"): not a NIfTI-1 file \
                 or a corrupt header",
                show_magic(magic)
            ));
        }
    }
    let mut dim = [0i64; 8];
    let mut pixdim = [0f64; 8];
    for i in 0..8 {
        dim[i] = f.i16(40 + 2 * i) as i64;
        pixdim[i] = f.f32(76 + 4 * i);
    }
    let mut srow = [[0f64; 4]; 3];
    for (r, row) in srow.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            *v = f.f32(280 + 16 * r + 4 * c);
        }
    }
    Ok(RawHeader {
        version: 1,
        endian,
        dim,
        datatype: f.i16(70),
        bitpix: f.i16(72),
        pixdim,
        vox_offset: f.f32(108),
        scl_slope: f.f32(112),
        scl_inter: f.f32(116),
        xyzt_units: b[123] as i32,
        descrip: f.text(148, 80),
        qform_code: f.i16(252) as i32,
        sform_code: f.i16(254) as i32,
        quatern: [f.f32(256), f.f32(260), f.f32(264)],
        qoffset: [f.f32(268), f.f32(272), f.f32(276)],
        srow,
    })
}

/// Parse a 540-byte NIfTI-2 header.
pub fn parse_v2(b: &[u8], endian: Endian) -> Result<RawHeader, String> {
    let f = Fields {
        b,
        big: endian == Endian::Big,
    };
    let magic = &b[4..12];
    if magic != b"n+2\0\r\n\x1a\n" {
        return Err(if magic.starts_with(b"ni2\0") {
            format!("this is the header of a NIfTI-2 .hdr/.img pair (magic \"ni2\"); {PAIR_ADVICE}")
        } else if magic.starts_with(b"n+2\0") {
            "NIfTI-2 magic is damaged after \"n+2\" (the file was probably transferred in text \
             mode, which rewrites line endings); copy it again in binary mode"
                .to_string()
        } else {
            format!(
                "wrong magic \"{}\" at byte 4 (expected \"n+2\\0\\r\\n\\x1a\\n\"): not a NIfTI-2 \
                 file or a corrupt header",
                show_magic(magic)
            )
        });
    }
    let mut dim = [0i64; 8];
    let mut pixdim = [0f64; 8];
    for i in 0..8 {
        dim[i] = f.i64(16 + 8 * i);
        pixdim[i] = f.f64(104 + 8 * i);
    }
    let mut srow = [[0f64; 4]; 3];
    for (r, row) in srow.iter_mut().enumerate() {
        for (c, v) in row.iter_mut().enumerate() {
            *v = f.f64(400 + 32 * r + 8 * c);
        }
    }
    let vox = f.i64(168);
    Ok(RawHeader {
        version: 2,
        endian,
        dim,
        datatype: f.i16(12),
        bitpix: f.i16(14),
        pixdim,
        // i64 → f64 is exact for any offset a real file can have; validation
        // refuses the rest via the file-size and integrality checks.
        vox_offset: vox as f64,
        scl_slope: f.f64(176),
        scl_inter: f.f64(184),
        xyzt_units: f.i32(500),
        descrip: f.text(240, 80),
        qform_code: f.i32(344),
        sform_code: f.i32(348),
        quatern: [f.f64(352), f.f64(360), f.f64(368)],
        qoffset: [f.f64(376), f.f64(384), f.f64(392)],
        srow,
    })
}

/// Human-readable byte count ("150.0 MiB").
pub fn human_bytes(n: u128) -> String {
    const UNITS: [&str; 7] = ["bytes", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    let mut v = n as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{n} bytes")
    } else {
        format!("{v:.1} {}", UNITS[u])
    }
}

fn shape_string(d: &[i64]) -> String {
    d.iter()
        .map(|x| x.to_string())
        .collect::<Vec<_>>()
        .join("×")
}

/// Validate everything the header claims; `max_bytes` bounds the voxel data.
pub fn validate(raw: &RawHeader, max_bytes: u64) -> Result<Header, String> {
    let dims = validate_dims(raw)?;
    let datatype = validate_datatype(raw)?;
    check_size(dims, datatype, max_bytes)?;
    let (scl_slope, scl_inter) = validate_scaling(raw)?;
    for (i, &p) in raw.pixdim.iter().enumerate().take(4).skip(1) {
        if !p.is_finite() {
            return Err(format!(
                "pixdim[{i}] (voxel spacing) is {p}; it must be a finite number of millimetres, \
                 fix the header"
            ));
        }
    }
    let unit_to_mm = match raw.xyzt_units & 0x07 {
        1 => 1000.0, // metres
        3 => 1e-3,   // micrometres
        _ => 1.0,    // millimetres, or unknown (read as mm, like ITK and nibabel)
    };
    let (affine_ras, transform_source) = transform::affine_ras(raw, unit_to_mm)?;
    let flip = Matrix4::from_diagonal(&nalgebra::Vector4::new(-1.0, -1.0, 1.0, 1.0));
    let affine_lps = flip * affine_ras;
    coapt_geom::volume::check_affine(&affine_lps).map_err(|e| {
        format!("the {transform_source} transform is unusable: {e}; fix the header")
    })?;
    let header_size = if raw.version == 1 {
        HDR1_SIZE
    } else {
        HDR2_SIZE
    };
    let vo = raw.vox_offset;
    if !(vo.is_finite() && vo.fract() == 0.0 && vo >= header_size as f64 && vo < 9e15) {
        return Err(format!(
            "vox_offset {vo} is invalid: it must be a whole number of bytes ≥ {header_size} \
             (the header size) in a single-file NIfTI"
        ));
    }
    let bpv = datatype.bytes();
    Ok(Header {
        version: raw.version,
        endian: raw.endian,
        dims,
        datatype,
        bytes_per_voxel: bpv,
        scl_slope,
        scl_inter,
        affine_lps,
        transform_source,
        sform_code: raw.sform_code,
        qform_code: raw.qform_code,
        pixdim: raw.pixdim,
        unit_to_mm,
        description: raw.descrip.clone(),
        vox_offset: vo as u64,
        data_bytes: dims.iter().map(|&d| d as u64).product::<u64>() * bpv as u64,
        header_size,
    })
}

fn validate_dims(raw: &RawHeader) -> Result<[usize; 3], String> {
    let n = raw.dim[0];
    if !(1..=7).contains(&n) {
        return Err(format!(
            "dim[0] (number of dimensions) is {n}; it must be 1..=7, the header is corrupt"
        ));
    }
    let n = n as usize;
    let used = &raw.dim[1..=n];
    if let Some((i, &d)) = used.iter().enumerate().find(|(_, d)| **d < 1) {
        return Err(format!(
            "dim[{}] is {d}; every dimension must be ≥ 1, the header is corrupt",
            i + 1
        ));
    }
    if n > 3 && raw.dim[4..=n].iter().any(|&d| d != 1) {
        let what = if n == 4 {
            "4-D volume"
        } else {
            "multi-dimensional volume"
        };
        return Err(format!(
            "{what} {}: coapt needs one 3-D volume; extract a single time point \
             (e.g. `fslroi in.nii.gz out.nii.gz 0 1`)",
            shape_string(used)
        ));
    }
    let mut dims = [1u64; 3];
    for (a, d) in dims.iter_mut().enumerate().take(n.min(3)) {
        *d = raw.dim[a + 1] as u64;
    }
    if let Some(a) = (0..3).find(|&a| dims[a] > MAX_AXIS) {
        let vox: u128 = dims.iter().map(|&d| d as u128).product();
        return Err(format!(
            "volume {} claims {} voxels along axis {a}, more than the {MAX_AXIS} a real scan can \
             have ({} voxels in all): the header is corrupt",
            shape_string(&raw.dim[1..=n.min(3)]),
            dims[a],
            vox
        ));
    }
    Ok(dims.map(|d| d as usize))
}

fn validate_datatype(raw: &RawHeader) -> Result<DataType, String> {
    let code = raw.datatype;
    let dt = match DataType::from_code(code) {
        Some(dt) => dt,
        None => {
            let what = match unsupported_datatype(code) {
                Some(name) => format!("datatype {code} ({name}) is not supported"),
                None => format!("unknown datatype code {code}"),
            };
            return Err(format!(
                "{what}: coapt reads scalar volumes (uint8, int8, int16, uint16, int32, uint32, \
                 int64, uint64, float32, float64); convert the image to one of these"
            ));
        }
    };
    if raw.bitpix as i64 != 8 * dt.bytes() as i64 {
        return Err(format!(
            "bitpix is {} but datatype {} has {} bits per voxel; the header is inconsistent",
            raw.bitpix,
            dt.name(),
            8 * dt.bytes()
        ));
    }
    Ok(dt)
}

fn check_size(dims: [usize; 3], dt: DataType, max_bytes: u64) -> Result<(), String> {
    let need = dims
        .iter()
        .try_fold(dt.bytes() as u64, |acc, &d| acc.checked_mul(d as u64));
    match need {
        Some(n) if n <= max_bytes => Ok(()),
        _ => {
            let n: u128 = dims.iter().map(|&d| d as u128).product::<u128>() * dt.bytes() as u128;
            Err(format!(
                "volume {}×{}×{} {} needs {n} bytes ({}) of voxel data, above the limit of \
                 {max_bytes} bytes ({}); if the volume is genuine, raise the limit with the \
                 environment variable COAPT_MAX_VOLUME_BYTES=<bytes>",
                dims[0],
                dims[1],
                dims[2],
                dt.name(),
                human_bytes(n),
                human_bytes(max_bytes as u128)
            ))
        }
    }
}

fn validate_scaling(raw: &RawHeader) -> Result<(Option<f64>, Option<f64>), String> {
    let (s, i) = (raw.scl_slope, raw.scl_inter);
    if s == 0.0 || s.is_nan() {
        return Ok((None, None));
    }
    if s.is_infinite() {
        return Err("scl_slope is infinite; fix the header (0 or NaN means no scaling)".into());
    }
    if i.is_infinite() {
        return Err("scl_inter is infinite; fix the header".into());
    }
    let inter = (i != 0.0 && !i.is_nan()).then_some(i);
    Ok((Some(s), inter))
}
