#!/usr/bin/env python3
"""Independent check of a coapt phantom directory, with nibabel/numpy (+ vtk).

    tools/phantom_crosscheck.py DIR [--no-contrast] [--seed N]

DIR holds what the phantom generator writes:
  ct.nii.gz           int16 HU (NIfTI: world is RAS)
  truth_mask.nii.gz   uint8 0/1 on the same grid
  landmarks.mrk.json  3D Slicer markups, C1-C3 and N1-N3
  truth.json          commissures_mm (top level or under valve_frame), LPS
  truth_surface.vtp   surface of the mask, LPS (frame in field data if given)

coapt works in LPS, NIfTI stores RAS: that flip is the bug this tool exists
to catch, so it re-derives every conversion here rather than reusing coapt's.
Prints one line per check (PASS / FAIL / SKIP); exit status 1 if any FAIL,
2 if DIR cannot be checked at all.
"""

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

try:
    import nibabel as nib
except ImportError:  # the one hard requirement besides numpy
    sys.exit("phantom_crosscheck: needs nibabel and numpy (see tools/README.md)")

BOUNDARY_MM = 2.0  # a commissure sits on the aortic wall: within 2 mm of the mask edge
LANDMARK_TOL_MM = 1e-6  # landmarks.mrk.json must reproduce truth.json exactly
MIN_LUMEN_HU = 250.0  # contrast-filled blood
SURFACE_TOL_VOX = 1.5  # marching cubes lies within ~0.87 voxel of boundary voxel centres
SURFACE_SAMPLES = 2000


class Report:
    def __init__(self):
        self.rows = []

    def add(self, name, ok, detail):
        status = "SKIP" if ok is None else ("PASS" if ok else "FAIL")
        self.rows.append((name, status, detail))
        return ok

    def print(self):
        w = max(len(r[0]) for r in self.rows)
        for name, status, detail in self.rows:
            print(f"{name:<{w}}  {status}  {detail}")
        fails = sum(r[1] == "FAIL" for r in self.rows)
        print(f"\n{len(self.rows)} checks, {fails} failed")
        return fails


def lps_to_ras(p):
    p = np.asarray(p, dtype=float)
    return p * np.array([-1.0, -1.0, 1.0])


def world_to_index(affine, ras):
    """Continuous voxel indices of RAS points (N,3) through the inverse affine."""
    inv = np.linalg.inv(affine)
    ras = np.atleast_2d(ras)
    return ras @ inv[:3, :3].T + inv[:3, 3]


def index_to_world(affine, ijk):
    return ijk @ affine[:3, :3].T + affine[:3, 3]


# --- reading the inputs -----------------------------------------------------


def find_commissures(truth):
    """(labels, points) from truth.json, or a message saying what is there."""
    if not isinstance(truth, dict):
        raise ValueError(f"truth.json holds a {type(truth).__name__}, expected an object")
    for where, holder in (("valve_frame.commissures_mm", truth.get("valve_frame")), ("commissures_mm", truth)):
        if isinstance(holder, dict) and "commissures_mm" in holder:
            return parse_points(holder["commissures_mm"], where)
    keys = sorted(truth)
    raise ValueError(
        "truth.json has neither valve_frame.commissures_mm nor commissures_mm "
        f"(top-level keys: {keys}); the generator must write one of them"
    )


def parse_points(v, where):
    """Three LPS points given as a list, a {label: xyz} dict or [{label, position_mm}]."""
    if isinstance(v, dict):
        labels = sorted(v)
        pts = [v[k] for k in labels]
    elif isinstance(v, list) and v and isinstance(v[0], dict):
        labels = [d.get("label", f"C{i + 1}") for i, d in enumerate(v)]
        pts = [d.get("position_mm", d.get("position")) for d in v]
    elif isinstance(v, list):
        labels = [f"C{i + 1}" for i in range(len(v))]
        pts = v
    else:
        raise ValueError(f"{where} is {type(v).__name__}, expected a list or dict of three points")
    arr = np.asarray(pts, dtype=float)
    if arr.shape != (3, 3):
        raise ValueError(f"{where} has shape {arr.shape}, expected three [x, y, z] points")
    return labels, arr


def read_markups(path):
    """{label: LPS point} from a Slicer .mrk.json, honouring coordinateSystem."""
    doc = json.loads(path.read_text())
    out, frames = {}, set()
    for m in doc.get("markups", []):
        if m.get("type", "Fiducial") != "Fiducial":
            continue
        frame = str(m.get("coordinateSystem", "LPS")).upper()
        if frame not in ("LPS", "RAS"):
            raise ValueError(f"unknown coordinateSystem {frame!r}")
        frames.add(frame)
        for cp in m.get("controlPoints", []):
            if cp.get("positionStatus", "defined") != "defined" or cp.get("position") is None:
                continue
            p = np.asarray(cp["position"], dtype=float)
            out[cp["label"].strip()] = lps_to_ras(p) if frame == "RAS" else p  # the flip is its own inverse
    return out, frames


def surface_frame(poly):
    """The frame recorded in the .vtp field data, LPS when absent."""
    fd = poly.GetFieldData()
    for i in range(fd.GetNumberOfArrays()):
        arr = fd.GetAbstractArray(i)
        if arr is not None and arr.GetName() and arr.GetName().lower() in ("frame", "coordinate_system", "coordinatesystem"):
            if hasattr(arr, "GetValue") and arr.GetNumberOfValues() > 0:
                return str(arr.GetValue(0)).upper()
    return "LPS"


# --- geometry ---------------------------------------------------------------


def neighbourhood(affine, shape, ras, radius_mm):
    """Voxel indices whose centres may lie within radius_mm of a RAS point.

    The box half-width along index axis k is radius * |row k of inv(A)|,
    which bounds the ball for any affine (oblique, sheared, anisotropic)."""
    inv = np.linalg.inv(affine)[:3, :3]
    centre = world_to_index(affine, ras)[0]
    half = radius_mm * np.linalg.norm(inv, axis=1)
    lo = np.maximum(np.floor(centre - half).astype(int), 0)
    hi = np.minimum(np.ceil(centre + half).astype(int), np.array(shape) - 1)
    if np.any(lo > hi):
        return np.empty((0, 3), dtype=int)
    axes = [np.arange(a, b + 1) for a, b in zip(lo, hi)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)


def boundary_distances(mask, affine, ras, radius_mm):
    """(nearest mask centre, nearest non-mask centre) in mm, inf if none within radius."""
    idx = neighbourhood(affine, mask.shape, ras, radius_mm)
    if len(idx) == 0:
        return math.inf, math.inf
    d = np.linalg.norm(index_to_world(affine, idx.astype(float)) - ras, axis=1)
    inside = mask[idx[:, 0], idx[:, 1], idx[:, 2]]
    near_in = d[inside].min() if inside.any() else math.inf
    near_out = d[~inside].min() if (~inside).any() else math.inf
    return near_in, near_out


def dilate(mask, steps):
    """6-connected binary dilation in numpy (no scipy needed)."""
    out = mask.copy()
    for _ in range(steps):
        grown = out.copy()
        for ax in range(3):
            for shift in (1, -1):
                grown |= np.roll(out, shift, axis=ax) & ~edge_slab(out.shape, ax, shift)
        out = grown
    return out


def edge_slab(shape, ax, shift):
    """Voxels that np.roll wrapped around from the opposite face."""
    slab = np.zeros(shape, dtype=bool)
    sl = [slice(None)] * 3
    sl[ax] = slice(0, 1) if shift == 1 else slice(-1, None)
    slab[tuple(sl)] = True
    return slab


def boundary_voxels(mask):
    """Voxels on either side of the mask edge (6-connected)."""
    outer = dilate(mask, 1) & ~mask
    inner = mask & dilate(~mask, 1)
    return inner | outer


# --- the checks ---------------------------------------------------------------


def check_volumes(rep, d):
    ct_img, mask_img = nib.load(str(d / "ct.nii.gz")), nib.load(str(d / "truth_mask.nii.gz"))
    ct_dtype, mask_dtype = ct_img.get_data_dtype(), mask_img.get_data_dtype()
    rep.add("ct dtype", ct_dtype == np.int16, f"{ct_dtype} (expected int16 HU)")
    mask = np.asarray(mask_img.dataobj)
    values = np.unique(mask)
    rep.add("mask dtype/values", mask_dtype == np.uint8 and set(values.tolist()) <= {0, 1},
            f"{mask_dtype}, values {values[:5].tolist()}{'…' if len(values) > 5 else ''}")
    same_shape = ct_img.shape == mask_img.shape
    rep.add("same shape", same_shape, f"ct {ct_img.shape}, mask {mask_img.shape}")
    diff = np.abs(ct_img.affine - mask_img.affine).max()
    rep.add("same affine", bool(diff <= 1e-6), f"max |Δ| {diff:.3g}")
    mask = mask > 0
    rep.add("mask not empty", bool(mask.any()), f"{int(mask.sum())} voxels")
    ct = np.asarray(ct_img.dataobj, dtype=np.float64) if same_shape else None
    return ct, mask, mask_img.affine


def check_commissures(rep, d, mask, affine):
    try:
        truth = json.loads((d / "truth.json").read_text())
        labels, pts = find_commissures(truth)
    except (OSError, ValueError) as e:
        rep.add("truth commissures", False, str(e))
        return None
    rep.add("truth commissures", True, f"{len(pts)} points ({', '.join(labels)})")
    for label, lps in zip(labels, pts):
        ras = lps_to_ras(lps)
        ijk = world_to_index(affine, ras)[0]
        d_in, d_out = boundary_distances(mask, affine, ras, BOUNDARY_MM)
        ok = d_in <= BOUNDARY_MM and d_out <= BOUNDARY_MM
        rep.add(f"{label} on mask boundary", ok,
                f"LPS {np.round(lps, 3).tolist()} → voxel {np.round(ijk, 2).tolist()}; "
                f"nearest mask voxel {mm(d_in)}, nearest non-mask voxel {mm(d_out)} (≤ {BOUNDARY_MM} mm each)")
    return pts


def mm(d):
    return f"{d:.2f} mm" if math.isfinite(d) else f"none within {BOUNDARY_MM} mm"


def check_landmarks(rep, d, truth_pts):
    try:
        marks, frames = read_markups(d / "landmarks.mrk.json")
    except (OSError, ValueError, KeyError, TypeError) as e:
        rep.add("landmarks file", False, f"cannot read landmarks.mrk.json: {e}")
        return
    want = ["C1", "C2", "C3", "N1", "N2", "N3"]
    missing = [l for l in want if l not in marks]
    rep.add("landmark labels", not missing,
            f"frame {'/'.join(sorted(frames)) or '?'}, labels {sorted(marks)}"
            + (f"; missing {missing}" if missing else ""))
    if truth_pts is None or any(l not in marks for l in ("C1", "C2", "C3")):
        rep.add("landmarks = truth", None, "needs truth commissures and C1-C3")
        return
    got = np.array([marks[l] for l in ("C1", "C2", "C3")])
    err = np.linalg.norm(got - truth_pts, axis=1).max()
    rep.add("landmarks = truth", bool(err <= LANDMARK_TOL_MM), f"max |C_i - truth| {err:.3g} mm (≤ {LANDMARK_TOL_MM})")


def check_intensity(rep, ct, mask, contrast):
    if ct is None:
        rep.add("lumen HU", None, "CT and mask grids differ")
        return
    shell = dilate(mask, 2) & ~mask
    inside, outside = ct[mask], ct[shell]
    detail = (f"inside mean {inside.mean():.1f} sd {inside.std():.1f} HU; "
              f"2-voxel shell outside mean {outside.mean():.1f} sd {outside.std():.1f} HU"
              if outside.size else f"inside mean {inside.mean():.1f} sd {inside.std():.1f} HU; no voxels outside")
    if contrast:
        rep.add("lumen HU > 250", bool(inside.mean() > MIN_LUMEN_HU), detail)
    else:
        rep.add("lumen HU", None, detail + " (no contrast: not judged)")


def check_surface(rep, d, mask, affine, seed):
    try:
        import vtk
        from vtk.util.numpy_support import vtk_to_numpy
    except ImportError:
        rep.add("surface near boundary", None, "vtk not importable; pip install vtk to check truth_surface.vtp")
        return
    path = d / "truth_surface.vtp"
    if not path.exists():
        rep.add("surface near boundary", False, "truth_surface.vtp missing")
        return
    reader = vtk.vtkXMLPolyDataReader()
    reader.SetFileName(str(path))
    reader.Update()
    poly = reader.GetOutput()
    if poly is None or poly.GetNumberOfPoints() == 0:
        rep.add("surface near boundary", False, "truth_surface.vtp has no points (or VTK cannot read it)")
        return
    pts = vtk_to_numpy(poly.GetPoints().GetData()).astype(float)
    frame = surface_frame(poly)
    rng = np.random.default_rng(seed)
    if len(pts) > SURFACE_SAMPLES:
        pts = pts[rng.choice(len(pts), SURFACE_SAMPLES, replace=False)]
    ras = lps_to_ras(pts) if frame == "LPS" else pts
    dist = distance_to_boundary_vox(boundary_voxels(mask), world_to_index(affine, ras), SURFACE_TOL_VOX)
    worst = dist.max()
    shown = f"{worst:.2f}" if math.isfinite(worst) else f"> {SURFACE_TOL_VOX}"
    rep.add("surface near boundary", bool(worst <= SURFACE_TOL_VOX),
            f"{len(pts)} of {poly.GetNumberOfPoints()} points ({frame}); max distance to boundary voxel "
            f"{shown} vox, {int((dist > SURFACE_TOL_VOX).sum())} beyond {SURFACE_TOL_VOX}")


def distance_to_boundary_vox(boundary, ijk, radius):
    """Index-space distance from each point to the nearest boundary voxel centre,
    searched within `radius` (inf beyond)."""
    r = int(math.ceil(radius))
    off = np.stack(np.meshgrid(*[np.arange(-r, r + 1)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    base = np.rint(ijk).astype(int)
    cand = base[:, None, :] + off[None, :, :]
    valid = np.all((cand >= 0) & (cand < np.array(boundary.shape)), axis=2)
    c = np.clip(cand, 0, np.array(boundary.shape) - 1)
    hit = valid & boundary[c[..., 0], c[..., 1], c[..., 2]]
    d = np.linalg.norm(cand - ijk[:, None, :], axis=2)
    return np.where(hit, d, np.inf).min(axis=1)


def contrast_expected(d, flag_no_contrast):
    if flag_no_contrast:
        return False
    try:
        truth = json.loads((d / "truth.json").read_text())
    except (OSError, ValueError):
        return True
    for holder in (truth, truth.get("ct", {}) if isinstance(truth, dict) else {}):
        if isinstance(holder, dict) and isinstance(holder.get("contrast"), bool):
            return holder["contrast"]
    return True


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("dir", type=Path, help="phantom directory")
    ap.add_argument("--no-contrast", action="store_true", help="do not require lumen HU > 250")
    ap.add_argument("--seed", type=int, default=0, help="surface point sampling seed")
    args = ap.parse_args()
    d = args.dir
    missing = [f for f in ("ct.nii.gz", "truth_mask.nii.gz") if not (d / f).exists()]
    if missing:
        print(f"phantom_crosscheck: {d}: missing {', '.join(missing)}", file=sys.stderr)
        return 2
    rep = Report()
    ct, mask, affine = check_volumes(rep, d)
    truth_pts = check_commissures(rep, d, mask, affine)
    check_landmarks(rep, d, truth_pts)
    check_intensity(rep, ct, mask, contrast_expected(d, args.no_contrast))
    check_surface(rep, d, mask, affine, args.seed)
    return 1 if rep.print() else 0


if __name__ == "__main__":
    sys.exit(main())
