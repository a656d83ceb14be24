#!/usr/bin/env python3
"""Cross-check coapt's NRRD and MetaImage reading and writing against SimpleITK.

Usage:
    python3 tools/volume_formats_crosscheck.py path/to/coapt [CT.nii.gz]

Both directions, on a CT (default: sample_data/ct.nii.gz) given an oblique,
left-handed direction matrix that is not symmetric (so a transposed
TransformMatrix or a missed RAS/LPS flip shows):

* SimpleITK writes it as .nrrd, .nhdr, .mha, .mhd (raw and compressed) and
  .nii.gz; `coapt info --json` must report the same dims, the same LPS affine
  (to 1e-6 mm; NIfTI stores float32, so 1e-4 there) and the same value mean;
* `coapt convert` writes .nrrd and .nii.gz; SimpleITK must read the same
  voxels and grid back;
* SimpleITK (GDCM) writes it as a DICOM CT series, one file per slice,
  named in reverse order: `coapt info DIR` must give the grid SimpleITK
  wrote and SimpleITK's own series reader reads, and the same value mean.

Exit status 1 on any mismatch. Needs SimpleITK and numpy (see tools/README.md).
Not part of `cargo test`.
"""

import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import SimpleITK as sitk


def lps_affine(img: sitk.Image) -> np.ndarray:
    """Voxel index -> LPS mm: direction columns scaled by spacing, then origin."""
    a = np.eye(4)
    d = np.array(img.GetDirection()).reshape(3, 3)
    a[:3, :3] = d @ np.diag(img.GetSpacing())
    a[:3, 3] = img.GetOrigin()
    return a


def dicom_series(coapt: str, img: sitk.Image, voxels: np.ndarray, folder: Path) -> bool:
    """`img` as a CT series written slice by slice by SimpleITK/GDCM (files
    named in reverse order), read by coapt and by SimpleITK's series reader."""
    folder.mkdir()
    d = np.array(img.GetDirection()).reshape(3, 3)
    # DICOM stacks slices along the normal of their rows and columns: make
    # the third axis that normal (a right-handed grid), as a scanner would.
    d[:, 2] = np.cross(d[:, 0], d[:, 1])
    img = sitk.Image(img)
    img.SetDirection(tuple(d.flatten()))
    want = lps_affine(img)
    uid = "1.2.826.0.1.3680043.2.1125.77"
    n = img.GetDepth()
    writer = sitk.ImageFileWriter()
    writer.KeepOriginalImageUIDOn()
    for k in range(n):
        sl = img[:, :, k]
        for tag, value in [
            ("0008|0060", "CT"), ("0020|000e", uid), ("0020|0011", "7"),
            ("0008|103e", "crosscheck"), ("0020|0013", str(n - k)),
            ("0020|0032", "\\".join(f"{x:.10g}" for x in img.TransformIndexToPhysicalPoint((0, 0, k)))),
            ("0020|0037", "\\".join(f"{x:.10g}" for x in list(d[:, 0]) + list(d[:, 1]))),
            ("0028|1052", "0"), ("0028|1053", "1"),
        ]:
            sl.SetMetaData(tag, value)
        writer.SetFileName(str(folder / f"slice{n - k:04d}.dcm"))
        writer.Execute(sl)
    info = json.loads(subprocess.check_output([coapt, "info", "--json", str(folder)]))
    vol = info["volume"]
    off = np.abs(np.array(vol["affine_voxel_to_lps"]) - want).max()
    reader = sitk.ImageSeriesReader()
    back = sitk.ReadImage(reader.GetGDCMSeriesFileNames(str(folder)))
    off_sitk = np.abs(lps_affine(back) - np.array(vol["affine_voxel_to_lps"])).max()
    same = (
        vol["dims"] == list(img.GetSize())
        and off < 1e-4
        and off_sitk < 1e-4
        and abs(vol["value_mean"] - voxels.mean()) < 1e-9 * max(1, abs(voxels.mean()))
        and abs(vol["value_mean"] - sitk.GetArrayFromImage(back).mean()) < 1e-9 * max(1, abs(voxels.mean()))
    )
    print(f"{'ok  ' if same else 'FAIL'} SimpleITK DICOM series -> coapt: {info['series'][0]['images']} "
          f"images, affine off by {off:.1e} mm (SimpleITK's series reader: {off_sitk:.1e} mm)")
    return bool(same)


def main() -> int:
    if len(sys.argv) not in (2, 3):
        print(__doc__)
        return 2
    coapt = sys.argv[1]
    ct = sys.argv[2] if len(sys.argv) == 3 else "sample_data/ct.nii.gz"
    img = sitk.ReadImage(ct)
    voxels = sitk.GetArrayFromImage(img)
    th = 0.5
    rot = np.array([[np.cos(th), -np.sin(th), 0], [np.sin(th), np.cos(th), 0], [0, 0, 1]])
    swap = np.array([[1, 0, 0], [0, 0, 1], [0, 1, 0]])  # det -1: left-handed
    img.SetDirection(tuple((rot @ swap).flatten()))
    want = lps_affine(img)
    ok = True
    with tempfile.TemporaryDirectory() as tmp:
        t = Path(tmp)
        for name, compress in [
            ("a.nrrd", False), ("b.nrrd", True), ("c.nhdr", True),
            ("d.mha", False), ("e.mha", True), ("f.mhd", True), ("g.nii.gz", True),
        ]:
            p = t / name
            sitk.WriteImage(img, str(p), useCompression=compress)
            info = json.loads(subprocess.check_output([coapt, "info", "--json", str(p)]))
            off = np.abs(np.array(info["affine_voxel_to_lps"]) - want).max()
            tol = 1e-4 if name.endswith(".nii.gz") else 1e-6
            same = (
                info["dims"] == list(img.GetSize())
                and off < tol
                and abs(info["value_mean"] - voxels.mean()) < 1e-9 * max(1, abs(voxels.mean()))
            )
            print(f"{'ok  ' if same else 'FAIL'} SimpleITK {name:8} -> coapt: {info['format']} "
                  f"{info['encoding']}, affine off by {off:.1e} mm")
            ok &= bool(same)
        for name in ["coapt.nrrd", "coapt.nii.gz"]:
            p = t / name
            src = t / "g.nii.gz"
            subprocess.check_call([coapt, "convert", str(src), str(p)])
            back = sitk.ReadImage(str(p))
            off = np.abs(lps_affine(back) - want).max()
            same = off < 1e-4 and np.array_equal(sitk.GetArrayFromImage(back), voxels)
            print(f"{'ok  ' if same else 'FAIL'} coapt {name:12} -> SimpleITK: "
                  f"{back.GetPixelIDTypeAsString()}, affine off by {off:.1e} mm, voxels equal")
            ok &= bool(same)
        ok &= dicom_series(coapt, img, voxels, t / "dicom")
    print("volume formats crosscheck: " + ("all passed" if ok else "FAILED"))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
