#!/usr/bin/env python3
"""Cross-check coapt's DICOM reading against pydicom, an independent reader.

Usage:
    python3 tools/dicom_pydicom_crosscheck.py path/to/coapt INPUT...

Each INPUT is a DICOM series folder (one series) or a single multi-frame
file (Enhanced / Legacy Converted Enhanced CT). pydicom reads it (with
pylibjpeg for JPEG lossless and RLE), frames or slices are ordered by their
Image Position (Patient) projected on the slice normal, each is rescaled by
its own slope and intercept, and the LPS affine is built from the direction
cosines and the positions. `coapt convert INPUT out.nii` must give the same
grid (affine to 1e-6 mm; NIfTI's sform is float32, so 1e-3 there) and the
same Hounsfield units voxel for voxel.

Exit status 1 on any mismatch. Needs pydicom, numpy, pylibjpeg and
pylibjpeg-libjpeg (see tools/README.md). Not part of `cargo test`.
"""

import struct
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pydicom


def frames_of(path: Path):
    """(position, row cosine, column cosine, spacing, HU image) per frame."""
    out = []
    if path.is_dir():
        for f in sorted(path.iterdir()):
            try:
                ds = pydicom.dcmread(f)
            except pydicom.errors.InvalidDicomError:
                continue  # a folder may hold other files; coapt skips them too
            if "PixelData" not in ds:
                continue
            iop = np.array(ds.ImageOrientationPatient, float)
            hu = ds.pixel_array.astype(np.float64) * float(ds.get("RescaleSlope", 1)) + float(
                ds.get("RescaleIntercept", 0)
            )
            out.append((np.array(ds.ImagePositionPatient, float), iop[:3], iop[3:],
                        np.array(ds.PixelSpacing, float), hu))
        return out
    ds = pydicom.dcmread(path)
    pixels = ds.pixel_array
    shared = ds.get("SharedFunctionalGroupsSequence", [None])[0]
    for k, fg in enumerate(ds.PerFrameFunctionalGroupsSequence):
        def item(name):
            for g in (fg, shared):
                if g is not None and name in g:
                    return g[name][0]
            raise KeyError(name)
        pos = np.array(item("PlanePositionSequence").ImagePositionPatient, float)
        iop = np.array(item("PlaneOrientationSequence").ImageOrientationPatient, float)
        sp = np.array(item("PixelMeasuresSequence").PixelSpacing, float)
        tr = item("PixelValueTransformationSequence")
        hu = pixels[k].astype(np.float64) * float(tr.RescaleSlope) + float(tr.RescaleIntercept)
        out.append((pos, iop[:3], iop[3:], sp, hu))
    return out


def volume(path: Path):
    fr = frames_of(path)
    normal = np.cross(fr[0][1], fr[0][2])
    fr.sort(key=lambda f: float(np.dot(f[0], normal)))
    row, col, sp = fr[0][1], fr[0][2], fr[0][3]
    step = fr[1][0] - fr[0][0] if len(fr) > 1 else normal
    a = np.eye(4)
    # Voxel (i, j, k): i along the row cosine (columns, spacing sp[1]),
    # j along the column cosine (rows, spacing sp[0]), k from slice to slice.
    a[:3, 0] = row * sp[1]
    a[:3, 1] = col * sp[0]
    a[:3, 2] = step
    a[:3, 3] = fr[0][0]
    # NIfTI order: x fastest; the image's rows are j, its columns i.
    data = np.stack([f[4].T for f in fr], axis=2)
    return a, data


def read_nifti(path: Path):
    b = path.read_bytes()
    dim = struct.unpack_from("<8h", b, 40)
    datatype = struct.unpack_from("<h", b, 70)[0]
    vox_offset = int(struct.unpack_from("<f", b, 108)[0])
    slope, inter = struct.unpack_from("<2f", b, 112)
    srow = np.array(struct.unpack_from("<12f", b, 280), float).reshape(3, 4)
    dt = {4: "<i2", 2: "u1", 512: "<u2", 8: "<i4", 16: "<f4"}[datatype]
    n = dim[1] * dim[2] * dim[3]
    v = np.frombuffer(b, dt, n, vox_offset).astype(np.float64)
    if slope not in (0.0, 1.0) or inter != 0.0:
        v = v * (slope or 1.0) + inter
    # sform is RAS; LPS flips x and y.
    a = np.eye(4)
    a[:3] = srow
    a[:2] *= -1
    return a, v.reshape(dim[3], dim[2], dim[1]).transpose(2, 1, 0)


def main() -> int:
    coapt, inputs = sys.argv[1], [Path(p) for p in sys.argv[2:]]
    bad = 0
    with tempfile.TemporaryDirectory() as tmp:
        for i, p in enumerate(inputs):
            out = Path(tmp) / f"v{i}.nii"
            r = subprocess.run([coapt, "convert", str(p), str(out)], capture_output=True, text=True)
            if r.returncode != 0:
                print(f"FAIL {p}: coapt convert: {r.stderr.strip()}")
                bad += 1
                continue
            a_ref, d_ref = volume(p)
            a, d = read_nifti(out)
            da = np.abs(a - a_ref).max()
            same_shape = d.shape == d_ref.shape
            dv = np.abs(d - d_ref).max() if same_shape else float("inf")
            ok = same_shape and da < 1e-3 and dv == 0.0
            bad += not ok
            print(f"{'ok  ' if ok else 'FAIL'} {p}: dims {d.shape} vs pydicom {d_ref.shape}, "
                  f"affine max diff {da:.2e} mm, HU max diff {dv}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
