#!/usr/bin/env python3
"""Score an aorta mask against TotalSegmentator in the aortic root + ascending
region of the real CT (`shared/real/`).

Usage:
    python3 tools/real_ct_compare.py --mask M.nii.gz [--real DIR] [--json OUT.json]
    python3 tools/real_ct_compare.py --self-check [--real DIR] [--json OUT.json]
    python3 tools/real_ct_compare.py --region-png OUT_PREFIX [--real DIR]

The region (all on the CT grid of DIR/ct.nii.gz; world coordinates from
nibabel, RAS, reported in LPS mm like the rest of coapt):

1. Annulus plane: centroid c_a of the world positions of the voxels of
   `totalseg_annulus.nii.gz` (TotalSegmentator's annulus ring); normal n = the
   right singular vector of the smallest singular value of the centred
   positions (least-squares plane, SVD), signed so that n points toward the
   centroid c_s of `totalseg_stj.nii.gz` (sinotubular-junction ring).
2. h_stj = n . (c_s - c_a), the STJ centroid's height above the annulus plane.
3. Top plane, 40 mm along the centreline above the STJ: march the centreline
   of TotalSeg's aorta from c_s in 5 mm steps (see `march_centreline`: each
   step moves to the centroid of a 3 mm thick, 25 mm radius disc of aorta
   voxels across the current direction) until its arc length reaches 40 mm;
   the top point p_t is interpolated at exactly 40 mm, the top normal d_t is
   the chord of the last two steps. Slab S = CT voxel centres x with
   n . (x - c_a) >= 0 and d_t . (x - p_t) <= 0.
   Why not "h_stj + 40 mm along n": on this CT the ascending aorta runs
   40-48 degrees off the annulus normal above the STJ (`--region-png` prints
   the angle of each step and draws both planes on two reformatted slices), so
   a plane perpendicular to n at h_stj + 40 mm cuts the vessel very obliquely
   and takes in a long stretch of the proximal arch (T would be 127 ml instead
   of 45 ml). The centreline-perpendicular top cuts the ascending aorta
   square, 40 mm of vessel above the STJ.
4. T = the 6-connected component of (TotalSeg aorta AND S) that contains the
   voxel of (TotalSeg aorta AND S) nearest c_a (TotalSeg's aorta begins 0-2 mm
   above the annulus plane, so c_a itself lies just below it; ties go to the
   lowest (i, j, k) in lexicographic order). The descending aorta crosses
   the same slab as another component, so it is excluded.
5. R = S AND {x : distance(x, T) <= 10 mm} (exact EDT in mm). A mask M is
   scored as M AND R against T: leaks of M into the neighbours of the root
   (atria, ventricle, pulmonary trunk) within 10 mm count as errors, the
   descending aorta and the arch do not.

Metrics (M is first resampled to the CT grid by nearest neighbour through
both affines: CT index -> world -> M index, rounded as floor(x + 0.5);
voxels outside M's grid are 0; any non-zero value is inside):

* Dice = 2 |M&R & T| / (|M&R| + |T|).
* Boundary of a set A = voxels of A with a 6-neighbour outside A (the grid
  border counts as outside). Distances from each boundary voxel of A to the
  nearest boundary voxel of B by an exact EDT with the voxel spacing (mm),
  and from B's to A's; both lists pooled ("symmetric"): mean = mean of the
  pooled list, p95 = its 95th percentile (numpy's default linear
  interpolation between order statistics: index 0.95 (n - 1)).
* Volumes in ml: voxel count x voxel volume / 1000.

`--self-check` runs the sanity checks: TotalSeg's T against itself (Dice 1,
distances 0), T eroded by one voxel (6-connected; expected Dice = 2|E|/(|E|+
|T|); every boundary voxel of E is exactly one voxel step (1.5 mm) from T's
boundary, T's are 1.5 mm from E's except at corners and thin parts, so p95 =
1.5 mm and the mean a little above), and the whole TotalSeg
aorta shifted by one voxel along k (+1.5 mm; the numbers the Rust test
`tests/it/real_ct.rs` must reproduce).

Needs numpy, nibabel, scipy; matplotlib for --region-png. Not part of
`cargo test`.
"""

import argparse
import json
import sys
import time
from pathlib import Path

import nibabel as nib
import numpy as np
from scipy import ndimage as ndi

ABOVE_STJ_MM = 40.0
STEP_MM = 5.0
LAYER_HALF_MM = 1.5
LAYER_RADIUS_MM = 25.0
NEIGHBOURHOOD_MM = 10.0
RAS_TO_LPS = np.diag([-1.0, -1.0, 1.0])
CROSS = ndi.generate_binary_structure(3, 1)


def default_real() -> Path:
    return Path(__file__).resolve().parent.parent.parent / "shared" / "real"


def bad_input(path: Path, problem: str):
    print(f"error: {path}: {problem}", file=sys.stderr)
    sys.exit(2)


def load(path: Path):
    if not path.is_file():
        bad_input(path, "not found")
    try:
        img = nib.load(str(path))
        data = np.asanyarray(img.dataobj)
    except Exception as e:  # nibabel raises many types
        bad_input(path, f"not a readable NIfTI file ({e})")
    if data.ndim != 3:
        bad_input(path, f"expected a 3-D volume, got shape {data.shape}")
    return data, img.affine.astype(np.float64)


def world_of(ijk: np.ndarray, affine: np.ndarray) -> np.ndarray:
    return ijk @ affine[:3, :3].T + affine[:3, 3]


def lps(v) -> list:
    return [float(x) for x in RAS_TO_LPS @ np.asarray(v, dtype=np.float64)]


def spacing_of(affine: np.ndarray) -> np.ndarray:
    return np.linalg.norm(affine[:3, :3], axis=0)


def march_centreline(aorta_w: np.ndarray, c_a: np.ndarray, c_s: np.ndarray):
    """Centreline of the aorta from the STJ centroid, ABOVE_STJ_MM along it.

    Start at c_s heading along unit(c_s - c_a). Each step: q = p + STEP_MM d;
    the next point p' is the centroid of the aorta voxels x with
    |d.(x - q)| <= LAYER_HALF_MM and distance from the line (q, d) <= LAYER_RADIUS_MM
    (a 3 mm thick disc across the vessel); d' = unit(p' - p); arc += |p' - p|.
    Stops once arc >= ABOVE_STJ_MM. The top point is interpolated on the last
    step at arc = ABOVE_STJ_MM exactly; the top normal is the chord of the last
    two steps (about 10 mm), which is steadier than one step's direction.
    """
    p = c_s.copy()
    d = (c_s - c_a) / np.linalg.norm(c_s - c_a)
    pts, arcs = [p.copy()], [0.0]
    arc = 0.0
    while arc < ABOVE_STJ_MM:
        q = p + STEP_MM * d
        rel = aorta_w - q
        ax = rel @ d
        rad = np.linalg.norm(rel - np.outer(ax, d), axis=1)
        layer = (np.abs(ax) <= LAYER_HALF_MM) & (rad <= LAYER_RADIUS_MM)
        if not layer.any() or len(pts) > 100:
            raise SystemExit("error: the centreline march left TotalSeg's aorta above the STJ")
        pn = aorta_w[layer].mean(axis=0)
        step = float(np.linalg.norm(pn - p))
        d = (pn - p) / step
        arc += step
        p = pn
        pts.append(p.copy())
        arcs.append(arc)
    f = (ABOVE_STJ_MM - arcs[-2]) / (arcs[-1] - arcs[-2])
    p_top = pts[-2] + f * (pts[-1] - pts[-2])
    chord = pts[-1] - pts[max(len(pts) - 3, 0)]
    return list(zip(arcs, pts)), p_top, chord / np.linalg.norm(chord)


class Region:
    """The root + ascending region of the real CT (see the module docstring)."""

    def __init__(self, real: Path):
        ct, self.affine = load(real / "ct.nii.gz")
        self.shape = ct.shape
        self.spacing = spacing_of(self.affine)
        masks = {}
        for name in ("totalseg_aorta", "totalseg_annulus", "totalseg_stj"):
            m, a = load(real / f"{name}.nii.gz")
            if m.shape != self.shape or not np.allclose(a, self.affine, atol=1e-6):
                bad_input(real / f"{name}.nii.gz", "not on the grid of ct.nii.gz")
            masks[name] = m != 0
        self.aorta = masks["totalseg_aorta"]
        ring = world_of(np.argwhere(masks["totalseg_annulus"]).astype(np.float64), self.affine)
        stj = world_of(np.argwhere(masks["totalseg_stj"]).astype(np.float64), self.affine)
        self.ring_n = len(ring)
        self.c_a = ring.mean(axis=0)
        self.c_s = stj.mean(axis=0)
        _, sv, vt = np.linalg.svd(ring - self.c_a, full_matrices=False)
        n = vt[2]
        if n @ (self.c_s - self.c_a) < 0:
            n = -n
        self.n = n
        self.singular_values = sv
        self.h_stj = float(n @ (self.c_s - self.c_a))

        self.centreline, self.p_top, self.d_top = march_centreline(
            world_of(np.argwhere(self.aorta).astype(np.float64), self.affine), self.c_a, self.c_s)
        ijk = np.indices(self.shape, dtype=np.float64).reshape(3, -1).T
        w = world_of(ijk, self.affine)
        self.height = ((w - self.c_a) @ n).reshape(self.shape)
        self.below_top = ((w - self.p_top) @ self.d_top).reshape(self.shape)
        self.slab = (self.height >= 0.0) & (self.below_top <= 0.0)
        labels, _ = ndi.label(self.aorta & self.slab, structure=CROSS)
        # TotalSeg's aorta starts at the annulus plane (its lowest voxels lie
        # 0-2 mm above it), so c_a itself is usually just outside it: seed
        # the component at the voxel of aorta AND S nearest c_a.
        cand = np.argwhere(self.aorta & self.slab)
        if len(cand) == 0:
            raise SystemExit("error: TotalSeg's aorta does not reach the slab above the annulus")
        dist = np.linalg.norm(world_of(cand.astype(np.float64), self.affine) - self.c_a, axis=1)
        seed = tuple(int(v) for v in cand[int(np.argmin(dist))])
        self.seed_distance_mm = float(dist.min())
        self.seed = seed
        self.T = labels == labels[seed]
        dist_to_t = ndi.distance_transform_edt(~self.T, sampling=self.spacing)
        self.R = self.slab & (dist_to_t <= NEIGHBOURHOOD_MM)
        self.voxel_ml = float(abs(np.linalg.det(self.affine[:3, :3]))) / 1000.0

    def numbers(self) -> dict:
        cos = abs(float(self.n[2]))
        return {
            "annulus_centre_lps_mm": lps(self.c_a),
            "annulus_normal_lps": lps(self.n),
            "annulus_normal_to_axial_deg": float(np.degrees(np.arccos(min(1.0, cos)))),
            "annulus_plane_rms_mm": float(self.singular_values[2] / np.sqrt(self.ring_n)),
            "stj_centre_lps_mm": lps(self.c_s),
            "h_stj_mm": self.h_stj,
            "top_point_lps_mm": lps(self.p_top),
            "top_normal_lps": lps(self.d_top),
            "top_height_above_annulus_mm": float((self.p_top - self.c_a) @ self.n),
            "top_normal_to_annulus_normal_deg": float(np.degrees(np.arccos(min(1.0, self.d_top @ self.n)))),
            "seed_ijk": list(self.seed),
            "seed_distance_mm": self.seed_distance_mm,
            "T_voxels": int(self.T.sum()),
            "T_ml": float(self.T.sum()) * self.voxel_ml,
            "R_voxels": int(self.R.sum()),
            "R_ml": float(self.R.sum()) * self.voxel_ml,
        }

    def resample(self, data: np.ndarray, affine: np.ndarray) -> np.ndarray:
        """Nearest-neighbour resampling of a mask onto the CT grid."""
        c = np.linalg.inv(affine) @ self.affine
        ijk = np.indices(self.shape, dtype=np.float64).reshape(3, -1)
        idx = np.floor(c[:3, :3] @ ijk + c[:3, 3:4] + 0.5).astype(np.int64)
        inside = np.all((idx >= 0) & (idx < np.array(data.shape)[:, None]), axis=0)
        out = np.zeros(ijk.shape[1], dtype=bool)
        out[inside] = data[idx[0, inside], idx[1, inside], idx[2, inside]] != 0
        return out.reshape(self.shape)

    def score(self, m_on_ct: np.ndarray) -> dict:
        return scores(m_on_ct & self.R, self.T, self.spacing, self.voxel_ml)


def boundary(a: np.ndarray) -> np.ndarray:
    return a & ~ndi.binary_erosion(a, structure=CROSS, border_value=0)


def scores(m: np.ndarray, t: np.ndarray, spacing: np.ndarray, voxel_ml: float) -> dict:
    nm, nt = int(m.sum()), int(t.sum())
    inter = int((m & t).sum())
    dice = 2.0 * inter / (nm + nt) if nm + nt else float("nan")
    out = {"dice": dice, "mask_ml": nm * voxel_ml, "ref_ml": nt * voxel_ml}
    if nm == 0 or nt == 0:
        out.update(mean_mm=float("inf"), p95_mm=float("inf"))
        return out
    bm, bt = boundary(m), boundary(t)
    d_to_t = ndi.distance_transform_edt(~bt, sampling=spacing)
    d_to_m = ndi.distance_transform_edt(~bm, sampling=spacing)
    d = np.concatenate([d_to_t[bm], d_to_m[bt]])
    out.update(mean_mm=float(d.mean()), p95_mm=float(np.percentile(d, 95)),
               boundary_voxels=[int(bm.sum()), int(bt.sum())])
    return out


def centreline(region: Region) -> list:
    """The marched centreline: arc length, height above the annulus plane and
    the angle of each step to the annulus normal and to the scanner z axis."""
    rows = []
    pts = region.centreline
    for i in range(1, len(pts)):
        d = pts[i][1] - pts[i - 1][1]
        d /= np.linalg.norm(d)
        rows.append({"arc_mm": float(pts[i][0]), "centre_lps_mm": lps(pts[i][1]),
                     "height_mm": float((pts[i][1] - region.c_a) @ region.n),
                     "angle_to_annulus_normal_deg": float(np.degrees(np.arccos(d @ region.n))),
                     "angle_to_z_deg": float(np.degrees(np.arccos(abs(d[2]))))})
    return rows


def region_png(region: Region, ct: np.ndarray, prefix: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    bend = region.p_top - region.c_a
    bend -= (bend @ region.n) * region.n
    if np.linalg.norm(bend) < 1e-6:
        bend = np.cross(region.n, [1.0, 0.0, 0.0])
    u = bend / np.linalg.norm(bend)
    v = np.cross(region.n, u)
    inv = np.linalg.inv(region.affine)
    for tag, e in (("bend", u), ("across", v)):
        s = np.arange(-60.0, 60.0, 0.5)
        hh = np.arange(-40.0, 110.0, 0.5)
        S, H = np.meshgrid(s, hh)
        pts = region.c_a + S[..., None] * e + H[..., None] * region.n
        idx = (pts @ inv[:3, :3].T + inv[:3, 3]).reshape(-1, 3).T
        img = ndi.map_coordinates(ct.astype(np.float32), idx, order=1, cval=-1024).reshape(S.shape)
        tm = ndi.map_coordinates(region.T.astype(np.float32), idx, order=0).reshape(S.shape)
        ao = ndi.map_coordinates(region.aorta.astype(np.float32), idx, order=0).reshape(S.shape)
        rm = ndi.map_coordinates(region.R.astype(np.float32), idx, order=0).reshape(S.shape)
        top = ((pts - region.p_top) @ region.d_top)
        fig, ax = plt.subplots(figsize=(6, 7.5))
        ax.imshow(img, cmap="gray", vmin=-200, vmax=600, origin="lower",
                  extent=[s[0], s[-1], hh[0], hh[-1]])
        ax.contour(s, hh, ao, levels=[0.5], colors="yellow", linewidths=0.7)
        ax.contour(s, hh, tm, levels=[0.5], colors="red", linewidths=1.2)
        ax.contour(s, hh, rm, levels=[0.5], colors="cyan", linewidths=0.7)
        for y, c in ((0.0, "blue"), (region.h_stj, "green"), (region.h_stj + ABOVE_STJ_MM, "grey")):
            ax.axhline(y, color=c, lw=0.8, ls="--")
        ax.contour(s, hh, top, levels=[0.0], colors="magenta", linewidths=0.8, linestyles="--")
        cl = np.array([[(c - region.c_a) @ e, (c - region.c_a) @ region.n] for _, c in region.centreline])
        ax.plot(cl[:, 0], cl[:, 1], "m.-", ms=3, lw=0.8)
        ax.set_xlabel(f"mm along {tag} axis")
        ax.set_ylabel("height above annulus plane (mm)")
        ax.set_title(f"{tag} plane: yellow TotalSeg aorta, red T, cyan R\n"
                     "blue annulus plane, green STJ height, grey STJ + 40 mm along n,\n"
                     "magenta centreline and top plane", fontsize=9)
        fig.tight_layout()
        fig.savefig(f"{prefix}_{tag}.png", dpi=90)
        plt.close(fig)
        print(f"wrote {prefix}_{tag}.png")


def fmt(name: str, s: dict) -> str:
    return (f"{name:28s} dice {s['dice']:.6f}  mean {s['mean_mm']:.4f} mm  p95 {s['p95_mm']:.4f} mm"
            f"  M&R {s['mask_ml']:.3f} ml  T {s['ref_ml']:.3f} ml")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--mask", type=Path)
    ap.add_argument("--real", type=Path, default=default_real())
    ap.add_argument("--json", type=Path)
    ap.add_argument("--self-check", action="store_true")
    ap.add_argument("--region-png")
    a = ap.parse_args()
    if not (a.mask or a.self_check or a.region_png):
        ap.print_usage()
        return 2
    t0 = time.perf_counter()
    region = Region(a.real)
    numbers = region.numbers()
    print(f"region: annulus centre (LPS mm) {np.round(numbers['annulus_centre_lps_mm'], 3).tolist()}")
    print(f"        annulus normal (LPS) {np.round(numbers['annulus_normal_lps'], 5).tolist()}, "
          f"{numbers['annulus_normal_to_axial_deg']:.2f} deg from the axial (z) axis")
    print(f"        h_stj {region.h_stj:.3f} mm; top plane at {np.round(numbers['top_point_lps_mm'], 3).tolist()}, "
          f"normal {np.round(numbers['top_normal_lps'], 5).tolist()}, "
          f"{numbers['top_height_above_annulus_mm']:.2f} mm above the annulus plane, "
          f"{numbers['top_normal_to_annulus_normal_deg']:.2f} deg from its normal")
    print(f"        "
          f"T {numbers['T_ml']:.3f} ml ({numbers['T_voxels']} voxels), "
          f"R {numbers['R_ml']:.3f} ml ({numbers['R_voxels']} voxels)")
    result = {"region": numbers}
    if a.region_png:
        rows = centreline(region)
        result["centreline"] = rows
        for r in rows:
            print(f"        centreline arc {r['arc_mm']:5.1f} mm, height {r['height_mm']:5.1f} mm: step "
                  f"{r['angle_to_annulus_normal_deg']:5.1f} deg from the annulus normal, "
                  f"{r['angle_to_z_deg']:5.1f} deg from z")
        ct, _ = load(a.real / "ct.nii.gz")
        region_png(region, ct, a.region_png)
    if a.mask:
        data, aff = load(a.mask)
        s = region.score(region.resample(data, aff))
        print(fmt(str(a.mask), s))
        result["scores"] = s
    if a.self_check:
        checks = {}
        checks["self"] = region.score(region.T)
        eroded = ndi.binary_erosion(region.T, structure=CROSS, border_value=0)
        checks["eroded_1"] = region.score(eroded)
        ne, nt = int(eroded.sum()), int(region.T.sum())
        checks["eroded_1"]["expected_dice"] = 2.0 * ne / (ne + nt)
        shifted_aff = region.affine.copy()
        shifted_aff[:3, 3] += region.affine[:3, 2]  # one voxel step along k
        checks["aorta_shift_k1"] = region.score(region.resample(region.aorta, shifted_aff))
        for k, s in checks.items():
            print(fmt(k, s))
        result["self_check"] = checks
        step = float(min(region.spacing))
        failed = [name for name, ok in (
            ("self: Dice 1, distances 0", checks["self"]["dice"] == 1.0
             and checks["self"]["mean_mm"] == 0.0 and checks["self"]["p95_mm"] == 0.0),
            ("eroded: Dice 2|E|/(|E|+|T|)", abs(checks["eroded_1"]["dice"] - checks["eroded_1"]["expected_dice"]) < 1e-12),
            ("eroded: p95 one voxel step", abs(checks["eroded_1"]["p95_mm"] - step) < 1e-9),
            ("eroded: mean in [step, 1.1 step]", step <= checks["eroded_1"]["mean_mm"] <= 1.1 * step),
        ) if not ok]
        for f in failed:
            print(f"FAIL {f}")
        if failed:
            return 1
        print("self-check PASS")
    print(f"time {time.perf_counter() - t0:.2f} s")
    if a.json:
        a.json.write_text(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
