#!/usr/bin/env bash
# Regenerates the Liu (2007) reproduction report (issue 16, item 5):
# docs/validation/liu-2007.md and its plots docs/validation/liu-2007/*.png, from the scenes in
# examples/liu2007/. Builds geardyn and the branch time-series helper
# (examples/liu2007_orbit.rs), then runs scripts/liu2007_report.py, which runs every sweep and
# measures every geardyn number in the report from their CSVs (work files: target/liu2007/).
#
#   bash scripts/liu2007_report.sh            # everything (about 5 minutes on 2 cores, idle)
#   bash scripts/liu2007_report.sh --reuse    # reuse the CSVs of an earlier run (editing the text)
#
# Python: $PYTHON, else ./.venv/bin/python (scripts/setup-python.sh), else python3; it needs
# numpy, pandas and matplotlib. The Ch. 3 perturbation oracle (tests/python/liu_ch3.py) is
# used for extra reference numbers when present (or from $LIU_CH3_ORACLE, a folder holding it).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
cargo build --release --quiet --bin geardyn --example liu2007_orbit
python=${PYTHON:-}
if [ -z "$python" ]; then
  if [ -x "$root/.venv/bin/python" ]; then python="$root/.venv/bin/python"; else python=python3; fi
fi
if ! "$python" -c 'import numpy, pandas, matplotlib' 2>/dev/null; then
  echo "liu2007_report: $python lacks numpy, pandas or matplotlib; set PYTHON to an interpreter" \
       "that has them, or run scripts/setup-python.sh (creates ./.venv)" >&2
  exit 1
fi
exec "$python" "$root/scripts/liu2007_report.py" "$@"
