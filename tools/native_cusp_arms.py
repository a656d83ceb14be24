"""Where do a diastolic CT's closed native cusps (the "Y") point?

    tools/.venv/bin/python tools/native_cusp_arms.py CT.nii.gz MASK.nii.gz LANDMARKS.mrk.json

The frame comes from the landmarks: origin at the nadirs' centroid, axis
towards the commissures' centroid, angle 0 at C1. At each height 2-10 mm
along the axis the Y's junction is taken as the darkest point within 5 mm
of the axis (0.5 mm grid); the mean HU along rays 4-10 mm from it, against
angle (every 2 degrees, smoothed over 10), has its three deepest minima at
least 75 degrees apart; each is followed from the junction to the mask's
edge, and that wall point's angle about the axis is compared with the
nearest commissure's. Prints, per height, the dips' depth (median HU minus
the minima's mean), the arms' wall angles and each commissure's angular
distance to the nearest arm. docs/results.md (landmarks, "The native
cusps' closed Y") quotes it on ../shared/real/. Needs numpy, scipy and
nibabel. Not part of `cargo test`.
"""

import json
import sys

import nibabel as nib
import numpy as np
from scipy.ndimage import map_coordinates

LPS_TO_RAS = np.array([-1.0, -1.0, 1.0])


def sampler(path, order):
    img = nib.load(path)
    data = img.get_fdata()
    inv = np.linalg.inv(img.affine)

    def at(points):
        p = np.atleast_2d(points)
        ijk = inv[:3, :3] @ p.T + inv[:3, 3:4]
        return map_coordinates(data, ijk, order=order, mode="nearest")

    return at


def main(ct_path, mask_path, lm_path):
    ct = sampler(ct_path, 1)
    mask = sampler(mask_path, 0)
    points = json.load(open(lm_path))["markups"][0]["controlPoints"]
    p = {c["label"]: np.array(c["position"]) * LPS_TO_RAS for c in points}
    com = np.array([p["C1"], p["C2"], p["C3"]])
    nad = np.array([p["N1"], p["N2"], p["N3"]])
    origin = nad.mean(0)
    axis = com.mean(0) - origin
    axis /= np.linalg.norm(axis)
    e1 = com[0] - origin
    e1 -= axis * np.dot(e1, axis)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)

    def angle(v):
        return np.degrees(np.arctan2(np.dot(v, e2), np.dot(v, e1))) % 360.0

    com_angles = [angle(c - origin) for c in com]
    print("commissure angles (deg):", np.round(com_angles, 1))
    thetas = np.radians(np.arange(0.0, 360.0, 2.0))
    grid = np.arange(-5.0, 5.01, 0.5)
    for h in np.arange(2.0, 10.01, 1.0):
        level = origin + axis * h
        best = min(
            (ct(level + dx * e1 + dy * e2)[0], dx, dy) for dx in grid for dy in grid
        )
        junction = level + best[1] * e1 + best[2] * e2
        radii = np.arange(4.0, 10.0, 0.5)
        profile = np.array(
            [
                ct(junction + np.outer(radii, np.cos(t) * e1 + np.sin(t) * e2)).mean()
                for t in thetas
            ]
        )
        smooth = np.convolve(
            np.r_[profile[-2:], profile, profile[:2]], np.ones(5) / 5, "same"
        )[2:-2]
        picks = []
        for i in np.argsort(smooth):
            a = thetas[i]
            if all(abs((a - b + np.pi) % (2 * np.pi) - np.pi) >= np.radians(75) for b in picks):
                picks.append(a)
            if len(picks) == 3:
                break
        depth = np.median(profile) - np.mean(
            [smooth[int(round(np.degrees(a) / 2.0)) % len(thetas)] for a in picks]
        )
        walls = []
        for a in picks:
            d = np.cos(a) * e1 + np.sin(a) * e2
            r = 2.0
            while r < 30.0 and mask(junction + r * d)[0] > 0:
                r += 0.25
            walls.append(angle(junction + r * d - origin))
        errors = [min(abs((w - c + 180.0) % 360.0 - 180.0) for w in walls) for c in com_angles]
        print(
            f"h {h:4.1f} mm  junction off the axis ({best[1]:+.1f}, {best[2]:+.1f}) mm"
            f"  dip {depth:5.0f} HU  arms at the wall {np.round(sorted(walls), 1)} deg"
            f"  C1-C3 to the nearest arm {np.round(errors, 1)} deg"
        )


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    main(*sys.argv[1:])
