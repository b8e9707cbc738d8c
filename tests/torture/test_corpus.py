#!/usr/bin/python3
"""Self-test of the torture corpus generator: every case is a pure function of its seed,
the 2x2x2 enumeration finds the expected number of classes, and every family writes an
input that frontmesh's referee accepts (surfaces closed and oriented). Prints
'N passed, N failed'; exit 0 when all passed."""
import hashlib
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import corpus  # noqa: E402


def digest(folder):
    h = hashlib.md5()
    for name in sorted(os.listdir(folder)):
        with open(os.path.join(folder, name), "rb") as f:
            h.update(name.encode() + f.read())
    return h.hexdigest()


def main():
    passed = failed = 0

    def check(ok, what):
        nonlocal passed, failed
        print(("ok   " if ok else "FAIL ") + what)
        passed += ok
        failed += not ok

    # 5^8 labelings of 2x2x2 voxels with labels 0..4, up to the 48 symmetries and renaming of
    # labels 1..4: 615 classes, 614 without the empty block.
    check(len(corpus.cube_classes()) == 614, "2x2x2 configurations: 614 non-empty classes")
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(len(corpus.FAMILIES)):
            a, b = os.path.join(tmp, "a%d" % seed), os.path.join(tmp, "b%d" % seed)
            ca = corpus.make_case(seed, a)
            corpus.make_case(seed, b)
            check(digest(a) == digest(b), "seed %d (%s) is reproducible" % (seed, ca["family"]))
            if ca["kind"] == "surface":
                mc = os.environ.get("FRONTMESH_MESHCHECK") or os.path.join(
                    HERE, "..", "..", "..", "shared", "tools", "meshcheck.py")
                if not os.path.exists(mc):
                    print("FRONTMESH-TEST-SKIPPED: meshcheck.py not found")
                    continue
                p = subprocess.run(["/usr/bin/python3", mc, os.path.join(a, "surface.vtp")],
                                   capture_output=True, text=True)
                check(p.returncode == 0, "seed %d surface is closed and oriented (meshcheck)" % seed)
            else:
                check(sum(v["voxels"] for v in ca["labels"].values()) > 0,
                      "seed %d image has labelled voxels" % seed)
    print("%d passed, %d failed" % (passed, failed))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
