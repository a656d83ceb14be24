#!/usr/bin/env python3
"""Cross-check of coapt's Hough circleness against OpenCV's HoughCircles.

    tools/hough_crosscheck.py CT.nii.gz SEGMENT.json [--every 10]

For every --every-th slice that coapt tracked (segment.json "track": slice k,
centre i, j in voxel indices, radius in mm) run cv2.HoughCircles
(HOUGH_GRADIENT) on that axial slice, windowed to 100..400 HU, radii
10-35 mm, and take the OpenCV circle nearest coapt's centre. Prints the
centre distance and radius difference in mm per slice and their maxima;
exit status 1 if either maximum exceeds 1 mm. In-plane pixels must be square
(OpenCV votes in pixels); the NIfTI array is indexed [i, j, k] as coapt's.
"""

import argparse
import json
import sys

import numpy as np

try:
    import cv2
    import nibabel as nib
except ImportError:
    sys.exit("hough_crosscheck: needs opencv-python-headless, nibabel, numpy")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("ct")
    ap.add_argument("report")
    ap.add_argument("--every", type=int, default=10)
    a = ap.parse_args()
    ct = nib.load(a.ct)
    data = np.asarray(ct.dataobj)
    sx, sy = (float(v) for v in ct.header.get_zooms()[:2])
    if abs(sx - sy) > 1e-6:
        sys.exit("hough_crosscheck: in-plane pixels are not square")
    track = json.load(open(a.report))["track"]
    worst_c = worst_r = 0.0
    rows = 0
    for t in track[:: a.every]:
        img = data[:, :, t["k"]].T.astype(np.float32)  # rows = j, cols = i
        # Window 100..400 HU: the contrast lumen against everything else.
        # OpenCV votes both ways along the gradient; with a wide window it
        # finds the concentric fat/soft-tissue ring around the aorta instead.
        u8 = np.clip((img - 100.0) / 300.0 * 255.0, 0, 255).astype(np.uint8)
        u8 = cv2.GaussianBlur(u8, (0, 0), 1.0 / sx)
        circles = cv2.HoughCircles(
            u8, cv2.HOUGH_GRADIENT, dp=1, minDist=10.0 / sx, param1=100, param2=30,
            minRadius=int(10.0 / sx), maxRadius=int(35.0 / sx))
        if circles is None:
            print(f"k {t['k']}: OpenCV found no circle")
            worst_c = worst_r = float("inf")
            continue
        c = min(circles[0], key=lambda c: (c[0] - t["i"]) ** 2 + (c[1] - t["j"]) ** 2)
        dc = float(np.hypot((c[0] - t["i"]) * sx, (c[1] - t["j"]) * sy))
        dr = float(c[2] * sx - t["r_mm"])
        worst_c, worst_r = max(worst_c, dc), max(worst_r, abs(dr))
        rows += 1
        print(f"k {t['k']:4d}: coapt r {t['r_mm']:6.2f} mm, OpenCV r {c[2] * sx:6.2f} mm, "
              f"centre distance {dc:5.2f} mm, radius difference {dr:+5.2f} mm")
    print(f"{rows} slices: max centre distance {worst_c:.2f} mm, max |radius difference| {worst_r:.2f} mm")
    sys.exit(0 if worst_c <= 1.0 and worst_r <= 1.0 else 1)


if __name__ == "__main__":
    main()
