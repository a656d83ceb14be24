#!/usr/bin/env python3
"""Cross-check and time coapt's marching cubes against VTK and scikit-image.

    tools/surface_crosscheck.py PHANTOM_DIR [--coapt BIN] [--threads 1,2]
                                [--repeat 5] [--hu 150] [--json OUT]
                                [--speed-only]

PHANTOM_DIR is what `coapt phantom` writes (truth_mask.nii.gz, ct.nii.gz,
truth_surface.vtp). Two masks are meshed, unsmoothed, at iso 0.5:
  truth   the truth mask;
  ct>HU   the CT thresholded at --hu (millions of triangles).
For each: coapt (`coapt surface --smooth 0 --keep-all`), vtkFlyingEdges3D
and vtkMarchingCubes, and skimage.measure.marching_cubes (Lewiner,
single-threaded). Compared: vertex and triangle counts, the symmetric
Hausdorff distance between the vertex sets (mm), how many triangles are the
same vertex triples, and how many edges of each output are not shared by
exactly two triangles.

Speed, in one run: `coapt bench surface --threads MAX` times coapt's
extraction at 1 and MAX threads, each against the memory-bandwidth bound
(one parallel summing pass over the volume's samples at the dtype the
extractor reads, in a pool of the same size); here vtkFlyingEdges3D is timed
around Update() with vtkSMPTools (STDThread backend) initialised to each
thread count in --threads, and its process-CPU / wall time shows how many
threads it really kept busy. A third input times both on the int16 CT
itself at iso HU + 0.5 (same inside set as the mask; coapt classifies with
16-bit integer compares): counts only, since VTK's padding value moves the
border vertices. The table at the end has the ratios.

--speed-only keeps the timings (and the comparison of VTK's vertex set with
coapt's) and skips vtkMarchingCubes, scikit-image and the accuracy part.

VTK and scikit-image get the mask padded by one voxel of zeros (outside the
timing), as coapt pads internally, so that surfaces cut by the grid border
close in all outputs and the vertex sets can agree.

On the truth mask it also measures accuracy: distances from the default
(smoothed) coapt surface to the phantom's analytic truth_surface.vtp, both
ways (mean, 95th percentile, max), and the smoothing volume change.

Needs numpy, nibabel, vtk, scipy, scikit-image (tools/requirements.txt).
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import nibabel as nib
import numpy as np
import vtk
from scipy.spatial import cKDTree
from skimage.measure import marching_cubes
from vtk.util import numpy_support as ns

RAS_TO_LPS = np.diag([-1.0, -1.0, 1.0, 1.0])


def lps_affine(img):
    return RAS_TO_LPS @ img.affine


def to_world(ijk, affine):
    return ijk @ affine[:3, :3].T + affine[:3, 3]


def read_vtp(path):
    r = vtk.vtkXMLPolyDataReader()
    r.SetFileName(str(path))
    r.Update()
    return polydata_arrays(r.GetOutput())


def polydata_arrays(pd):
    pts = ns.vtk_to_numpy(pd.GetPoints().GetData()).astype(np.float64)
    polys = pd.GetPolys()
    if hasattr(polys, "GetConnectivityArray"):
        tris = ns.vtk_to_numpy(polys.GetConnectivityArray()).reshape(-1, 3)
    else:
        tris = ns.vtk_to_numpy(polys.GetData()).reshape(-1, 4)[:, 1:]
    return pts, tris.astype(np.int64)


def image_data(padded, vtk_type=vtk.VTK_UNSIGNED_CHAR):
    img = vtk.vtkImageData()
    img.SetDimensions(*padded.shape)
    img.SetOrigin(-1.0, -1.0, -1.0)  # index of the padding layer
    img.SetSpacing(1.0, 1.0, 1.0)
    arr = ns.numpy_to_vtk(padded.ravel(order="F"), deep=True, array_type=vtk_type)
    img.GetPointData().SetScalars(arr)
    return img


def run_vtk(cls, img, iso, repeat):
    f = cls()
    f.SetInputData(img)
    f.SetValue(0, iso)
    f.ComputeNormalsOff()
    f.ComputeScalarsOff()
    if hasattr(f, "ComputeGradientsOff"):
        f.ComputeGradientsOff()
    times, cpu = [], []
    for _ in range(repeat):
        f.Modified()
        c = time.process_time()
        t = time.perf_counter()
        f.Update()
        times.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
    best = int(np.argmin(times))
    run_vtk.cpu_over_wall = cpu[best] / times[best]
    run_vtk.cpu_min = min(cpu)
    return min(times), float(np.median(times)), polydata_arrays(f.GetOutput())


def time_both(a, path, iso, img_vtk, threads):
    """coapt's bench (1 and max threads) and vtkFlyingEdges3D at each count."""
    out = json.loads(subprocess.run(
        [a.coapt, "bench", "surface", "--mask", str(path), "--iso", str(iso), "--repeat",
         str(a.repeat), "--threads", str(max(threads)), "--quiet"],
        check=True, capture_output=True, text=True).stdout)
    out["coapt_vertices"] = out.pop("marching_cubes_vertices")
    out["coapt_triangles"] = out.pop("marching_cubes_triangles")
    coapt = {row["threads"]: row for row in out["per_threads"]}
    rows = []
    for t in threads:
        vtk.vtkSMPTools.SetBackend("STDThread")
        vtk.vtkSMPTools.Initialize(t)
        fe_min, fe_med, fe_out = run_vtk(vtk.vtkFlyingEdges3D, img_vtk, iso, a.repeat)
        row = {
            "threads": t,
            "vtk_smp_backend": vtk.vtkSMPTools.GetBackend(),
            "vtk_smp_threads": vtk.vtkSMPTools.GetEstimatedNumberOfThreads(),
            "vtk_flying_edges_s": {"min": fe_min, "median": fe_med},
            "vtk_cpu_over_wall": run_vtk.cpu_over_wall,
            "vtk_process_cpu_s": run_vtk.cpu_min,
        }
        if t in coapt:
            c = coapt[t]
            row.update({
                "one_pass_s": c["one_pass_s"]["min"],
                "coapt_s": c["marching_cubes_s"],
                "coapt_over_one_pass": c["marching_cubes_over_one_pass"],
                "vtk_over_coapt": fe_min / c["marching_cubes_s"]["min"],
            })
            if "cpu_s" in c:
                row["coapt_cpu_s"] = c["cpu_s"]["marching_cubes"]
                row["one_pass_cpu_s"] = c["cpu_s"]["one_pass"]
        rows.append(row)
    out["per_threads"] = rows
    out["vtk_output"] = fe_out
    return out


def print_speed_table(results):
    print(f"\n{'input':<22}{'thr':>4}{'one pass ms':>13}{'coapt ms':>10}{'coapt/pass':>12}"
          f"{'VTK FE ms':>11}{'VTK/coapt':>11}{'VTK cpu/wall':>14}")
    for name, r in results["masks"].items():
        for row in r["speed"]["per_threads"]:
            if "coapt_s" not in row:
                continue
            print(f"{name:<22}{row['threads']:>4}{1e3 * row['one_pass_s']:>13.1f}"
                  f"{1e3 * row['coapt_s']['min']:>10.1f}{row['coapt_over_one_pass']:>12.1f}"
                  f"{1e3 * row['vtk_flying_edges_s']['min']:>11.1f}{row['vtk_over_coapt']:>11.2f}"
                  f"{row['vtk_cpu_over_wall']:>14.2f}")
    print("\nSpeed-up from 1 thread to the most threads (wall, min of --repeat):")
    print(f"{'input':<22}{'threads':>8}{'coapt':>8}{'VTK FE':>8}")
    for name, r in results["masks"].items():
        rows = {row["threads"]: row for row in r["speed"]["per_threads"] if "coapt_s" in row}
        if 1 in rows and len(rows) > 1:
            one, top = rows[1], rows[max(rows)]
            print(f"{name:<22}{'1→' + str(max(rows)):>8}"
                  f"{one['coapt_s']['min'] / top['coapt_s']['min']:>8.2f}"
                  f"{one['vtk_flying_edges_s']['min'] / top['vtk_flying_edges_s']['min']:>8.2f}")
    print("\nOne thread, CPU time (not inflated by other processes on the machine):")
    print(f"{'input':<22}{'one pass ms':>13}{'coapt ms':>10}{'coapt/pass':>12}{'VTK FE ms':>11}{'VTK/coapt':>11}")
    for name, r in results["masks"].items():
        for row in r["speed"]["per_threads"]:
            if "coapt_cpu_s" not in row:
                continue
            print(f"{name:<22}{1e3 * row['one_pass_cpu_s']:>13.1f}{1e3 * row['coapt_cpu_s']:>10.1f}"
                  f"{row['coapt_cpu_s'] / row['one_pass_cpu_s']:>12.1f}{1e3 * row['vtk_process_cpu_s']:>11.1f}"
                  f"{row['vtk_process_cpu_s'] / row['coapt_cpu_s']:>11.2f}")
    print(f"(min of --repeat runs; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs at the end)", flush=True)


def open_edges(tris):
    e = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    return int((counts != 2).sum())


def compare(ref_pts, ref_tris, pts, tris):
    """Hausdorff (mm) between vertex sets; triangles equal as vertex triples."""
    d_ab, _ = cKDTree(ref_pts).query(pts)
    d_ba, idx = cKDTree(pts).query(ref_pts)
    out = {"hausdorff_mm": float(max(d_ab.max(), d_ba.max()))}
    if out["hausdorff_mm"] < 1e-3 and len(pts) == len(ref_pts):
        # Map reference vertex ids onto ours, then compare triangle sets.
        mapped = np.sort(idx[ref_tris], axis=1)
        mine = np.sort(tris, axis=1)
        a = {tuple(t) for t in mapped.tolist()}
        b = {tuple(t) for t in mine.tolist()}
        out["same_triangles"] = len(a & b)
        out["triangles_only_in_reference"] = len(a - b)
        out["triangles_only_in_coapt"] = len(b - a)
    return out


def distances(points, surface_pd):
    loc = vtk.vtkStaticCellLocator()
    loc.SetDataSet(surface_pd)
    loc.BuildLocator()
    d = np.empty(len(points))
    cp = [0.0, 0.0, 0.0]
    cell, sub, d2 = vtk.reference(0), vtk.reference(0), vtk.reference(0.0)
    for n, p in enumerate(points):
        loc.FindClosestPoint(p.tolist(), cp, cell, sub, d2)
        d[n] = float(d2) ** 0.5
    return {
        "mean_mm": float(d.mean()),
        "p95_mm": float(np.percentile(d, 95)),
        "max_mm": float(d.max()),
    }


def vtp_polydata(path):
    r = vtk.vtkXMLPolyDataReader()
    r.SetFileName(str(path))
    r.Update()
    return r.GetOutput()


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("phantom", type=Path)
    ap.add_argument("--coapt", default="target/release/coapt")
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--hu", type=float, default=150.0)
    ap.add_argument("--json", type=Path)
    ap.add_argument("--speed-only", action="store_true", help="timings only (see above)")
    a = ap.parse_args()
    threads = [int(t) for t in a.threads.split(",")]
    tmp = Path(tempfile.mkdtemp(prefix="surface-xcheck-"))
    results = {"threads": threads, "vtk": vtk.vtkVersion.GetVTKVersion(), "masks": {}}

    truth_img = nib.load(a.phantom / "truth_mask.nii.gz")
    ct_img = nib.load(a.phantom / "ct.nii.gz")
    ct_mask = (np.asanyarray(ct_img.dataobj) > a.hu).astype(np.uint8)
    hu_path = tmp / "ct_threshold.nii.gz"
    out_img = nib.Nifti1Image(ct_mask, ct_img.affine)
    out_img.set_qform(ct_img.affine, int(ct_img.header["qform_code"]) or 1)
    out_img.set_sform(ct_img.affine, int(ct_img.header["sform_code"]) or 1)
    nib.save(out_img, hu_path)
    masks = {
        "truth": (a.phantom / "truth_mask.nii.gz", truth_img),
        f"ct>{a.hu:g}HU": (hu_path, nib.load(hu_path)),
    }

    for name, (path, img) in masks.items():
        data = np.asanyarray(img.dataobj).astype(np.uint8)
        aff = lps_affine(img)
        padded = np.pad(data, 1)
        r = {"dims": list(data.shape), "voxels": int(data.size), "inside": int(data.sum())}
        raw = tmp / f"{len(results['masks'])}_raw.vtp"
        subprocess.run(
            [a.coapt, "surface", "--mask", str(path), "--out", str(raw), "--smooth", "0",
             "--keep-all", "--quiet"], check=True)
        c_pts, c_tris = read_vtp(raw)
        r["coapt"] = {"vertices": len(c_pts), "triangles": len(c_tris)}
        if not a.speed_only:
            r["coapt"]["open_or_nonmanifold_edges"] = open_edges(c_tris)
        img_vtk = image_data(padded)
        speed = time_both(a, path, 0.5, img_vtk, threads)
        fe_pts, fe_tris = speed.pop("vtk_output")
        r["speed"] = speed
        fe_pts = to_world(fe_pts, aff)
        if a.speed_only:
            d_ab, _ = cKDTree(fe_pts).query(c_pts)
            d_ba, _ = cKDTree(c_pts).query(fe_pts)
            r["vtkFlyingEdges3D"] = {"vertices": len(fe_pts), "triangles": len(fe_tris),
                                     "hausdorff_mm": float(max(d_ab.max(), d_ba.max()))}
            results["masks"][name] = r
            print(json.dumps({name: r}, indent=1), flush=True)
            continue
        r["vtkFlyingEdges3D"] = {"vertices": len(fe_pts), "triangles": len(fe_tris), "open_or_nonmanifold_edges": open_edges(fe_tris),
                                 **compare(fe_pts, fe_tris, c_pts, c_tris)}
        mc_min, _, (mc_pts, mc_tris) = run_vtk(vtk.vtkMarchingCubes, img_vtk, 0.5, min(a.repeat, 3))
        mc_pts = to_world(mc_pts, aff)
        r["vtkMarchingCubes"] = {"vertices": len(mc_pts), "triangles": len(mc_tris), "seconds": mc_min, "open_or_nonmanifold_edges": open_edges(mc_tris),
                                 **compare(mc_pts, mc_tris, c_pts, c_tris)}
        times = []
        for _ in range(min(a.repeat, 3)):
            t0 = time.perf_counter()
            sk_v, sk_f, _, _ = marching_cubes(padded, 0.5)
            times.append(time.perf_counter() - t0)
        sk_pts = to_world(sk_v - 1.0, aff)
        r["skimage_lewiner"] = {"vertices": len(sk_pts), "triangles": len(sk_f), "seconds": min(times), "open_or_nonmanifold_edges": open_edges(sk_f.astype(np.int64)),
                                **compare(sk_pts, sk_f.astype(np.int64), c_pts, c_tris)}
        results["masks"][name] = r
        print(json.dumps({name: r}, indent=1), flush=True)

    # The CT itself (int16), classified at the same set as the mask.
    iso = a.hu + 0.5
    ct = np.asanyarray(ct_img.dataobj).astype(np.int16)
    img_ct = image_data(np.pad(ct, 1, constant_values=np.iinfo(np.int16).min), vtk.VTK_SHORT)
    speed = time_both(a, a.phantom / "ct.nii.gz", iso, img_ct, threads)
    fe_pts, fe_tris = speed.pop("vtk_output")
    speed["vtk_vertices"], speed["vtk_triangles"] = len(fe_pts), len(fe_tris)
    results["masks"][f"ct int16 iso {iso:g}"] = {"speed": speed}
    print(json.dumps({f"ct int16 iso {iso:g}": speed}, indent=1), flush=True)
    print_speed_table(results)
    if a.speed_only:
        if a.json:
            a.json.write_text(json.dumps(results, indent=1) + "\n")
        return

    # Accuracy of the default (smoothed) surface against the analytic truth.
    smooth = tmp / "aorta.vtp"
    subprocess.run([a.coapt, "surface", "--mask", str(a.phantom / "truth_mask.nii.gz"), "--out", str(smooth), "--quiet"], check=True)
    rep = json.loads((tmp / "surface.json").read_text())
    truth_pd = vtp_polydata(a.phantom / "truth_surface.vtp")
    mine_pd = vtp_polydata(smooth)
    c_pts, _ = polydata_arrays(mine_pd)
    t_pts, _ = polydata_arrays(truth_pd)
    acc = {
        "spacing_mm": [float(x) for x in truth_img.header.get_zooms()[:3]],
        "coapt_to_truth": distances(c_pts, truth_pd),
        "truth_to_coapt": distances(t_pts, mine_pd),
        "smoothing_volume_change_pct": rep["smoothing_volume_change_pct"],
        "enclosed_volume_mm3": rep["enclosed_volume_mm3"],
        "truth_surface_volume_mm3": json.loads((a.phantom / "truth.json").read_text()).get("truth_surface_volume_mm3"),
    }
    # Cap labels against the truth's: region of the nearest truth cell.
    truth_region = ns.vtk_to_numpy(truth_pd.GetCellData().GetArray("region"))
    mine_region = ns.vtk_to_numpy(mine_pd.GetCellData().GetArray("region"))
    cc = vtk.vtkCellCenters()
    cc.SetInputData(mine_pd)
    cc.Update()
    centres = ns.vtk_to_numpy(cc.GetOutput().GetPoints().GetData())
    loc = vtk.vtkStaticCellLocator()
    loc.SetDataSet(truth_pd)
    loc.BuildLocator()
    cp, cell, sub, d2 = [0.0, 0.0, 0.0], vtk.reference(0), vtk.reference(0), vtk.reference(0.0)
    nearest = np.empty(len(centres), dtype=np.int64)
    for n, p in enumerate(centres):
        loc.FindClosestPoint(p.tolist(), cp, cell, sub, d2)
        nearest[n] = int(cell)
    want = truth_region[nearest]
    acc["region_agreement"] = float((want == mine_region).mean())
    acc["region_confusion"] = {f"{w}->{m}": int(((want == w) & (mine_region == m)).sum()) for w in range(3) for m in range(3)}
    results["accuracy"] = acc
    print(json.dumps({"accuracy": acc}, indent=1))
    if a.json:
        a.json.write_text(json.dumps(results, indent=1) + "\n")


if __name__ == "__main__":
    sys.exit(main())
