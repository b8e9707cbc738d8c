#!/usr/bin/python3
"""Runs the surfaces of tests/torture/regressions/ through the stages and referees each.

  regressions.py [--frontmesh BIN] [--out DIR] [--timeout S]

Each *.vtu there is a valid surface on which a stage once failed (README.md says which and
why). For each: `frontmesh run` of a recipe with the surface as input.surface, from tetra
(the surface goes to tetra as it is) or, for the names starting with `remesh-`, from repair
(a background surface, remeshed first); a NAME.yaml beside NAME.vtu adds recipe keys. Then
  run    exit 0 within the time limit (a time-out is a hang)
  valid  ../shared/tools/meshcheck.py mesh.vtu --surface <tetra's input> --strict-surface
         says VALID
One line per surface; the last line is 'N passed, N failed'. Exit 0 when nothing failed.
"""

import argparse
import fnmatch
import glob
import os
import shutil
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import run as torture  # noqa: E402  (meshcheck_path)


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frontmesh", default=os.path.join(torture.REPO, "build", "pipeline", "frontmesh"))
    ap.add_argument("--out", default=os.path.join("/tmp", "frontmesh-regressions"))
    ap.add_argument("--timeout", type=int, default=300)
    ap.add_argument("--only", default="*",
                    help="a name pattern (fnmatch), e.g. 'tetra-*' (the sanitizer run of CI)")
    args = ap.parse_args()
    meshcheck = torture.meshcheck_path()
    if meshcheck is None:
        print("FRONTMESH-TEST-SKIPPED: ../shared/tools/meshcheck.py not found (or FRONTMESH_MESHCHECK)")
        return 0
    surfaces = sorted(s for s in glob.glob(os.path.join(HERE, "regressions", "*.vtu"))
                      if fnmatch.fnmatch(os.path.splitext(os.path.basename(s))[0], args.only))
    if not surfaces:
        print("regressions.py: no surfaces in %s" % os.path.join(HERE, "regressions"))
        return 1
    passed = failed = 0
    for surface in surfaces:
        name = os.path.splitext(os.path.basename(surface))[0]
        d = os.path.join(args.out, name)
        shutil.rmtree(d, ignore_errors=True)
        os.makedirs(d)
        recipe = os.path.join(d, "recipe.yaml")
        extra = os.path.splitext(surface)[0] + ".yaml"
        with open(recipe, "w") as f:
            f.write("input:\n  surface: %s\noutput:\n  dir: %s\n" % (surface, os.path.join(d, "out")))
            if os.path.exists(extra):
                with open(extra) as e:
                    f.write(e.read())
        from_remesh = name.startswith("remesh-")
        cmd = [args.frontmesh, "run", recipe, "--threads", "1", "--quiet"]
        if not from_remesh:
            cmd[3:3] = ["--from", "tetra"]
        reference = (os.path.join(d, "out", "checkpoints", "03-remesh.vtu") if from_remesh
                     else surface)
        why = None
        try:
            r = subprocess.run(cmd, capture_output=True, text=True, timeout=args.timeout)
            if r.returncode != 0:
                last = (r.stderr.strip().splitlines() or ["?"])[-1]
                why = "exit %d: %s" % (r.returncode, last)
        except subprocess.TimeoutExpired:
            why = "no result after %d s (a hang)" % args.timeout
        if why is None:
            mesh = os.path.join(d, "out", "mesh.vtu")
            c = subprocess.run(["/usr/bin/python3", meshcheck, mesh, "--surface", reference,
                                "--strict-surface"], capture_output=True, text=True)
            if c.returncode != 0 or "RESULT   VALID" not in c.stdout:
                why = "meshcheck: " + (c.stdout.strip().splitlines() or ["?"])[-1]
        if why is None:
            passed += 1
            print("PASS %s" % name)
        else:
            failed += 1
            print("FAIL %s: %s (reproduce: %s)" % (name, why, " ".join(cmd)))
    print("%d passed, %d failed" % (passed, failed))
    return 0 if failed == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
