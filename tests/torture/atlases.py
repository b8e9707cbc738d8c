#!/usr/bin/python3
"""Meshes every mricron-data atlas, every label, image to refined tets, and referees each mesh
(issue 20's atlas table).

  atlases.py [--only NAME,NAME] [--frontmesh BIN] [--out DIR] [--timeout S] [--json FILE]

One recipe per atlas (the settings of examples/aal-atlas.yaml: every label, a 1.5 mm
multi-label blur, h = 1 mm; the thresholded ch2 whole head as in examples/colin27-brain.yaml),
run with `frontmesh run --threads 1`. For each: exit status, the slowest stage's wall time and
peak memory (limits 300 s and 8 GB per stage), ../shared/tools/meshcheck.py --strict-surface
against the remeshed surface, and the quality figures. Prints a Markdown table; exit 0 when
every atlas meshed validly within the limits. A missing atlas file is reported as skipped.
"""
import argparse
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
from run import meshcheck_path  # noqa: E402

TEMPLATES = "/usr/share/mricron/templates"
ATLAS = """input:
  image: {image}
  labels: all
extract:
  blur_sigma_mm: 1.5
remesh:
  edge_length: 1.0
  curvature_angle_deg: 20
  max_volume_change_percent: 0.45
output:
  dir: out
"""
HEAD = """input:
  image: {image}
  threshold: {threshold}
extract:
  closing_voxels: 1
  opening_voxels: 1
  blur_sigma_mm: 1.5
repair:
  min_component_volume_mm3: 30
remesh:
  edge_length: 1.55
output:
  dir: out
"""
CASES = [
    ("aal", "aal.nii.gz", ATLAS, {}),
    ("brodmann", "brodmann.nii.gz", ATLAS, {}),
    ("JHU-WhiteMatter-1mm", "JHU-WhiteMatter-labels-1mm.nii.gz", ATLAS, {}),
    ("JHU-WhiteMatter-2mm", "JHU-WhiteMatter-labels-2mm.nii.gz", ATLAS, {}),
    ("HarvardOxford-cort", "HarvardOxford-cort-maxprob-thr0-1mm.nii.gz", ATLAS, {}),
    ("HarvardOxford-sub", "HarvardOxford-sub-maxprob-thr0-1mm.nii.gz", ATLAS, {}),
    ("AICHA", "AICHAmc.nii.gz", ATLAS, {}),
    ("jhu189", "jhu189.nii.gz", ATLAS, {}),
    ("natbrainlab", "natbrainlab.nii.gz", ATLAS, {}),
    ("inia19-NeuroMaps", "inia19-NeuroMaps.nii.gz", ATLAS, {}),
    ("ch2-head", "ch2.nii.gz", HEAD, {"threshold": 30}),
]


def run_atlas(name, image, template, extra, args):
    d = os.path.join(args.out, name)
    os.makedirs(d, exist_ok=True)
    recipe = os.path.join(d, "recipe.yaml")
    with open(recipe, "w") as f:
        f.write(template.format(image=image, **extra))
    row = {"atlas": name, "ok": False}
    t0 = time.time()
    try:
        p = subprocess.run([args.frontmesh, "run", recipe, "--threads", "1", "--quiet", "--force"],
                           cwd=d, capture_output=True, text=True, timeout=args.timeout)
    except subprocess.TimeoutExpired:
        row["error"] = "no result after %d s" % args.timeout
        return row
    row["wall_s"] = round(time.time() - t0, 1)
    if p.returncode != 0:
        row["error"] = "exit %d: %s" % (p.returncode, (p.stderr.strip().splitlines() or [""])[-1][:200])
        return row
    out = os.path.join(d, "out")
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    stages = summary["stages"]
    row["slowest_stage_s"] = max(s.get("wall_s", 0) for s in stages)
    row["peak_mb"] = max(s.get("peak_rss_mb", 0) for s in stages)
    row["warnings"] = sum(len(s.get("warnings", [])) for s in stages)
    # Issue 20 item 2: faces that kept their background triangles, and whether remesh fell
    # back to the whole background; item 6: the remeshed surface's quality.
    remesh = next((s.get("counters", {}) for s in stages if s.get("name") == "remesh"), {})
    row["copied_faces"] = int(remesh.get("remesh.faces_copied_from_background", 0))
    row["fallback"] = int(remesh.get("remesh.fallback_to_background", 0))
    row["surface_min_angle"] = remesh.get("remesh.min_angle_deg")
    row["surface_mean_eta"] = remesh.get("remesh.mean_eta")
    js = os.path.join(d, "meshcheck.json")
    q = subprocess.run(["/usr/bin/python3", meshcheck_path(), os.path.join(out, "mesh.vtu"),
                        "--surface", os.path.join(out, "checkpoints", "03-remesh.vtu"),
                        "--strict-surface", "--json", js], capture_output=True, text=True)
    if q.returncode != 0 or not os.path.exists(js):
        row["error"] = "meshcheck exit %d" % q.returncode
        return row
    with open(js) as f:
        report = json.load(f)
    row["regions"] = report["n_regions"]
    row["valid"] = report["valid"]
    row["tets"] = report["n_tets"]
    row["skew_gt_08"] = report["skewness"]["frac_gt_0_8"]
    row["min_dihedral"] = report["dihedral"]["min_deg"]
    row["ok"] = row["valid"] and row["slowest_stage_s"] <= 300 and row["peak_mb"] <= 8192
    if not row["ok"]:
        row["error"] = "invalid mesh, or a stage over 300 s or 8 GB"
    return row


def fmt(value, pattern):
    return "" if value is None else pattern % value


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", help="comma-separated atlas names")
    ap.add_argument("--frontmesh", default=os.path.join(REPO, "build", "pipeline", "frontmesh"))
    ap.add_argument("--out", default=os.path.join("/tmp", "frontmesh-atlases"))
    ap.add_argument("--timeout", type=int, default=3600)
    ap.add_argument("--json", help="write every atlas's row here")
    args = ap.parse_args()
    args.frontmesh = os.path.abspath(args.frontmesh)
    if meshcheck_path() is None:
        print("FRONTMESH-TEST-SKIPPED: ../shared/tools/meshcheck.py not found")
        return 0
    only = set(args.only.split(",")) if args.only else None
    rows = []
    print("| atlas | regions | tets | wall s | slowest stage s | peak MB | skew > 0.8 | "
          "min dihedral | surface min angle | surface mean eta | copied faces | warnings | result |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name, file, template, extra in CASES:
        if only and name not in only:
            continue
        image = os.path.join(TEMPLATES, file)
        if not os.path.exists(image):
            rows.append({"atlas": name, "skipped": True})
            print("| %s | | | | | | | | | | | | skipped: %s missing |" % (name, image), flush=True)
            continue
        r = run_atlas(name, image, template, extra, args)
        rows.append(r)
        if "regions" in r:
            copied = "whole background" if r["fallback"] else str(r["copied_faces"])
            print("| %s | %d | %s | %.0f | %.0f | %.0f | %.4f%% | %.2f | %s | %s | %s | %d | %s |" % (
                name, r["regions"], r["tets"], r["wall_s"], r["slowest_stage_s"], r["peak_mb"],
                100 * r["skew_gt_08"], r["min_dihedral"], fmt(r["surface_min_angle"], "%.2f"),
                fmt(r["surface_mean_eta"], "%.3f"), copied, r["warnings"],
                "ok" if r["ok"] else r["error"]), flush=True)
        else:
            print("| %s | | | | | | | | | | | | FAIL: %s |" % (name, r.get("error")), flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)
    return 0 if all(r.get("ok") or r.get("skipped") for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
