#!/usr/bin/python3
"""Runs torture corpus cases (corpus.py) through the whole pipeline and referees each result.

  run.py [--seeds A-B | --seeds 1,5,9] [-j N] [--frontmesh BIN] [--out DIR] [--keep]
         [--timeout S] [--strict-quality] [--json FILE]

For every seed: make the case, run `frontmesh run` (images: every stage; surfaces:
--from tetra), then check
  run      exit 0 within the time limit (a time-out is a hang), no stage over 300 s or 8 GB
  valid    ../shared/tools/meshcheck.py mesh.vtu --surface <tetra input> --strict-surface
           says VALID with the surface preserved, and `frontmesh check mesh.vtu` exits 0
  labels   every label of the image is a region of the mesh, or named in a warning
           ("label L", not "label L0") or in a stage's dropped_components
  volume   regions of at least 1,000 voxels: mesh volume within 2% of the voxel volume
  quality  skewness > 0.8 for at most 0.010% of tets, min dihedral >= 10 deg, remeshed
           surface min angle >= 20 deg and mean eta <= 0.05 (issue 20 item 6)
run/valid failures always count; labels/volume/quality count with --strict-quality and are
otherwise listed as deficits. One line per failure with the seed and the command that
reproduces it; the last line is 'N passed, N failed'. Exit 0 when nothing failed.
The long mode is simply a larger seed range, e.g. run.py --seeds 0-799 -j 2 (see README).
"""
import argparse
import concurrent.futures
import json
import os
import re
import shutil
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
import corpus  # noqa: E402


def parse_seeds(text):
    seeds = []
    for part in text.split(","):
        if "-" in part:
            a, b = part.split("-")
            seeds += list(range(int(a), int(b) + 1))
        else:
            seeds.append(int(part))
    return seeds


def meshcheck_path():
    env = os.environ.get("FRONTMESH_MESHCHECK")
    if env:
        return env if os.path.exists(env) else None
    p = os.path.join(REPO, "..", "shared", "tools", "meshcheck.py")
    return p if os.path.exists(p) else None


def run_case(seed, args):
    d = os.path.join(args.out, "%05d" % seed)
    shutil.rmtree(d, ignore_errors=True)
    case = corpus.make_case(seed, d)
    cmd = [args.frontmesh, "run", os.path.join(d, "recipe.yaml"), "--threads", "1", "--quiet"]
    if case.get("from"):
        cmd += ["--from", case["from"]]
    repro = "tests/torture/run.py --seeds %d --keep   # or: tests/torture/corpus.py %d DIR && %s" % (
        seed, seed, " ".join(["frontmesh"] + cmd[1:2] + ["DIR/recipe.yaml"] + cmd[3:]))
    res = {"seed": seed, "family": case["family"], "fail": [], "deficit": [], "repro": repro}
    t0 = time.time()
    try:
        p = subprocess.run(cmd, cwd=d, capture_output=True, text=True, timeout=args.timeout)
    except subprocess.TimeoutExpired:
        res["fail"].append("run: no result after %d s (hang?)" % args.timeout)
        return finish(res, d, args)
    res["wall_s"] = round(time.time() - t0, 2)
    if p.returncode != 0:
        last = (p.stderr.strip().splitlines() or ["(no message)"])[-1]
        res["fail"].append("run: exit %d: %s" % (p.returncode, last[:300]))
        return finish(res, d, args)
    out = os.path.join(d, "out")
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    warnings = [w for s in summary["stages"] for w in s.get("warnings", [])]
    # Components a stage did not mesh (issue 20): named beside their warning line.
    dropped = [c for s in summary["stages"] for c in s.get("dropped_components", [])]
    res["dropped_components"] = len(dropped)
    for s in summary["stages"]:
        if s.get("wall_s", 0) > 300:
            res["fail"].append("run: %s took %.0f s (limit 300 s)" % (s["name"], s["wall_s"]))
        if s.get("peak_rss_mb", 0) > 8192:
            res["fail"].append("run: %s peaked at %.0f MB (limit 8 GB)" % (s["name"], s["peak_rss_mb"]))
    surface_ref = (os.path.join(d, "surface.vtp") if case["kind"] == "surface"
                   else os.path.join(out, "checkpoints", "03-remesh.vtu"))
    mc = meshcheck_path()
    report = {}
    if mc:
        js = os.path.join(d, "meshcheck.json")
        q = subprocess.run(["/usr/bin/python3", mc, os.path.join(out, "mesh.vtu"), "--surface",
                            surface_ref, "--strict-surface", "--json", js],
                           capture_output=True, text=True, timeout=args.timeout)
        if q.returncode != 0 or not os.path.exists(js):
            lines = [l for l in q.stdout.splitlines() if "RESULT" in l or "INVALID" in l]
            res["fail"].append("valid: meshcheck exit %d %s" % (q.returncode, (lines or [""])[-1][:200]))
        else:
            with open(js) as f:
                report = json.load(f)
    c = subprocess.run([args.frontmesh, "check", os.path.join(out, "mesh.vtu")],
                       capture_output=True, text=True, timeout=args.timeout)
    if c.returncode != 0:
        res["fail"].append("valid: frontmesh check exit %d" % c.returncode)
    if report:
        check_figures(case, report, summary, warnings, dropped, res)
    return finish(res, d, args)


def check_figures(case, report, summary, warnings, dropped, res):
    regions = report.get("regions", {})
    for label, info in case.get("labels", {}).items():
        # "label 1" must not match "label 12": the number ends at a non-digit.
        pattern = re.compile(r"\b(label|region) %s(?!\d)" % re.escape(label))
        named = (any(pattern.search(w) for w in warnings) or
                 any(str(c["label"]) == label for c in dropped))
        if label not in regions:
            if not named:
                res["deficit"].append("labels: label %s (%d voxels) is not in the mesh and no "
                                      "warning names it" % (label, info["voxels"]))
            continue
        if info["voxels"] >= 1000:
            rel = regions[label]["volume"] / info["volume_mm3"] - 1.0
            res.setdefault("worst_volume_rel", 0.0)
            res["worst_volume_rel"] = max(res["worst_volume_rel"], abs(rel))
            if abs(rel) > 0.02:
                res["deficit"].append("volume: region %s %+.2f%% of its %d voxels' volume" % (
                    label, 100 * rel, info["voxels"]))
    skew = report["skewness"]["frac_gt_0_8"]
    dih = report["dihedral"]["min_deg"]
    res["skew_gt_08"] = skew
    res["min_dihedral"] = dih
    if skew > 1e-4:
        res["deficit"].append("quality: %.4f%% of tets with skewness > 0.8" % (100 * skew))
    if dih < 10.0:
        res["deficit"].append("quality: min dihedral %.2f deg" % dih)
    if case["kind"] == "image":
        remesh = next((s for s in summary["stages"] if s["name"] == "remesh"), None)
        if remesh:
            q = remesh["quality"]
            res["surface_min_angle"] = q["min_angle_deg"]
            res["surface_mean_eta"] = q["eta_mean"]
            if q["min_angle_deg"] < 20.0:
                res["deficit"].append("quality: remeshed surface min angle %.2f deg" % q["min_angle_deg"])
            if q["eta_mean"] > 0.05:
                res["deficit"].append("quality: remeshed surface mean eta %.3f" % q["eta_mean"])


def finish(res, d, args):
    failed = res["fail"] or (args.strict_quality and res["deficit"])
    if not failed and not args.keep:
        shutil.rmtree(d, ignore_errors=True)
    return res


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", default="0-15")
    ap.add_argument("-j", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--frontmesh", default=os.path.join(REPO, "build", "pipeline", "frontmesh"))
    ap.add_argument("--out", default=os.path.join("/tmp", "frontmesh-torture"))
    ap.add_argument("--keep", action="store_true", help="keep every case folder, not only failures")
    ap.add_argument("--timeout", type=int, default=600, help="seconds per case before it counts as a hang")
    ap.add_argument("--strict-quality", action="store_true")
    ap.add_argument("--json", help="write every case's result here")
    args = ap.parse_args()
    args.frontmesh = os.path.abspath(args.frontmesh)
    if not os.path.exists(args.frontmesh):
        print("run.py: %s not found (build first, or --frontmesh BIN)" % args.frontmesh)
        return 2
    if meshcheck_path() is None:
        print("FRONTMESH-TEST-SKIPPED: ../shared/tools/meshcheck.py not found (or FRONTMESH_MESHCHECK)")
        return 0
    os.makedirs(args.out, exist_ok=True)
    seeds = parse_seeds(args.seeds)
    corpus.cube_classes_cached = corpus.cube_classes()  # once, not per case
    t0 = time.time()
    results = []
    with concurrent.futures.ThreadPoolExecutor(max_workers=args.j) as pool:
        for res in pool.map(lambda s: run_case(s, args), seeds):
            results.append(res)
            bad = res["fail"] + (res["deficit"] if args.strict_quality else [])
            for b in bad:
                print("FAIL seed %d (%s): %s\n     reproduce: %s" % (res["seed"], res["family"], b, res["repro"]),
                      flush=True)
            if not args.strict_quality:
                for b in res["deficit"]:
                    print("deficit seed %d (%s): %s" % (res["seed"], res["family"], b), flush=True)
    failed = [r for r in results if r["fail"] or (args.strict_quality and r["deficit"])]
    wall = time.time() - t0
    figures = [r for r in results if "min_dihedral" in r]
    if figures:
        print("worst: min dihedral %.2f deg (seed %d); skewness > 0.8 %.4f%% (seed %d)" % (
            min(r["min_dihedral"] for r in figures), min(figures, key=lambda r: r["min_dihedral"])["seed"],
            100 * max(r["skew_gt_08"] for r in figures), max(figures, key=lambda r: r["skew_gt_08"])["seed"]))
    print("torture: seeds %s, %d cases in %.0f s, %d with deficits" % (
        args.seeds, len(results), wall, sum(1 for r in results if r["deficit"])))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=1)
    print("%d passed, %d failed" % (len(results) - len(failed), len(failed)))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
