#!/usr/bin/env bash
# Installs the Debian 12 packages frontmesh needs, only those missing (idempotent).
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  libvtk9-dev libinsighttoolkit5-dev libeigen3-dev libyaml-cpp-dev
  catch2 libtbb-dev
  mricron-data                                   # real atlases for examples and e2e tests
  python3 python3-numpy python3-vtk9 python3-meshio   # the meshcheck referee, checkpoint checks
  tetgen                                         # peer mesher for the benchmarks
  gmsh                                           # reads our .msh/.mesh exports back in the tests
  calculix-ccx                                   # solves our .inp exports in the tests (ccx)
  clang-format                                   # scripts/check-format.sh (CI step)
  clang libclang-rt-14-dev                       # sanitizer build and libFuzzer targets (CI)
  snakemake                                      # examples/cohort/Snakefile (local or SLURM)
  python3-jsonschema                             # summary.json against docs/summary.schema.json
  chromium                                       # scripts/report-screenshot.sh (report.html)
  python3-dolfinx python3-gmsh                   # FEniCSx reads our .msh and solves on it (tests)
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "frontmesh: installing ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${missing[@]}"
else
  echo "frontmesh: all Debian packages present"
fi
