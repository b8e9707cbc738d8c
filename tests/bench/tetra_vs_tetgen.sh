#!/usr/bin/env bash
# Benchmark of the tetra stage (issue 4) against Debian's tetgen on the very same closed surface.
# Not part of the test suite.
#
# usage: tests/bench/tetra_vs_tetgen.sh SURFACE.vtu [ALPHA] [WORKDIR]
#   SURFACE.vtu  closed, oriented surface (e.g. a remesh or repair checkpoint)
#   ALPHA        tetra.stretching (default 1.15)
#   WORKDIR      scratch folder (default /tmp/tetra_vs_tetgen)
# environment: FRONTMESH (the frontmesh executable; default build-main's), TETGEN_SWITCHES
#   (default -pYq1.3; several sets separated by commas, e.g. "-pYq1.3,-pYq1.2,-pYq1.2 -O7"),
#   THREADS (frontmesh --threads, default 1: the issue's one-core figure), REFINE (1: the
#   frontmesh row is tetra + refine, the issue 5 comparison; default 0: tetra alone),
#   REPS (runs of every tool, in turn: frontmesh, then each tetgen set, REPS times; the table
#   shows each tool's median wall and CPU time and its largest peak memory; default 1. On a
#   shared host, where one run can take 30% longer than the next, use 3 or 5)
#
# Runs `frontmesh run RECIPE --from tetra --until tetra` with
#   {input: {surface: SURFACE}, output: {dir: WORKDIR/frontmesh}, tetra: {stretching: ALPHA}}
# and `tetgen $TETGEN_SWITCHES` on the surface converted to .smesh, both under /usr/bin/time -v,
# checks both results with meshcheck.py --json and prints wall and CPU (user + system) time,
# peak RSS, tets, tets/s (per wall second), quality and the frontmesh/tetgen ratios. On a
# shared machine the CPU time is the steadier figure.
set -euo pipefail

SURFACE=$(realpath "${1:?usage: $0 SURFACE.vtu [ALPHA] [WORKDIR]}")
ALPHA=${2:-1.15}
WORK=${3:-/tmp/tetra_vs_tetgen}
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
FRONTMESH=${FRONTMESH:-$ROOT/build-main/pipeline/frontmesh}
TETGEN_SWITCHES=${TETGEN_SWITCHES:--pYq1.3}
MESHCHECK=${MESHCHECK:-$ROOT/../shared/tools/meshcheck.py}
[ -f "$MESHCHECK" ] || MESHCHECK=/work/shared/tools/meshcheck.py
PY=/usr/bin/python3
THREADS=${THREADS:-1}
REFINE=${REFINE:-0}
UNTIL=tetra
[ "$REFINE" = 1 ] && UNTIL=refine

rm -rf "$WORK"
mkdir -p "$WORK/frontmesh" "$WORK/tetgen"

# ---- frontmesh tetra --------------------------------------------------------------------
cat > "$WORK/recipe.yaml" <<EOF
input:
  surface: $SURFACE
output:
  dir: $WORK/frontmesh
tetra:
  stretching: $ALPHA
EOF
REPS=${REPS:-1}
run_frontmesh() {  # run_frontmesh REP: timings in frontmesh/time-REP.txt
    /usr/bin/time -v "$FRONTMESH" run "$WORK/recipe.yaml" --from tetra --until "$UNTIL" \
        --threads "$THREADS" --force > "$WORK/frontmesh/log.txt" 2> "$WORK/frontmesh/time-$1.txt" || {
        echo "frontmesh failed:"; tail -20 "$WORK/frontmesh/time-$1.txt"; exit 1; }
}
run_frontmesh 1
FM_MESH=$WORK/frontmesh/mesh.vtu
[ -f "$FM_MESH" ] || FM_MESH=$(ls "$WORK"/frontmesh/checkpoints/*-tetra.vtu | head -1)

# ---- tetgen on the same surface -----------------------------------------------------------
# (read with meshcheck's own reader: meshio cannot read VTK's raw appended data)
$PY - "$SURFACE" "$WORK/tetgen/surf.smesh" "$(dirname "$MESHCHECK")" <<'EOF'
import sys
sys.path.insert(0, sys.argv[3])
from meshcheck import read_mesh
P, _, tris, _, _ = read_mesh(sys.argv[1])
with open(sys.argv[2], "w") as f:
    f.write("%d 3 0 0\n" % len(P))
    for i, p in enumerate(P):
        f.write("%d %.17g %.17g %.17g\n" % (i, p[0], p[1], p[2]))
    f.write("%d 0\n" % len(tris))
    for a, b, c in tris:
        f.write("3 %d %d %d\n" % (a, b, c))
    f.write("0\n0\n")
EOF
# One run per switch set, each in its own folder (tetgen-1, tetgen-2, ...).
IFS=',' read -r -a SWITCH_SETS <<< "$TETGEN_SWITCHES"
TG_NAMES=""
k=0
for SW in "${SWITCH_SETS[@]}"; do
    k=$((k + 1))
    D="$WORK/tetgen-$k"
    mkdir -p "$D"
    cp "$WORK/tetgen/surf.smesh" "$D/"
    echo "$SW" > "$D/switches.txt"
    ( cd "$D" && /usr/bin/time -v tetgen $SW -Q surf.smesh > log.txt 2> time-1.txt ) || {
        echo "tetgen $SW failed:"; tail -20 "$D/time-1.txt"; exit 1; }
    $PY - "$D/surf.1" "$D/mesh.vtu" <<'PYEOF'
import sys
import meshio
import numpy as np
base = sys.argv[1]
def rows(path):
    with open(path) as f:
        lines = [l.split("#")[0].split() for l in f]
    lines = [l for l in lines if l]
    n = int(lines[0][0])
    return lines[1:1 + n]
nodes = rows(base + ".node")
first = int(nodes[0][0])
P = np.array([[float(v) for v in r[1:4]] for r in nodes])
T = np.array([[int(v) - first for v in r[1:5]] for r in rows(base + ".ele")], dtype=np.int64)
meshio.write(sys.argv[2], meshio.Mesh(P, [("tetra", T)]))
PYEOF
    TG_NAMES="$TG_NAMES tetgen-$k"
done

# ---- further runs, every tool in turn (same host noise for all) -------------------------
for ((r = 2; r <= REPS; r++)); do
    run_frontmesh "$r"
    for T in $TG_NAMES; do
        SW=$(cat "$WORK/$T/switches.txt")
        ( cd "$WORK/$T" && /usr/bin/time -v tetgen $SW -Q surf.smesh > log.txt 2> "time-$r.txt" ) || {
            echo "tetgen $SW failed:"; tail -20 "$WORK/$T/time-$r.txt"; exit 1; }
    done
done

# ---- referee ------------------------------------------------------------------------------
check() {  # check NAME MESH: meshcheck with the surface kept; ok.txt says whether it passed
    if $PY "$MESHCHECK" "$2" --surface "$SURFACE" --strict-surface --json "$WORK/$1/check.json" \
        > "$WORK/$1/check.txt" 2>&1; then echo yes > "$WORK/$1/ok.txt"; else echo NO > "$WORK/$1/ok.txt"; fi
}
check frontmesh "$FM_MESH"
for T in $TG_NAMES; do check "$T" "$WORK/$T/mesh.vtu"; done

$PY - "$WORK" "$ALPHA" "$UNTIL" "$REPS" frontmesh $TG_NAMES <<'PYEOF'
import json, re, statistics, sys
work, alpha, until, reps = sys.argv[1:5]
reps = int(reps)
names = sys.argv[5:]
def timing(path):
    t = open(path).read()
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (\S+)", t).group(1)
    s = 0.0
    for part in wall.split(":"):
        s = s * 60 + float(part)
    rss = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", t).group(1)) / 1024.0
    cpu = float(re.search(r"User time \(seconds\): (\S+)", t).group(1)) + \
        float(re.search(r"System time \(seconds\): (\S+)", t).group(1))
    return s, rss, cpu
rows = {}
def timings(name):  # median wall and CPU, largest peak memory over the runs
    runs = [timing("%s/%s/time-%d.txt" % (work, name, r)) for r in range(1, reps + 1)]
    return (statistics.median(t[0] for t in runs), max(t[1] for t in runs),
            statistics.median(t[2] for t in runs))
for name in names:
    wall, rss, cpu = timings(name)
    c = json.load(open("%s/%s/check.json" % (work, name)))
    if name == "frontmesh":
        label = "frontmesh %s a%s" % ("tetra" if until == "tetra" else "tetra+refine", alpha)
    else:
        label = "tetgen " + open("%s/%s/switches.txt" % (work, name)).read().strip()
    rows[name] = dict(label=label, wall=wall, cpu=cpu, rss=rss, tets=c["n_tets"], nodes=c["n_nodes"],
                      ok=open("%s/%s/ok.txt" % (work, name)).read().strip(),
                      bnd=c["boundary_faces"], skew08=100 * c["skewness"]["frac_gt_0_8"],
                      skewmean=c["skewness"]["mean"], dmin=c["dihedral"]["min_deg"],
                      d10=100 * c["dihedral"]["frac_tets_min_lt_10"])
print("surface: %s boundary triangles" % rows["frontmesh"]["bnd"])
if reps > 1:
    print("times: median of %d runs per tool, in turn; peak memory: the largest" % reps)
print("%-30s %8s %8s %8s %10s %9s %9s %8s %9s %8s %8s %6s" % ("tool", "wall s", "cpu s", "peak MB",
      "tets", "nodes", "tets/s", "skew>.8%", "skew mean", "min dih", "<10deg%", "valid"))
for name in names:
    r = rows[name]
    print("%-30s %8.2f %8.2f %8.0f %10d %9d %9.0f %8.4f %9.3f %8.2f %8.4f %6s" % (
        r["label"], r["wall"], r["cpu"], r["rss"], r["tets"], r["nodes"], r["tets"] / max(r["wall"], 1e-9),
        r["skew08"], r["skewmean"], r["dmin"], r["d10"], r["ok"]))
f = rows["frontmesh"]
for name in names[1:]:
    t = rows[name]
    print("ratios frontmesh/(%s): wall %.2f, cpu %.2f, peak memory %.2f, tets %.2f, tets/s %.2f" % (
        t["label"], f["wall"] / t["wall"], f["cpu"] / max(t["cpu"], 1e-9), f["rss"] / t["rss"],
        f["tets"] / t["tets"], (f["tets"] / f["wall"]) / (t["tets"] / t["wall"])))
print("frontmesh per boundary triangle: %.2f tets, %.2f nodes" % (f["tets"] / f["bnd"], f["nodes"] / f["bnd"]))
PYEOF
