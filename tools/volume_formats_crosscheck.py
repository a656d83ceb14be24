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
  voxels and grid back.

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
    print("volume formats crosscheck: " + ("all passed" if ok else "FAILED"))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
