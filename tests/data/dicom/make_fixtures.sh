#!/usr/bin/env bash
# JPEG-compressed DICOM series made by an encoder coapt does not own
# (dcmtk's dcmcjpeg, Debian package dcmtk 3.6.7), read by tests/it/dicom.rs.
#
# Their source is the small uncompressed series that the test
# `dicom::jpeg_lossless_series_read_back_bit_identical_to_uncompressed`
# writes (9×8×7 int16, oblique, values over the whole int16 range, Rescale
# Intercept alternating −1024/0 per slice), left by a test run under
# $TMPDIR/coapt-it-dicom-jpeg-lossless-PID/oblique-plain. Regenerate with:
#
#   tests/data/dicom/make_fixtures.sh /tmp/coapt-it-dicom-jpeg-lossless-PID/oblique-plain
set -euo pipefail
src="$1"
here="$(cd "$(dirname "$0")" && pwd)"
for kind in sv1 p14_sv6 baseline; do
  rm -rf "${here:?}/dcmtk_$kind"
  mkdir -p "$here/dcmtk_$kind"
done
for f in "$src"/*; do
  b="$(basename "$f")"
  # JPEG lossless, first-order prediction (1.2.840.10008.1.2.4.70).
  dcmcjpeg +e1 "$f" "$here/dcmtk_sv1/$b"
  # JPEG lossless Process 14, predictor 6 (1.2.840.10008.1.2.4.57).
  dcmcjpeg +el +sv 6 "$f" "$here/dcmtk_p14_sv6/$b"
  # JPEG baseline (1.2.840.10008.1.2.4.50): dcmcjpeg rescales the 16-bit
  # values to 8 bits (a Rescale Slope of about 16 HU per grey level) before
  # the lossy DCT — what coapt refuses.
  dcmcjpeg +eb "$f" "$here/dcmtk_baseline/$b"
done
