#!/usr/bin/env bash
# Cross-check coapt's files with independent readers (nibabel, VTK, SimpleITK):
# the committed sample, a fresh `standard` phantom, and STL/PLY hand-offs.
# Needs the venv of tools/README.md; not part of `cargo test`.
#   tools/crosscheck.sh            (uses tools/.venv/bin/python)
set -euo pipefail
cd "$(dirname "$0")/.."
PY="${PYTHON:-tools/.venv/bin/python}"
cargo build --release --quiet
COAPT="${CARGO_TARGET_DIR:-target}/release/coapt"
T="$(mktemp -d)"
trap 'rm -rf "$T"' EXIT
fail=0
run() { echo "== $*"; "$@" || fail=1; }

"$COAPT" phantom --preset standard --seed 2 --out "$T/standard" --quiet
for dir in sample_data "$T/standard"; do
    run "$PY" tools/phantom_crosscheck.py "$dir"
    "$COAPT" info --json "$dir/ct.nii.gz" > "$T/ct.json"
    run "$PY" tools/nifti_crosscheck.py "$dir/ct.nii.gz" "$T/ct.json"
    "$COAPT" info --json "$dir/truth_mask.nii.gz" > "$T/mask.json"
    run "$PY" tools/nifti_crosscheck.py "$dir/truth_mask.nii.gz" "$T/mask.json"
    # What coapt says it wrote, in the form vtp_crosscheck.py expects.
    "$COAPT" info --json "$dir/truth_surface.vtp" | "$PY" -c '
import json, sys
i = json.load(sys.stdin)
arr = lambda xs: {a["name"]: [a["type"], a["components"]] for a in xs}
print(json.dumps({"points": i["points"], "polys": i["triangles"], "lines": i["lines"], "frame": i["frame"],
                  "point_arrays": arr(i["point_data"]), "cell_arrays": arr(i["cell_data"]),
                  "field_arrays": arr(i["field_data"])}))' > "$T/surface.json"
    run "$PY" tools/vtp_crosscheck.py "$dir/truth_surface.vtp" --expect-json "$T/surface.json"
done
"$COAPT" convert sample_data/truth_surface.vtp "$T/surface.stl"
"$COAPT" convert sample_data/truth_surface.vtp "$T/surface.ply"
tris=$("$COAPT" info --json sample_data/truth_surface.vtp | "$PY" -c 'import json,sys; print(json.load(sys.stdin)["triangles"])')
run "$PY" tools/vtp_crosscheck.py "$T/surface.stl" --expect-json "{\"polys\": $tris}"
run "$PY" tools/vtp_crosscheck.py "$T/surface.ply" --expect-json "{\"polys\": $tris}"
run "$PY" tools/volume_formats_crosscheck.py "$COAPT" sample_data/ct.nii.gz
if [ "$fail" -ne 0 ]; then echo "crosscheck: FAILED"; exit 1; fi
echo "crosscheck: all passed"
