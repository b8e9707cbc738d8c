#!/usr/bin/env bash
# Renders a frontmesh mesh.vtu in ParaView (pvbatch, off screen) into a PNG: the tets below
# the mid-height plane (crinkle clip, whole tets), in the label colours the VTU stores, with
# their edges, seen from above (issue 22: what a user sees in ParaView). Usage:
#   bash scripts/paraview-screenshot.sh OUT/mesh.vtu [PNG]
# Needs Debian's paraview (pvbatch) and xvfb, installed WITHOUT recommends:
#   apt-get install --no-install-recommends paraview xvfb xauth
# paraview recommends python3-paraview, which conflicts with python3-vtk9 and takes
# libvtk9-dev away with it (the build and the referee need both). This script unpacks
# python3-paraview aside (dpkg -x) and puts it first on PYTHONPATH instead.
set -euo pipefail
mesh=${1:?usage: paraview-screenshot.sh MESH.vtu [PNG]}
png=${2:-/tmp/frontmesh-paraview.png}
[ -f "$mesh" ] || { echo "paraview-screenshot: '$mesh' does not exist" >&2; exit 2; }
command -v pvbatch > /dev/null || { echo "paraview-screenshot: apt-get install --no-install-recommends paraview" >&2; exit 2; }
command -v xvfb-run > /dev/null || { echo "paraview-screenshot: apt-get install --no-install-recommends xvfb xauth" >&2; exit 2; }
aside=${FRONTMESH_PARAVIEW_PYTHON:-/opt/python3-paraview}
if [ ! -d "$aside/usr/lib/python3/dist-packages/paraview" ]; then
  tmp=$(mktemp -d)
  (cd "$tmp" && apt-get download python3-paraview > /dev/null)
  dpkg -x "$tmp"/python3-paraview_*.deb "$aside"
  rm -rf "$tmp"
fi
script=$(mktemp --suffix=.py)
trap 'rm -f "$script"' EXIT
cat > "$script" <<'PY'
import sys
from paraview.simple import *
mesh, out = sys.argv[1], sys.argv[2]
view = CreateView('RenderView')
view.ViewSize = [1200, 1000]
view.OrientationAxesVisibility = 0
try:
    view.UseColorPaletteForBackground = 0
except AttributeError:
    pass
view.Background = [1, 1, 1]
reader = XMLUnstructuredGridReader(FileName=[mesh])
# The bounds exist only once the reader has run: before, they are VTK's empty box
# (1, -1, ...), which put the cut at z = 0 and the camera below the mesh.
reader.UpdatePipeline()
b = reader.GetDataInformation().GetBounds()
if not (b[0] <= b[1] and b[2] <= b[3] and b[4] <= b[5]):
    sys.exit("paraview-screenshot: %s holds no cells" % mesh)
centre = [(b[0] + b[1]) / 2, (b[2] + b[3]) / 2, (b[4] + b[5]) / 2]
clip = Clip(Input=reader)
clip.ClipType = 'Plane'
clip.ClipType.Normal = [0, 0, 1]
clip.ClipType.Origin = centre
clip.Crinkleclip = 1
shown = Show(clip, view)
shown.SetRepresentationType('Surface With Edges')
shown.EdgeColor = [0.15, 0.15, 0.15]
ColorBy(shown, ('CELLS', 'colour'))
shown.MapScalars = 0  # the RGB label colours of the VTU as they are
view.CameraPosition = [centre[0], centre[1], b[5] + 3 * (b[5] - b[4])]
view.CameraFocalPoint = centre
view.CameraViewUp = [0, 1, 0]
view.ResetCamera()
Render(view)
SaveScreenshot(out, view, ImageResolution=[1200, 1000])
PY
PYTHONPATH="$aside/usr/lib/python3/dist-packages${PYTHONPATH:+:$PYTHONPATH}" \
  xvfb-run -a -s "-screen 0 1280x1024x24" pvbatch "$script" "$(realpath "$mesh")" "$png"
echo "paraview-screenshot: wrote $png"
