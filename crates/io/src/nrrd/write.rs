//! Writing: attached NRRD, gzip encoding, little-endian, `space:
//! left-posterior-superior`, so 3D Slicer, ITK and teem read it as is.

use std::io::{self, Write};
use std::path::Path;

use flate2::Compression;
use flate2::write::GzEncoder;

use crate::nifti::{DataType, GZIP_LEVEL, NiftiWrite, as_bytes};
use crate::write_atomic;
use coapt_base::Result;
use coapt_geom::Volume;

/// Write `vol` atomically as an attached gzip NRRD.
pub fn write<T: NiftiWrite>(path: &Path, vol: &Volume<T>) -> Result<()> {
    write_atomic(path, |w| encode(w, vol))
}

/// NRRD's name for a stored type.
fn type_name(dt: DataType) -> &'static str {
    match dt {
        DataType::U8 => "uint8",
        DataType::I8 => "int8",
        DataType::I16 => "int16",
        DataType::U16 => "uint16",
        DataType::I32 => "int32",
        DataType::U32 => "uint32",
        DataType::I64 => "int64",
        DataType::U64 => "uint64",
        DataType::F32 => "float",
        DataType::F64 => "double",
    }
}

/// `vol` as a complete NRRD file into `w`.
pub fn encode<T: NiftiWrite>(w: &mut impl Write, vol: &Volume<T>) -> io::Result<()> {
    let [ni, nj, nk] = vol.dims();
    let a = vol.affine();
    // `{:?}` prints the shortest text that parses back to the same f64, so
    // the affine round-trips exactly.
    let col = |c: usize| format!("({:?},{:?},{:?})", a[(0, c)], a[(1, c)], a[(2, c)]);
    let header = format!(
        "NRRD0004\n\
         # written by coapt {}\n\
         type: {}\n\
         dimension: 3\n\
         space: left-posterior-superior\n\
         sizes: {ni} {nj} {nk}\n\
         space directions: {} {} {}\n\
         kinds: domain domain domain\n\
         endian: little\n\
         encoding: gzip\n\
         space origin: {}\n\n",
        env!("CARGO_PKG_VERSION"),
        type_name(T::DATATYPE),
        col(0),
        col(1),
        col(2),
        col(3),
    );
    w.write_all(header.as_bytes())?;
    let mut gz = GzEncoder::new(w, Compression::new(GZIP_LEVEL));
    if cfg!(target_endian = "little") {
        gz.write_all(as_bytes(vol.as_slice()))?;
    } else {
        let swapped: Vec<T> = vol.as_slice().iter().map(|x| x.swap_bytes()).collect();
        gz.write_all(as_bytes(&swapped))?;
    }
    gz.finish()?;
    Ok(())
}
