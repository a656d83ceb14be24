#!/usr/bin/env python3
"""SimpleITK baseline for `coapt bench segment`: the textbook recipe without
the isoperimetric stop or the VAJ cut, on the same CT, seed and threshold.

    tools/segment_baseline.py CT.nii.gz OUT.nii.gz --seed-mm X,Y,Z --threshold HU [--open-mm 2.5]

Steps: connected threshold (lower = HU, 6-connected) from the seed, binary
opening with a ball of --open-mm (radius per axis in voxels), largest
connected component. Prints "seconds S" (compute only, without file I/O) and
writes OUT as uint8. The seed is in LPS millimetres, which is SimpleITK's
physical space, so it needs no conversion.
"""

import argparse
import sys
import time

try:
    import SimpleITK as sitk
except ImportError:
    sys.exit("segment_baseline: needs SimpleITK (pip install SimpleITK)")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ct")
    ap.add_argument("out")
    ap.add_argument("--seed-mm", required=True, help="X,Y,Z in LPS mm")
    ap.add_argument("--threshold", type=float, required=True, help="lower threshold (HU)")
    ap.add_argument("--open-mm", type=float, default=2.5)
    a = ap.parse_args()
    img = sitk.ReadImage(a.ct)
    seed = img.TransformPhysicalPointToIndex([float(v) for v in a.seed_mm.split(",")])
    t0 = time.perf_counter()
    region = sitk.ConnectedThreshold(img, seedList=[seed], lower=a.threshold, upper=32767, replaceValue=1)
    radius = [max(1, int(round(a.open_mm / s))) for s in img.GetSpacing()]
    opened = sitk.BinaryMorphologicalOpening(region, radius, sitk.sitkBall, 0, 1)
    cc = sitk.RelabelComponent(sitk.ConnectedComponent(opened), sortByObjectSize=True)
    mask = sitk.Cast(cc == 1, sitk.sitkUInt8)
    secs = time.perf_counter() - t0
    sitk.WriteImage(mask, a.out, True)
    print(f"seconds {secs:.3f}")
    print(f"voxels {int(sitk.GetArrayViewFromImage(mask).sum())}")


if __name__ == "__main__":
    main()
