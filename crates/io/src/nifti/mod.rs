//! NIfTI volumes (.nii, .nii.gz): the CT and mask artifacts.
//!
//! Reading accepts single-file NIfTI-1 and NIfTI-2, either byte order,
//! gzipped or not (sniffed from the content, not the name), any scalar
//! numeric datatype. The header is validated in full before anything is
//! allocated for voxels, so a corrupt or hostile header costs nothing; the
//! voxel data is then streamed straight into the output buffer.
//!
//! NIfTI stores RAS world coordinates; coapt's world is LPS (see
//! docs/artifacts.md, "Conventions"),
//! so x and y are negated on the way in and out:
//! `affine_lps = diag(-1, -1, 1, 1) · affine_ras`.
//!
//! Writing produces little-endian NIfTI-1 with the same transform as sform
//! and qform (both code 1, scanner anatomical), so every reader, whichever
//! transform it prefers, sees the same grid.

mod header;
mod read;
mod transform;
mod write;

#[cfg(test)]
mod tests;

use std::path::Path;

pub use header::{DataType, Endian, Header, TransformSource};
pub use header::{MAX_AXIS, human_bytes};
pub use read::{read_header, read_header_with, read_with};
pub use transform::SPACING_MM;

// The other volume readers (NRRD, MetaImage) decode their voxels with the
// same conversion, so every format refuses and converts values alike.
pub(crate) use read::{convert as decode_voxels, read_full};
pub use write::{GZIP_LEVEL, encode, write};

use coapt_base::Result;
use coapt_geom::Volume;

/// Voxel-data size allowed when no limit is configured: 2 GiB.
pub const DEFAULT_MAX_BYTES: u64 = 2 << 30;
/// Environment variable that overrides [`DEFAULT_MAX_BYTES`] (in bytes).
pub const MAX_BYTES_ENV: &str = "COAPT_MAX_VOLUME_BYTES";

/// Limits applied while reading.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReadOptions {
    /// Refuse volumes whose voxel data (as stored, and as converted) would
    /// take more bytes than this.
    pub max_bytes: u64,
}

impl Default for ReadOptions {
    /// 2 GiB, or `COAPT_MAX_VOLUME_BYTES` when it holds a valid byte count.
    fn default() -> Self {
        Self {
            max_bytes: max_bytes_from(std::env::var(MAX_BYTES_ENV).ok().as_deref()),
        }
    }
}

/// The limit an environment value asks for; an invalid value is reported
/// and ignored rather than fatal, since it only guards memory.
fn max_bytes_from(var: Option<&str>) -> u64 {
    let Some(s) = var else {
        return DEFAULT_MAX_BYTES;
    };
    match s.trim().parse::<u64>() {
        Ok(n) if n > 0 => n,
        _ => {
            tracing::warn!(
                "{MAX_BYTES_ENV}={s:?} is not a positive whole number of bytes; \
                 using the default limit of {DEFAULT_MAX_BYTES} bytes"
            );
            DEFAULT_MAX_BYTES
        }
    }
}

/// Any stored numeric type as f32, with scl_slope/scl_inter applied.
pub fn read_f32(path: &Path) -> Result<Volume<f32>> {
    read_with(path, &ReadOptions::default())
}

/// As int16: every (scaled) value must be an integer in -32768..=32767.
pub fn read_i16(path: &Path) -> Result<Volume<i16>> {
    read_with(path, &ReadOptions::default())
}

/// As uint8 (masks): every (scaled) value must be an integer in 0..=255.
pub fn read_u8(path: &Path) -> Result<Volume<u8>> {
    read_with(path, &ReadOptions::default())
}

mod sealed {
    pub trait Sealed {}
}

/// A primitive number whose every bit pattern is a valid value, so voxel
/// bytes can be read into and written from it directly. Sealed: the unsafe
/// byte views in this module rely on it.
pub trait Element: sealed::Sealed + Copy + Default + Send + Sync + 'static {
    /// The NIfTI datatype with this exact in-memory representation.
    const DATATYPE: DataType;
    fn swap_bytes(self) -> Self;
}

/// A voxel type the reader can produce.
pub trait NiftiRead: Element {
    /// Human description of the values accepted, for error messages.
    const RANGE: &'static str;
    /// `v` as Self if exactly representable (floats: nearest value).
    fn from_f64(v: f64) -> Option<Self>;
}

/// A voxel type the writer can store.
pub trait NiftiWrite: Element {}

macro_rules! int_element {
    ($t:ty, $dt:ident, $range:expr) => {
        impl sealed::Sealed for $t {}
        impl Element for $t {
            const DATATYPE: DataType = DataType::$dt;
            #[inline]
            fn swap_bytes(self) -> Self {
                <$t>::swap_bytes(self)
            }
        }
        impl NiftiRead for $t {
            const RANGE: &'static str = $range;
            #[inline]
            fn from_f64(v: f64) -> Option<Self> {
                // NaN fails both comparisons; fract() rejects non-integers.
                if v >= <$t>::MIN as f64 && v <= <$t>::MAX as f64 && v.fract() == 0.0 {
                    Some(v as $t)
                } else {
                    None
                }
            }
        }
        impl NiftiWrite for $t {}
    };
}

int_element!(u8, U8, "integers in 0..=255 (uint8)");
int_element!(i16, I16, "integers in -32768..=32767 (int16)");
int_element!(i32, I32, "integers in -2147483648..=2147483647 (int32)");

macro_rules! float_element {
    ($t:ty, $dt:ident, $bits:ty) => {
        impl sealed::Sealed for $t {}
        impl Element for $t {
            const DATATYPE: DataType = DataType::$dt;
            #[inline]
            fn swap_bytes(self) -> Self {
                <$t>::from_bits(<$bits>::swap_bytes(self.to_bits()))
            }
        }
        impl NiftiRead for $t {
            const RANGE: &'static str = "any number";
            #[inline]
            fn from_f64(v: f64) -> Option<Self> {
                Some(v as $t)
            }
        }
        impl NiftiWrite for $t {}
    };
}

float_element!(f32, F32, u32);
float_element!(f64, F64, u64);

/// The voxels as raw bytes (native byte order).
pub(crate) fn as_bytes<T: Element>(s: &[T]) -> &[u8] {
    // SAFETY: Element is sealed to primitive numbers: no padding, no invalid
    // bit patterns, alignment of u8 is 1, and the length covers exactly the
    // same memory.
    unsafe { std::slice::from_raw_parts(s.as_ptr().cast::<u8>(), std::mem::size_of_val(s)) }
}

/// The voxels as raw mutable bytes (native byte order).
pub(crate) fn as_bytes_mut<T: Element>(s: &mut [T]) -> &mut [u8] {
    // SAFETY: as in `as_bytes`; any byte pattern written is a valid T.
    unsafe { std::slice::from_raw_parts_mut(s.as_mut_ptr().cast::<u8>(), std::mem::size_of_val(s)) }
}
