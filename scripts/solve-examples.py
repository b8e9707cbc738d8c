#!/usr/bin/python3
"""Mesh example recipes and check their exports in CalculiX, gmsh, meshio and FEniCSx.

usage: solve-examples.py [-h] [--frontmesh PATH] [--out DIR] [--threads N]
                         [--solver {auto,spooles,iterative-cholesky,iterative-scaling}]
                         [--ccx-timeout S] [--memory-gb G] [RECIPE.yaml ...]

Issue 22's acceptance on the shipped examples (default: every examples/*.yaml). For each
recipe, into OUT/NAME (NAME = the recipe's file name without .yaml):
  1. frontmesh run RECIPE --threads N --set output.dir=OUT/NAME
                          --set output.formats=[vtu,msh,inp,feb]
     (unchanged stages are reused on a second call);
  2. CalculiX: OUT/NAME/solve/job.inp *INCLUDEs the unchanged mesh.inp and adds only the
     user's deck: a material (E = 3 kPa, nu = 0.45, brain tissue in mm-N-s-t) and a *SOLID
     SECTION per region element set, boundary_NODES fixed, gravity on ALLELEMENTS, one
     linear *STATIC step (U printed to job.dat and written to job.frd). ccx runs on N
     threads under /usr/bin/time -v; it passes when it exits 0 without *ERROR and job.dat
     holds a finite displacement for every node of mesh.inp, some of it non-zero.
     Debian's ccx 2.20 has SPOOLES (direct) and the iterative solvers (ITERATIVE SCALING,
     ITERATIVE CHOLESKY); --solver auto takes SPOOLES up to 50,000 nodes and ITERATIVE
     CHOLESKY above (colin27-brain, 112k nodes, one thread: SPOOLES 61 s and 1.5 GB,
     ITERATIVE CHOLESKY 10 s and 0.37 GB, same result).
     It is stopped past --ccx-timeout seconds or --memory-gb of resident memory;
  3. tags: mesh.msh is read by gmsh (python API), meshio and FEniCSx (dolfinx.io.gmshio,
     each in its own process); each must see the same 3-D tags with the same tet counts
     and the same 2-D tags with the same triangle counts as the tets of mesh.vtu give by
     the README's scheme (region r -> r; a face between r and the outside -> r; between
     labels a < b -> a * 100000 + b), and the region tags must be summary.json's labels;
  4. FEBio: tests/io/check_feb.py checks mesh.feb's structure (no FEBio for Debian).
Prints one PASS/FAIL line per example with its figures and writes OUT/solve-examples.json.
Exit 0 when every example passes, 1 when one fails, 2 on bad arguments.
"""
import argparse
import glob
import json
import os
import re
import signal
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
FORMATS = "[vtu,msh,inp,feb]"
SOLVERS = {"spooles": "SPOOLES", "iterative-cholesky": "ITERATIVE CHOLESKY",
           "iterative-scaling": "ITERATIVE SCALING"}
SPOOLES_MAX_NODES = 50000
# Brain tissue in CalculiX's consistent units mm, N, s, t: E in MPa, density in t/mm^3,
# gravity in mm/s^2.
YOUNG_MPA, POISSON, DENSITY, GRAVITY = 0.003, 0.45, 1.04e-9, 9810.0


def tree_rss_mb(pid):
    """Resident memory of a process and its descendants (Linux /proc), in MB."""
    total, todo = 0, [pid]
    while todo:
        p = todo.pop()
        try:
            with open("/proc/%d/status" % p) as f:
                for line in f:
                    if line.startswith("VmRSS:"):
                        total += int(line.split()[1])
            with open("/proc/%d/task/%d/children" % (p, p)) as f:
                todo += [int(c) for c in f.read().split()]
        except (OSError, ValueError):
            pass  # the process ended meanwhile
    return total / 1024.0


def run_measured(cmd, cwd, log, env=None, timeout_s=None, memory_mb=None):
    """Runs cmd under /usr/bin/time -v with its output in the file log; stops its process
    group past timeout_s or memory_mb. Returns rc, wall_s, peak_mb and why it was stopped
    (None when it was not)."""
    time_log = log + ".time"
    if os.path.exists(time_log):
        os.remove(time_log)
    start = time.monotonic()
    with open(log, "w") as out:
        proc = subprocess.Popen(["/usr/bin/time", "-v", "-o", time_log] + cmd, cwd=cwd,
                                stdout=out, stderr=subprocess.STDOUT, env=env,
                                start_new_session=True)
    stopped, watched_mb = None, 0.0
    while proc.poll() is None:
        time.sleep(0.5)
        watched_mb = max(watched_mb, tree_rss_mb(proc.pid))
        wall = time.monotonic() - start
        if memory_mb and watched_mb > memory_mb:
            stopped = "resident memory %.0f MB over the limit of %.0f MB after %.0f s" % (
                watched_mb, memory_mb, wall)
        elif timeout_s and wall > timeout_s:
            stopped = "still running after %.0f s (limit %.0f s), %.0f MB resident" % (
                wall, timeout_s, watched_mb)
        if stopped:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    result = {"rc": proc.returncode, "wall_s": time.monotonic() - start,
              "peak_mb": watched_mb, "stopped": stopped}
    if not stopped and os.path.exists(time_log):
        text = open(time_log).read()
        rss = re.search(r"Maximum resident set size \(kbytes\): (\d+)", text)
        wall = re.search(r"Elapsed \(wall clock\) time.*: (?:(\d+):)?(\d+):([\d.]+)", text)
        status = re.search(r"Exit status: (\d+)", text)
        if rss:
            result["peak_mb"] = int(rss.group(1)) / 1024.0
        if wall:
            h, m, s = wall.groups()
            result["wall_s"] = int(h or 0) * 3600 + int(m) * 60 + float(s)
        if status:
            result["rc"] = int(status.group(1))
    return result


def inp_contents(path):
    """Nodes of a frontmesh .inp and its regions as (label, element set, elements): the
    header's '** region LABEL NAME' comments name the *ELEMENT blocks' ELSETs."""
    nodes, regions, labels, section = 0, [], {}, None
    with open(path) as f:
        for line in f:
            if line.startswith("** region "):
                _, _, label, name = line.rstrip("\n").split(" ", 3)
                labels[name.upper()] = int(label)
            elif line.startswith("**"):
                continue
            elif line.startswith("*"):
                head = line.upper()
                section = None
                if head.startswith("*NODE,") or head.strip() == "*NODE":
                    section = "node"
                elif head.startswith("*ELEMENT,"):
                    elset = re.search(r"ELSET=([^,\s]+)", line, re.I).group(1)
                    regions.append([labels.get(elset.upper()), elset, 0])
                    section = "element"
            elif line.strip():
                if section == "node":
                    nodes += 1
                elif section == "element":
                    regions[-1][2] += 1
    return nodes, regions


def ccx_deck(regions, solver):
    """The user's part of the job: everything but the mesh, which is *INCLUDEd."""
    deck = ["*HEADING", "frontmesh example solved by CalculiX (scripts/solve-examples.py)",
            "*INCLUDE, INPUT=../mesh.inp"]
    for label, elset, _ in regions:
        deck += ["*MATERIAL, NAME=TISSUE_%d" % label, "*ELASTIC",
                 "%g, %g" % (YOUNG_MPA, POISSON), "*DENSITY", "%g" % DENSITY,
                 "*SOLID SECTION, ELSET=%s, MATERIAL=TISSUE_%d" % (elset, label)]
    deck += ["*BOUNDARY", "boundary_NODES, 1, 3", "*STEP", "*STATIC, SOLVER=%s" % solver,
             "*DLOAD", "ALLELEMENTS, GRAV, %g, 0., 0., -1." % GRAVITY,
             "*NODE FILE", "U", "*NODE PRINT, NSET=ALLNODES", "U", "*END STEP"]
    return "\n".join(deck) + "\n"


def displacements(dat):
    """(nodes with a displacement line, nodes with a non-finite value, max |u_i|) of a
    ccx .dat with one NODE PRINT of U."""
    count, bad, peak, inside = 0, 0, 0.0, False
    with open(dat) as f:
        for line in f:
            fields = line.split()
            if line.lstrip().startswith("displacements"):
                inside = True
            elif inside and len(fields) == 4 and fields[0].isdigit():
                count += 1
                try:
                    values = [float(x) for x in fields[1:]]
                except ValueError:  # "**********": a Fortran field overflowed
                    bad += 1
                    continue
                if not all(v == v and abs(v) != float("inf") for v in values):
                    bad += 1
                else:
                    peak = max(peak, max(abs(v) for v in values))
    return count, bad, peak


def solve_with_ccx(out, args):
    nodes, regions = inp_contents(os.path.join(out, "mesh.inp"))
    solver = args.solver
    if solver == "auto":
        solver = "spooles" if nodes <= SPOOLES_MAX_NODES else "iterative-cholesky"
    job_dir = os.path.join(out, "solve")
    os.makedirs(job_dir, exist_ok=True)
    for old in glob.glob(os.path.join(job_dir, "job.*")):
        os.remove(old)
    with open(os.path.join(job_dir, "job.inp"), "w") as f:
        f.write(ccx_deck(regions, SOLVERS[solver]))
    env = dict(os.environ, OMP_NUM_THREADS=str(args.threads),
               CCX_NPROC_EQUATION_SOLVER=str(args.threads))
    log = os.path.join(job_dir, "ccx.log")
    run = run_measured(["ccx", "-i", "job"], job_dir, log, env, args.ccx_timeout,
                       args.memory_gb * 1024)
    result = {"solver": SOLVERS[solver], "nodes": nodes, "wall_s": run["wall_s"],
              "peak_mb": run["peak_mb"], "regions": {str(r[0]): r[2] for r in regions},
              "problems": ["mesh.inp: no '** region' comment names element set " + r[1]
                           for r in regions if r[0] is None]}
    if run["stopped"]:
        result["problems"].append("ccx stopped: " + run["stopped"])
        return result
    text = open(log, errors="replace").read()
    if run["rc"] != 0:
        result["problems"].append("ccx exit code %d (%s)" % (run["rc"], log))
    if "*ERROR" in text:
        line = next(l for l in text.splitlines() if "*ERROR" in l)
        result["problems"].append("ccx: " + line.strip())
    dat = os.path.join(job_dir, "job.dat")
    count, bad, peak = displacements(dat) if os.path.exists(dat) else (0, 0, 0.0)
    result["max_u_mm"] = peak
    if count != nodes:
        result["problems"].append("job.dat: %d nodes displaced of %d" % (count, nodes))
    if bad:
        result["problems"].append("job.dat: %d nodes with a non-finite displacement" % bad)
    if not peak > 0.0:
        result["problems"].append("job.dat: no node moved")
    return result


# ---- readers, each run as `solve-examples.py --read READER FILE` in its own process ----

def read_reference(vtu):
    """Region tags and tet counts of mesh.vtu, and the surface tags its tets give by the
    README's scheme with their triangle counts."""
    import numpy as np
    import vtk
    from vtk.util import numpy_support as ns
    reader = vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName(vtu)
    reader.Update()
    grid = reader.GetOutput()
    offsets = ns.vtk_to_numpy(grid.GetCells().GetOffsetsArray())
    conn = ns.vtk_to_numpy(grid.GetCells().GetConnectivityArray())
    per_cell = int(offsets[1] - offsets[0])
    tets = conn.reshape(-1, per_cell)[:, :4].astype(np.int64)  # corners of tet4 / tet10
    region = ns.vtk_to_numpy(grid.GetCellData().GetArray("region")).astype(np.int64)
    faces = np.sort(np.concatenate([tets[:, [1, 2, 3]], tets[:, [0, 2, 3]],
                                    tets[:, [0, 1, 3]], tets[:, [0, 1, 2]]]), axis=1)
    owner = np.tile(region, 4)
    # One 63-bit key per face: three node ids of 21 bits (up to 2,097,151 nodes).
    if grid.GetNumberOfPoints() >= 1 << 21:
        raise SystemExit("mesh.vtu: too many nodes for the face key")
    key = (faces[:, 0] << 42) | (faces[:, 1] << 21) | faces[:, 2]
    order = np.argsort(key, kind="stable")
    key, owner = key[order], owner[order]
    first = np.ones(len(key), bool)
    first[1:] = key[1:] != key[:-1]
    starts = np.flatnonzero(first)
    uses = np.diff(np.append(starts, len(key)))
    if uses.max() > 2:
        raise SystemExit("mesh.vtu: a face of more than two tets")
    a = owner[starts]
    b = np.where(uses == 2, owner[np.minimum(starts + 1, len(key) - 1)], 0)
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    keep = lo != hi  # faces inside a region carry no tag
    tags = np.where(lo[keep] == 0, hi[keep], lo[keep] * 100000 + hi[keep])
    return {"cells": counts(region), "facets": counts(tags)}


def counts(values):
    import numpy as np
    tags, n = np.unique(np.asarray(values), return_counts=True)
    return {str(int(t)): int(c) for t, c in zip(tags, n)}


def read_gmsh(msh):
    import gmsh
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.open(msh)
    seen = {"cells": {}, "facets": {}, "names": {}}
    for dim, tag in gmsh.model.getPhysicalGroups():
        n = 0
        for entity in gmsh.model.getEntitiesForPhysicalGroup(dim, tag):
            _, element_tags, _ = gmsh.model.mesh.getElements(dim, entity)
            n += sum(len(t) for t in element_tags)
        seen["cells" if dim == 3 else "facets"][str(tag)] = n
        seen["names"]["%d %d" % (dim, tag)] = gmsh.model.getPhysicalName(dim, tag)
    gmsh.finalize()
    return seen


def read_meshio(msh):
    import meshio
    import numpy as np
    mesh = meshio.read(msh, file_format="gmsh")
    cells, facets = [], []
    for block, tags in zip(mesh.cells, mesh.cell_data["gmsh:physical"]):
        if block.type.startswith("tetra"):
            cells.append(tags)
        elif block.type.startswith("triangle"):
            facets.append(tags)
    names = {"%d %d" % (int(v[1]), int(v[0])): k for k, v in mesh.field_data.items()}
    return {"cells": counts(np.concatenate(cells)),
            "facets": counts(np.concatenate(facets)) if facets else {}, "names": names}


def read_fenicsx(msh):
    # Debian's dolfinx 0.5.2 gmshio.read_from_msh returns an undefined name; its body as
    # upstream fixed it (as tests/io/check_fenicsx.py does): gmsh reads the file,
    # model_to_mesh builds the mesh with its cell and facet tags.
    import gmsh
    from dolfinx.io import gmshio
    from mpi4py import MPI
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("frontmesh")
    gmsh.merge(msh)
    mesh, cell_tags, facet_tags = gmshio.model_to_mesh(gmsh.model, MPI.COMM_WORLD, 0, gdim=3)
    gmsh.finalize()
    cells = mesh.topology.index_map(3).size_local
    if len(cell_tags.values) != cells:
        raise SystemExit("%d tagged cells of %d" % (len(cell_tags.values), cells))
    return {"cells": counts(cell_tags.values), "facets": counts(facet_tags.values)}


READERS = {"reference": read_reference, "gmsh": read_gmsh, "meshio": read_meshio,
           "fenicsx": read_fenicsx}


def read_tags(out, args):
    """Runs each reader on the example's files; compares what they saw."""
    seen, result = {}, {"problems": [], "equal": {}}
    for name in ["reference", "gmsh", "meshio", "fenicsx"]:
        path = os.path.join(out, "mesh.vtu" if name == "reference" else "mesh.msh")
        log = os.path.join(out, "solve", "read-%s.log" % name)
        run = run_measured(["/usr/bin/python3", os.path.abspath(__file__), "--read", name,
                            path], out, log, None, args.ccx_timeout, args.memory_gb * 1024)
        result[name] = {"wall_s": run["wall_s"], "peak_mb": run["peak_mb"]}
        text = open(log, errors="replace").read()
        lines = [l for l in text.splitlines() if l.startswith("{")]
        if run["stopped"] or run["rc"] != 0 or not lines:
            why = run["stopped"] or (text.strip().splitlines() or ["no output"])[-1]
            result["problems"].append("%s: %s" % (name, why))
            continue
        seen[name] = json.loads(lines[-1])
    reference = seen.get("reference")
    summary = json.load(open(os.path.join(out, "summary.json")))
    labels = {str(r["label"]): r.get("name") for r in summary.get("regions", [])}
    if reference:
        result["reference_cells"] = reference["cells"]
        result["regions"] = len(reference["cells"])
        result["surfaces"] = len(reference["facets"])
        if set(reference["cells"]) != set(labels):
            result["problems"].append("mesh.vtu regions %s, summary.json %s" % (
                sorted(reference["cells"], key=int), sorted(labels, key=int)))
    for name in ["gmsh", "meshio", "fenicsx"]:
        if name not in seen or not reference:
            result["equal"][name] = False
            continue
        ok = True
        for kind in ["cells", "facets"]:
            if seen[name][kind] != reference[kind]:
                ok = False
                result["problems"].append("%s: %s tags differ from mesh.vtu's: %s" % (
                    name, kind, difference(seen[name][kind], reference[kind])))
        for label, region_name in labels.items():
            got = seen[name].get("names", {}).get("3 " + label)
            if "names" in seen[name] and region_name and got != region_name:
                ok = False
                result["problems"].append("%s: region %s named %r, summary.json %r" % (
                    name, label, got, region_name))
        result["equal"][name] = ok
    return result


def difference(got, want):
    keys = sorted(set(got) | set(want), key=int)
    diff = ["%s: %s vs %s" % (k, got.get(k), want.get(k)) for k in keys
            if got.get(k) != want.get(k)]
    return ", ".join(diff[:5]) + (" (%d more)" % (len(diff) - 5) if len(diff) > 5 else "")


def check_feb(out):
    checker = os.path.join(ROOT, "tests", "io", "check_feb.py")
    run = subprocess.run(["/usr/bin/python3", checker, os.path.join(out, "mesh.feb")],
                         capture_output=True, text=True)
    if run.returncode != 0:
        return ["check_feb.py: " + (run.stdout.strip().splitlines() or ["exit %d" %
                                                                         run.returncode])[-1]]
    return []


def example(recipe, args):
    name = os.path.splitext(os.path.basename(recipe))[0]
    out = os.path.abspath(os.path.join(args.out, name))
    os.makedirs(os.path.join(args.out), exist_ok=True)
    record = {"example": name, "recipe": recipe, "output": out, "problems": []}
    mesh_log = os.path.join(args.out, name + ".frontmesh.log")
    run = run_measured([args.frontmesh, "run", os.path.abspath(recipe), "--threads",
                        str(args.threads), "--quiet", "--set", "output.dir=" + out, "--set",
                        "output.formats=" + FORMATS], os.getcwd(), mesh_log)
    record["frontmesh"] = {"wall_s": run["wall_s"], "peak_mb": run["peak_mb"]}
    if run["rc"] != 0:
        record["problems"].append("frontmesh exit code %d (%s)" % (run["rc"], mesh_log))
        return record
    stages = json.load(open(os.path.join(out, "summary.json"))).get("stages", [])
    record["frontmesh"]["reused"] = bool(stages) and all(s.get("reused") for s in stages)
    record["ccx"] = solve_with_ccx(out, args)
    record["tags"] = read_tags(out, args)
    record["feb"] = check_feb(out)
    # The .inp's region element sets, as the deck above uses them, against mesh.vtu.
    cells = record["tags"].pop("reference_cells", None)
    record["tags"]["equal"]["inp"] = cells is not None and record["ccx"]["regions"] == cells
    if cells is not None and record["ccx"]["regions"] != cells:
        record["problems"].append("mesh.inp: region element sets differ from mesh.vtu's: " +
                                  difference(record["ccx"]["regions"], cells))
    record["problems"] += record["ccx"].pop("problems") + record["tags"].pop("problems")
    record["problems"] += record["feb"]
    return record


def line(record):
    status = "FAIL" if record["problems"] else "PASS"
    text = "%s %s:" % (status, record["example"])
    ccx, tags = record.get("ccx"), record.get("tags")
    if ccx:
        tets = sum(ccx["regions"].values())
        text += " {:,} tets, {:,} nodes, {} regions, {} surfaces |".format(
            tets, ccx["nodes"], len(ccx["regions"]), tags.get("surfaces", "?"))
        text += " frontmesh %.1f s%s |" % (record["frontmesh"]["wall_s"],
                                          " (stages reused)" if record["frontmesh"]["reused"]
                                          else "")
        text += " ccx %s %.1f s %.0f MB, max |u| %s mm |" % (
            ccx["solver"], ccx["wall_s"], ccx["peak_mb"],
            "%.4g" % ccx["max_u_mm"] if "max_u_mm" in ccx else "-")
        text += " tags equal: %s |" % ", ".join(
            "%s %s" % (k, "yes" if v else "no") for k, v in tags["equal"].items())
        text += " feb %s" % ("ok" if not record["feb"] else "FAIL")
    for problem in record["problems"]:
        text += "\n    " + problem
    return text


def main():
    parser = argparse.ArgumentParser(
        usage="solve-examples.py [-h] [--frontmesh PATH] [--out DIR] [--threads N] "
              "[--solver S] [--ccx-timeout S] [--memory-gb G] [RECIPE.yaml ...]",
        description=__doc__.split("\n\n", 2)[2], formatter_class=argparse.RawTextHelpFormatter)
    parser.add_argument("recipes", nargs="*", metavar="RECIPE.yaml",
                        help="recipes to run (default: examples/*.yaml)")
    default_fm = os.path.join(ROOT, "build", "pipeline", "frontmesh")
    parser.add_argument("--frontmesh", default=default_fm, metavar="PATH",
                        help="the frontmesh binary (default: build/pipeline/frontmesh)")
    parser.add_argument("--out", default="out", metavar="DIR",
                        help="output folder; each example goes to OUT/NAME (default: out)")
    parser.add_argument("--threads", type=int, default=1, metavar="N",
                        help="threads of frontmesh and ccx (default: 1)")
    parser.add_argument("--solver", choices=["auto"] + sorted(SOLVERS), default="auto", metavar="S",
                        help="ccx equation solver (default: auto, see above)")
    parser.add_argument("--ccx-timeout", type=float, default=2400, metavar="S",
                        help="stop ccx (and each reader) after S seconds (default: 2400)")
    parser.add_argument("--memory-gb", type=float, default=16, metavar="G",
                        help="stop ccx (and each reader) above G GB resident (default: 16)")
    parser.add_argument("--read", nargs=2, metavar=("READER", "FILE"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.read:
        print(json.dumps(READERS[args.read[0]](args.read[1])))
        return 0
    recipes = args.recipes or sorted(glob.glob(os.path.join(ROOT, "examples", "*.yaml")))
    missing = [r for r in recipes if not os.path.isfile(r)]
    if missing or not os.access(args.frontmesh, os.X_OK) or args.threads < 1:
        parser.print_usage(sys.stderr)
        print("solve-examples.py: %s" % (
            "no recipe %s" % missing[0] if missing else
            "--threads must be at least 1" if args.threads < 1 else
            "no frontmesh binary at %s (build it or pass --frontmesh)" % args.frontmesh),
            file=sys.stderr)
        return 2
    for tool in ["ccx", "/usr/bin/time"]:
        if subprocess.run(["sh", "-c", "command -v " + tool], capture_output=True).returncode:
            print("solve-examples.py: %s not found (scripts/install-deps.sh)" % tool,
                  file=sys.stderr)
            return 2
    records = []
    for recipe in recipes:
        records.append(example(recipe, args))
        print(line(records[-1]), flush=True)
    with open(os.path.join(args.out, "solve-examples.json"), "w") as f:
        json.dump(records, f, indent=1)
    return 1 if any(r["problems"] for r in records) else 0


if __name__ == "__main__":
    sys.exit(main())
