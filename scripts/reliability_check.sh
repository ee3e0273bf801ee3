#!/usr/bin/env bash
# CLI-level reliability check (not in CI: it needs the shared checker outside the project):
# 24 random incisions, 12 over the built-in block and 12 over meshes/ellipsoid_v22.msh, written
# as path CSVs by random_incision (the property test's generator), replayed by
#   cut_replay --check --out case.vtk --stats case.json   (physics and collapse as configured)
# and each output checked by meshcheck.py (validity, pieces, volume, quality).
#
#   scripts/reliability_check.sh [FIRST_SEED] [EXTRA cut_replay FLAGS...]
# Needs a build in build/ (scripts/test or cmake --build build). Environment: MESHCHECK (default
# ../shared/tools/meshcheck.py next to the project), OUT (default build/reliability).
set -uo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
FIRST="${1:-1}"
shift || true
EXTRA=("$@")
BIN="$ROOT/build/devel/lib/tissue_cut"
MESHCHECK="${MESHCHECK:-$ROOT/../shared/tools/meshcheck.py}"
OUT="${OUT:-$ROOT/build/reliability}"
for tool in "$BIN/random_incision" "$BIN/cut_replay" "$MESHCHECK"; do
  [ -e "$tool" ] || { echo "reliability_check: $tool is missing"; exit 1; }
done
mkdir -p "$OUT"
fail=0
start=$(date +%s)
printf '%-10s %5s %-70s %6s %6s %7s %5s %8s %6s %s\n' mesh seed incision ticks tets cut pieces dVrest/V Qmin meshcheck
for mesh in block ellipsoid_v22.msh; do
  mesh_arg=block
  [ "$mesh" != block ] && mesh_arg="$ROOT/meshes/$mesh"
  for ((seed = FIRST; seed < FIRST + 12; ++seed)); do
    stem="$OUT/${mesh%%.*}_$seed"
    read -r blade rate what < <("$BIN/random_incision" --mesh "$mesh_arg" --seed "$seed" --out "$stem.csv")
    mesh_flag=()
    [ "$mesh" != block ] && mesh_flag=(--mesh "$mesh_arg")
    "$BIN/cut_replay" "${mesh_flag[@]}" --path "$stem.csv" --blade-length "$blade" --rate "$rate" \
      --check --quiet --out "$stem.vtk" --stats "$stem.json" "${EXTRA[@]}" >"$stem.log" 2>&1
    rc=$?
    if [ $rc -ne 0 ]; then
      printf '%-10s %5s %-70s cut_replay exit %d: %s\n' "${mesh%%.*}" "$seed" "${what:0:70}" $rc "$(tail -1 "$stem.log")"
      fail=$((fail + 1))
      continue
    fi
    /usr/bin/python3 "$MESHCHECK" "$stem.vtk" >"$stem.check.json" 2>"$stem.check.log"
    /usr/bin/python3 - "$stem.json" "$stem.check.json" "${mesh%%.*}" "$seed" "$what" <<'PY' || fail=$((fail + 1))
import json, sys
stats, check = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
bad = [k for k in ("inverted", "zero_volume", "faces_shared_by_more_than_two_tets",
                   "faces_with_same_orientation_twice", "boundary_edges_unmatched") if check.get(k, 0)]
v0 = stats["initial"]["volume_rest"]
dv = abs(stats["volume_rest"] - v0) / v0
if dv > 1e-3:
    bad.append("rest volume")
print("%-10s %5s %-70s %6d %6d %7d %5d %8.1e %6.3f %s" % (
    sys.argv[3], sys.argv[4], sys.argv[5][:70], stats["ticks"]["count"], check["tets"],
    stats["cut"]["cut_tetrahedra"], check["components"], dv, check["quality_min"],
    "ok" if not bad else "BAD: " + ", ".join("%s %s" % (k, check.get(k, "")) for k in bad)))
sys.exit(1 if bad else 0)
PY
  done
done
echo "reliability_check: 24 incisions from seed $FIRST, $fail failed, $(( $(date +%s) - start )) s; files in $OUT"
[ $fail -eq 0 ]
