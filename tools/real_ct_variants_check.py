#!/usr/bin/env python3
"""Check the real-CT variants written by `tests/it/real_ct_variants.rs`
with nibabel and scipy, independently of coapt's reader and sampler.

Usage:
    COAPT_KEEP_VARIANTS=DIR cargo test --release --test it real_ct_variants
    python3 tools/real_ct_variants_check.py DIR [--real shared/real]

For each variant `DIR/<name>/ct.nii.gz` and each point (the six landmarks of
`landmarks.mrk.json`, LPS -> RAS by negating x and y, plus the centroids of
TotalSeg's annulus and STJ rings), the trilinear HU in the variant
(`scipy.ndimage.map_coordinates`, order 1, at inv(affine) . RAS) against the
original's. Passes when, for variants made of the original's voxels (ras,
kij, flipk, crop_*), they agree to 1e-6 HU; for the trilinear ones (iso*,
oblique20) the value lies within the min/max of the original voxels within
sqrt(3) (s_variant + s_original) mm of the point (the convex-combination
bound; +-0.5 HU for the int16 rounding) and within a quarter of that range
of the original's value (an empirical tolerance, not a bound: the
convex-combination range alone lets a grid shifted by 3 mm pass). Also: the sform and qform nibabel
decodes agree. Prints a table of HU per point and variant; exit 1 on any
failure.

Needs numpy, nibabel, scipy.
"""

import argparse
import json
import sys
from pathlib import Path

import nibabel as nib
import numpy as np
from scipy import ndimage as ndi

EXACT = ("ras", "kij", "flipk", "crop_arch", "crop_no_arch")


def sample(data: np.ndarray, affine: np.ndarray, ras: np.ndarray) -> float:
    idx = np.linalg.solve(affine[:3, :3], ras - affine[:3, 3])
    if np.any(idx < -1e-6) or np.any(idx > np.array(data.shape) - 1 + 1e-6):
        return float("nan")
    return float(ndi.map_coordinates(data, idx[:, None], order=1, mode="nearest")[0])


def range_near(data, affine, ras, radius):
    ijk = np.indices(data.shape).reshape(3, -1).T
    c = np.linalg.solve(affine[:3, :3], ras - affine[:3, 3])
    span = radius / np.linalg.norm(affine[:3, :3], axis=0) + 1
    near = np.all(np.abs(ijk - c) <= span, axis=1)
    w = ijk[near] @ affine[:3, :3].T + affine[:3, 3]
    inside = np.linalg.norm(w - ras, axis=1) <= radius
    v = data.reshape(-1)[np.ravel_multi_index(ijk[near][inside].T, data.shape)]
    return float(v.min()), float(v.max())


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("dir", type=Path)
    ap.add_argument("--real", type=Path,
                    default=Path(__file__).resolve().parent.parent.parent / "shared" / "real")
    a = ap.parse_args()
    orig = nib.load(str(a.real / "ct.nii.gz"))
    od = np.asanyarray(orig.dataobj).astype(np.float64)
    oa = orig.affine
    s_o = float(np.linalg.norm(oa[:3, 0]))
    lm = json.loads((a.real / "landmarks.mrk.json").read_text())["markups"][0]
    assert lm["coordinateSystem"] == "LPS"
    pts = [(c["label"], np.array(c["position"]) * [-1, -1, 1]) for c in lm["controlPoints"]]
    for name in ("annulus", "stj"):
        m = np.asanyarray(nib.load(str(a.real / f"totalseg_{name}.nii.gz")).dataobj) != 0
        pts.append((name, (np.argwhere(m) @ oa[:3, :3].T + oa[:3, 3]).mean(axis=0)))
    variants = sorted(p.parent for p in a.dir.glob("*/ct.nii.gz"))
    if not variants:
        print(f"error: {a.dir}: no */ct.nii.gz")
        return 2
    fails = []
    print(f"{'variant':14s} {'spacing':>7s} {'shape':>16s} " + " ".join(f"{p[0]:>8s}" for p in pts))
    print(f"{'original':14s} {s_o:7.2f} {str(od.shape):>16s} "
          + " ".join(f"{sample(od, oa, p):8.1f}" for _, p in pts))
    for v in variants:
        img = nib.load(str(v / "ct.nii.gz"))
        sf, qf = img.get_sform(), img.get_qform()
        if not np.allclose(sf, qf, atol=1e-4):
            fails.append(f"{v.name}: sform != qform")
        d = np.asanyarray(img.dataobj).astype(np.float64)
        s_v = float(np.linalg.norm(img.affine[:3, 0]))
        row = []
        for label, p in pts:
            want, have = sample(od, oa, p), sample(d, img.affine, p)
            row.append(have)
            if np.isnan(have):
                fails.append(f"{v.name} {label}: outside the variant")
            elif v.name in EXACT:
                if abs(have - want) > 1e-6:
                    fails.append(f"{v.name} {label}: {have} vs {want}")
            else:
                lo, hi = range_near(od, oa, p, np.sqrt(3) * (s_v + s_o) + 1e-6)
                if not (lo - 0.5 <= have <= hi + 0.5):
                    fails.append(f"{v.name} {label}: {have} outside [{lo}, {hi}]")
                elif abs(have - want) > 0.25 * (hi - lo) + 0.5:
                    fails.append(f"{v.name} {label}: {have} vs {want}, more than a quarter "
                                 f"of the local range [{lo}, {hi}]")
        print(f"{v.name:14s} {s_v:7.2f} {str(d.shape):>16s} " + " ".join(f"{x:8.1f}" for x in row))
    for f in fails:
        print("FAIL", f)
    print("PASS" if not fails else f"{len(fails)} failures")
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
