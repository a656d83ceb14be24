#!/usr/bin/env python3
"""Cross-check a NIfTI file written by coapt against nibabel.

Usage:
    COAPT_NIFTI_XCHECK_OUT=/tmp/x.nii.gz cargo test --lib io::nifti::tests::crosscheck_fixture
    python3 tools/nifti_crosscheck.py /tmp/x.nii.gz [/tmp/x.json]

The JSON (written beside the volume by that test) holds what coapt put in:
shape, dtype, the voxel->world LPS affine, the voxel sum and first values.
Checks: nibabel's shape and dtype; nibabel's RAS affine equals
diag(-1,-1,1,1) @ coapt's LPS affine; the sform and qform nibabel decodes agree;
the voxel values. Exit status 1 on any mismatch.

Needs nibabel and numpy (python3 -m venv /tmp/nifti-venv &&
/tmp/nifti-venv/bin/pip install nibabel numpy). Not part of `cargo test`.
"""

import json
import sys
from pathlib import Path

import nibabel as nib
import numpy as np


def main() -> int:
    if len(sys.argv) not in (2, 3):
        print(__doc__)
        return 2
    path = Path(sys.argv[1])
    expected_path = Path(sys.argv[2]) if len(sys.argv) == 3 else path.with_suffix(".json")
    expected = json.loads(expected_path.read_text())

    img = nib.load(str(path))
    hdr = img.header
    data = np.asanyarray(img.dataobj)
    sform, scode = img.get_sform(coded=True)
    qform, qcode = img.get_qform(coded=True)
    print(f"file           {path}")
    print(f"nibabel        {nib.__version__}")
    print(f"shape          {data.shape}")
    print(f"dtype          {data.dtype} (header datatype {int(hdr['datatype'])})")
    print(f"sform_code     {int(scode)}  qform_code {int(qcode)}  qfac {float(hdr['pixdim'][0])}")
    print(f"zooms          {hdr.get_zooms()}")
    print(f"descrip        {hdr['descrip'].item().decode()}")
    np.set_printoptions(precision=7, suppress=True)
    print("affine (RAS, nibabel):")
    print(img.affine)

    failures = []

    def check(name, ok, detail=""):
        print(f"[{'ok' if ok else 'FAIL'}] {name} {detail}")
        if not ok:
            failures.append(name)

    check("shape", list(data.shape) == list(expected["shape"]), f"{data.shape} vs {expected['shape']}")
    check("dtype", str(data.dtype) == expected["dtype"], f"{data.dtype} vs {expected['dtype']}")
    lps = np.array(expected["affine_lps"], dtype=np.float64)
    ras_expected = np.diag([-1.0, -1.0, 1.0, 1.0]) @ lps
    d = np.abs(img.affine - ras_expected).max()
    check("affine == diag(-1,-1,1,1) @ coapt LPS", d == 0.0, f"(max |diff| = {d:.3g} mm)")
    dq = np.abs(qform - sform).max()
    check("qform == sform", dq < 1e-5, f"(max |diff| = {dq:.3g} mm)")
    check("codes", int(scode) == 1 and int(qcode) == 1, f"sform {int(scode)}, qform {int(qcode)}")
    # Fortran order: the first values run along i.
    first = data.ravel(order="F")[: len(expected["first"])].tolist()
    check("first voxels (i fastest)", first == expected["first"], f"{first}")
    total = int(data.astype(np.int64).sum())
    check("voxel sum", total == expected["sum"], f"{total} vs {expected['sum']}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
