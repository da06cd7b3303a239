#!/usr/bin/env bash
# World step: convert the built-in steel frame into a Gazebo package and validate it.
set -euo pipefail
FRAME="$DEMO_OUT/frame.ifc"
PKG="$DEMO_OUT/frame_pkg"
if [ ! -f "$FRAME" ]; then
  "$BIMROBOT" example steel-frame -o "$FRAME"
fi
"$BIMROBOT" convert "$FRAME" -o "$PKG" --target both --no-progress
"$VENV/bin/python" - "$PKG" <<'PY'
import sys
from pathlib import Path
from bimrobot.world.check import problems, sdf_validator, validate_sdf
import json

package = Path(sys.argv[1])
report = json.loads((package / "report.json").read_text())
found = problems(package)
print(f"checked {len(list((package / 'models').iterdir()))} models: meshes present, masses and inertia physical"
      if not found else "PROBLEMS:\n" + "\n".join(found))
if sdf_validator():
    for world in report["world_files"].values():
        valid, output = validate_sdf(package / world, package / "models")
        print(f"ign sdf -k {world}: {'Valid' if valid else output}")
else:
    print("(ign sdf not installed: SDF validation skipped)")
from bimrobot.world.render import render_package
picture = render_package(package, package.parent / "frame_world.png", title="frame_pkg: the converted steel frame")
print(f"picture of the world: {picture}")
sys.exit(1 if found else 0)
PY
echo "world: the Gazebo package is in $PKG/ (worlds/, models/<GlobalId>/, launch/, maps/, report.json, README.md);"
echo "       a picture of its world is $DEMO_OUT/frame_world.png"
