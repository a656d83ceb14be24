#!/usr/bin/env python3
"""Cross-check a NIfTI file written by coapt against nibabel.

Usage:
    coapt info --json FILE.nii.gz > info.json
    python3 tools/nifti_crosscheck.py FILE.nii.gz info.json

`info.json` is what coapt says it wrote: dims, datatype, the voxel->world LPS
affine and the value range. Checks: nibabel's shape and dtype; nibabel's RAS
affine equals diag(-1,-1,1,1) @ coapt's LPS affine exactly; the sform and
qform nibabel decodes agree and both have code 1; the values' min, max and
mean. Exit status 1 on any mismatch. `tools/crosscheck.sh` runs it.

Needs nibabel and numpy (see tools/README.md). Not part of `cargo test`.
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

    dtypes = {"U8": "uint8", "I16": "int16", "F32": "float32", "F64": "float64", "I32": "int32"}
    want_dtype = dtypes.get(expected["datatype"].strip('"'), expected["datatype"])
    check("shape", list(data.shape) == list(expected["dims"]), f"{data.shape} vs {expected['dims']}")
    check("dtype", str(data.dtype) == want_dtype, f"{data.dtype} vs {want_dtype}")
    lps = np.array(expected["affine_voxel_to_lps"], dtype=np.float64)
    ras_expected = np.diag([-1.0, -1.0, 1.0, 1.0]) @ lps
    d = np.abs(img.affine - ras_expected).max()
    check("affine == diag(-1,-1,1,1) @ coapt LPS", d == 0.0, f"(max |diff| = {d:.3g} mm)")
    dq = np.abs(qform - sform).max()
    check("qform == sform", dq < 1e-5, f"(max |diff| = {dq:.3g} mm)")
    check("codes", int(scode) == 1 and int(qcode) == 1, f"sform {int(scode)}, qform {int(qcode)}")
    values = np.asarray(img.get_fdata(dtype=np.float64))
    lo, hi, mean = values.min(), values.max(), values.mean()
    check("min", lo == expected["value_min"], f"{lo} vs {expected['value_min']}")
    check("max", hi == expected["value_max"], f"{hi} vs {expected['value_max']}")
    rel = abs(mean - expected["value_mean"]) / max(1.0, abs(mean))
    check("mean", rel < 1e-9, f"{mean} vs {expected['value_mean']}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
