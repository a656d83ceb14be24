#!/usr/bin/env python3
"""Nadirs against TotalSegmentator's annulus: how far each lies out from the
annulus mask's edge at its own angle.

    tools/.venv/bin/python tools/nadirs_vs_annulus.py ANNULUS.nii.gz A.mrk.json [B.mrk.json ...]

`../shared/real/totalseg_annulus.nii.gz` is a filled disc, not a ring: the
annulus plane's section of the root, bounded where the cusps hinge. Its
plane is the least-squares plane of its voxels (LPS: the NIfTI affine's RAS
turned by diag(-1, -1, 1)) and its centre their centroid. For each nadir
N1-N3 of each markups file (which holds C1-C3 and N1-N3) the script prints its angle about that centre in
the plane, its radius, the disc's edge at that angle (the largest voxel
radius within 6 degrees), how far out of the edge the nadir lies (negative:
inside), and its height above the plane. A nadir on the hinge line lies at
the edge; one in the lumen inside it; one on the sinus or LVOT wall beyond
the hinge outside it.
"""

import sys

import nibabel as nib
import numpy as np

from landmark_distances import points  # the markups reader: C1-C3, N1-N3 or exit 2

LPS_FROM_RAS = np.diag([-1.0, -1.0, 1.0, 1.0])
EDGE_HALF_WIDTH_DEG = 6.0


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    img = nib.load(sys.argv[1])
    affine = LPS_FROM_RAS @ img.affine
    ijk = np.argwhere(np.asarray(img.dataobj) > 0.5).astype(float)
    if len(ijk) < 10:
        sys.exit(f"{sys.argv[1]}: fewer than 10 annulus voxels")
    disc = ijk @ affine[:3, :3].T + affine[:3, 3]
    centre = disc.mean(axis=0)
    _, _, vt = np.linalg.svd(disc - centre)
    e1, normal = vt[0], vt[2]
    e2 = np.cross(normal, e1)
    q = disc - centre
    ang = np.degrees(np.arctan2(q @ e2, q @ e1))
    rad = np.hypot(q @ e1, q @ e2)
    print(
        f"annulus disc: {len(disc)} voxels, edge radius {rad.max():.2f} mm at most, "
        f"thickness sd {(q @ normal).std():.2f} mm"
    )

    def edge(a):
        near = np.abs((ang - a + 180.0) % 360.0 - 180.0) <= EDGE_HALF_WIDTH_DEG
        return rad[near].max() if near.any() else float("nan")

    print("file  point  angle_deg  radius_mm  edge_mm  out_of_edge_mm  height_mm")
    for path in sys.argv[2:]:
        for label, p in sorted(points(path).items()):
            if not label.startswith("N"):
                continue
            d = p - centre
            a = np.degrees(np.arctan2(d @ e2, d @ e1))
            r = np.hypot(d @ e1, d @ e2)
            print(
                f"{path}  {label}  {a:9.1f}  {r:9.2f}  {edge(a):7.2f}  "
                f"{r - edge(a):+14.2f}  {d @ normal:+9.2f}"
            )


if __name__ == "__main__":
    main()
