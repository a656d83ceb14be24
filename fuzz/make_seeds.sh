#!/usr/bin/env bash
# Seeds of the `dicom` and `stages` targets, from committed fixtures and the
# small case the `stages` harness builds (the sample phantom at 2 mm), made
# with a release build of coapt:  fuzz/make_seeds.sh [path/to/coapt]
set -euo pipefail
cd "$(dirname "$0")"
coapt=${1:-../target/release/coapt}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# dicom: mode byte 0 = one file; 1 = a folder of files, each after its u16 length.
mkdir -p seeds/dicom
for d in ../tests/data/dicom/*/; do
  n=$(basename "$d")
  first=$(ls "$d" | head -1)
  { printf '\x00'; cat "$d/$first"; } > "seeds/dicom/one_$n"
  python3 - "$d" "seeds/dicom/folder_$n" <<'PY'
import os, struct, sys
d, out = sys.argv[1], sys.argv[2]
files = sorted(os.listdir(d))[:3]
with open(out, "wb") as o:
    o.write(b"\x01")
    for f in files:
        b = open(os.path.join(d, f), "rb").read()
        o.write(struct.pack("<H", len(b)) + b)
PY
done

# stages: the first byte picks the stage and the input replaced.
c="$tmp/case"
"$coapt" phantom --out "$c" --preset sample --spacing "2, 2, 2 mm" --quiet
printf '[leaflet1]\nkind = "ozaki_size"\nsize = 21\n[leaflet2]\nkind = "ozaki_size"\nsize = 21\n[leaflet3]\nkind = "ozaki_size"\nsize = 21\n' > "$c/template.toml"
printf 'model = "neo-hookean"\nmu = "900 kPa"\nthickness = "0.5 mm"\npressure = "80 mmHg"\nbending = true\ntolerance = "1e-4 N"\nmax_iterations = 100\ntime_limit = "300 s"\n' > "$c/close.toml"
"$coapt" segment --ct "$c/ct.nii.gz" --landmarks "$c/landmarks.mrk.json" --out "$c/mask.nii.gz" --quiet
"$coapt" surface --mask "$c/mask.nii.gz" --out "$c/aorta.vtp" --quiet
"$coapt" valve --surface "$c/aorta.vtp" --landmarks "$c/landmarks.mrk.json" --out "$c/valve.json" --spacing "1 mm" --quiet
"$coapt" leaflets --valve "$c/valve.json" --paths "$c/paths.vtp" --surface "$c/aorta.vtp" --template "$c/template.toml" --out "$c/leaflets.vtp" --h "2 mm" --quiet
"$coapt" close --leaflets "$c/leaflets.vtp" --surface "$c/aorta.vtp" --config "$c/close.toml" --valve "$c/valve.json" --out "$c/closed.vtp" --quiet
head() { python3 -c "import gzip,sys; sys.stdout.buffer.write(gzip.open(sys.argv[1]).read()[:352])" "$1"; }
s=seeds/stages
mkdir -p $s
{ printf '\x00'; head "$c/ct.nii.gz"; } > $s/0_segment_ct_header
{ printf '\x01'; head "$c/ct.nii.gz"; } > $s/1_segment_landmarks_ct_header
{ printf '\x02'; head "$c/mask.nii.gz"; } > $s/2_surface_mask_header
{ printf '\x03'; head "$c/mask.nii.gz"; } > $s/3_landmarks_mask_header
{ printf '\x04'; cat "$c/landmarks.mrk.json"; } > $s/4_valve_landmarks
{ printf '\x05'; cat "$c/valve.json"; } > $s/5_leaflets_valve_json
{ printf '\x06'; cat "$c/template.toml"; } > $s/6_leaflets_template
{ printf '\x07'; sed 's/max_iterations = 100/max_iterations = 20/; s/"300 s"/"1 s"/' "$c/close.toml"; } > $s/7_close_config
{ printf '\x08'; cat "$c/leaflets.vtp"; } > $s/8_close_leaflets
{ printf '\x09'; cat "$c/closed.vtp"; } > $s/9_report_closed
{ printf '\x0a'; cat "$c/closure.json"; } > $s/10_report_closure_json
{ printf '\x0b'; cat "$c/leaflets.json"; } > $s/11_report_leaflets_json
ls -la seeds/dicom $s
