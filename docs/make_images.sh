#!/usr/bin/env bash
# The figures shown in docs/plots.md, one of each kind, small (80 dpi), from the demo's outputs.
#   make images        (= make demo, then docs/make_images.sh demo-out)
set -euo pipefail
DEMO=${1:-demo-out}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
BIN=${BIN:-$ROOT/.venv/bin/}
F=$ROOT/fixtures
O=$ROOT/docs/images
P=(-q --dpi 80)
mkdir -p "$O"
"${BIN}plot" hill --hill oberstdorf_hs106 -o "$O/hill.png" "${P[@]}"
"${BIN}plot" track "$DEMO/skijump/smoothed.parquet" -o "$O/track.png" "${P[@]}"
"${BIN}plot" speed "$DEMO/skijump/smoothed.parquet" -o "$O/speed.png" "${P[@]}"
"${BIN}plot" series "$DEMO/skijump/smoothed.parquet" -o "$O/series.png" "${P[@]}"
"${BIN}plot" errors "$DEMO/skijump/smoothed.parquet" --truth "$F/skijump/truth.parquet" -o "$O/errors.png" "${P[@]}"
"${BIN}plot" mag "$DEMO/skijump/smoothed.parquet" -o "$O/mag.png" "${P[@]}"
"${BIN}plot" spline "$DEMO/skirace/attitude.parquet" --truth "$F/skirace/truth.parquet" -o "$O/spline.png" "${P[@]}"
"${BIN}plot" series "$DEMO/skirace/attitude.parquet" -o "$O/series-skirace.png" "${P[@]}"
"${BIN}plot" gates "$DEMO/gates/anchored.parquet" --gates "$F/gates/survey.parquet" -o "$O/gates.png" "${P[@]}"
"${BIN}plot" body "$DEMO/gates_body/anchored.parquet" --gates "$F/gates_body/raw/survey.parquet" -o "$O/body.png" "${P[@]}"
"${BIN}plot" holds "$DEMO/climbing/holds.parquet" --holds "$F/climbing/holds.parquet" \
  --truth "$F/climbing/truth.parquet" -o "$O/holds.png" "${P[@]}"
# two simulated runs of one course (the ones tests/test_compare_runs.py uses), compared gate by gate
T=$(mktemp -d)
"${BIN}python" -c "from sportfusion.skirace.sim_runs import run_table as r; import sys; [open(f'$T/{k}.parquet', 'wb').write(r(k)) for k in 'AB']"
"${BIN}compare-runs" -q "$T/A.parquet" --run "$T/B.parquet" --label A --label B --profile "$T/prof.parquet" -o "$T/cmp.parquet"
"${BIN}plot" compare "$T/cmp.parquet" --profile "$T/prof.parquet" -o "$O/compare.png" "${P[@]}"
rm -rf "$T"
# a 256-colour palette keeps each image at a few tens of KB (Pillow comes with matplotlib)
"${BIN}python" -c "
import sys
from PIL import Image
for f in sys.argv[1:]:
    Image.open(f).convert('RGB').quantize(256, dither=Image.Dither.NONE).save(f, optimize=True)
" "$O"/*.png
ls -l "$O"
