#!/usr/bin/env bash
# A plain `pip install .` (no extras) in a fresh venv, then the main commands: an import that is
# not a declared dependency fails here (the test venv has every extra and test tool installed).
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON="${PYTHON:-python3}"
work="$(mktemp -d "${TMPDIR:-/tmp}/sescid-plain.XXXXXX")"
trap 'rm -rf "$work"' EXIT
"$PYTHON" -m venv "$work/venv"
"$work/venv/bin/python" -m pip install -q --upgrade pip >/dev/null
"$work/venv/bin/python" -m pip install -q . >"$work/pip.log" 2>&1 || { cat "$work/pip.log"; exit 1; }
sescid="$work/venv/bin/sescid"
cd "$work"
# the wheel carries the kernels compiled when it was built (tools/build_backend): the first
# command after the install loads them and compiles none
"$work/venv/bin/python" - <<'PY'
import sys
from sescid.cli import cli
from sescid.kinematics import counting_compiles
with counting_compiles() as names:
    cli.main(["poses", "--robot", "op2", "--count", "38", "--seed", "0", "--out", "first.csv"],
             standalone_mode=False)
if names:
    sys.exit(f"the first poses after the install compiled {sorted(set(names))}")
print("first poses after the install: every kernel loaded from the wheel's cache")
PY
set -x
"$sescid" --version
"$sescid" demo --out-dir demo_out
"$sescid" simulate --robot op2 --count 1000 --range-deg 30 --noise 0.00493 --seed 0 --out sim.csv
"$sescid" identify sim.csv --robot op2 --method consistent --total-mass 2.97 --out fit.json
"$sescid" export fit.json --out op2_identified.urdf
"$sescid" poses --robot op2 --count 38 --select d-optimal --seed 0 --out poses.csv
"$sescid" experiment --robot op2 --poses poses.csv --samples 100 --seed 0 --out raw.csv --truth truth.json
"$sescid" fsr raw.csv --robot op2 --poses poses.csv --out measured.csv
"$sescid" identify measured.csv --robot op2 --weighted --out fit_w.json
"$sescid" export fit_w.json --out op2_walkthrough.urdf
"$sescid" report fit_w.json measured.csv --out-dir report
"$sescid" audit measured.csv --models op2 --json audit.json
"$sescid" compare fit.json fit_w.json --json compare.json
"$sescid" identify measured.csv --robot op2 --payload MP_ARM_LOW_R --base fit_w.json --out payload.json
# the example models ship in the wheel and load by name from this folder (outside the clone)
"$sescid" simulate --robot wheeled_humanoid --support axle --line y --count 40 --range-deg 40 --seed 1 --out balance.csv
"$sescid" identify balance.csv --robot wheeled_humanoid --support axle --line y --method map --out balance_fit.json
# a command that needs an extra says which, in one line, and exits 2
mkdir bag_folder
echo '{"format": "sescid-bag-mapping/1", "joints": {"topic": "/j"},
       "feet": {"right": {"source": "pads", "topic": "/f"}}}' >map.json
set +e
"$sescid" bag bag_folder --map map.json --out raw_bag.csv 2>err.txt
code=$?
set -e
cat err.txt
test "$code" = 2 && test "$(wc -l <err.txt)" = 1
grep -q "needs the bags extra: pip install 'sescid\[bags\]'" err.txt
"$work/venv/bin/python" - <<'PY'
import sys
for mod in ("lxml", "mujoco", "rosbags", "viser", "trimesh", "pinocchio", "yourdfpy"):
    try:
        __import__(mod)
    except ImportError:
        continue
    sys.exit(f"{mod} is installed by a plain `pip install .`: the check would not see it")
print("plain install: no optional package present")
PY
