#!/usr/bin/env bash
# World step: convert the built-in steel frame into a Gazebo package, validate it, draw it.
set -euo pipefail
FRAME="$DEMO_OUT/frame.ifc"
PKG="$DEMO_OUT/frame_pkg"
if [ ! -f "$FRAME" ]; then
  "$BIMROBOT" example steel-frame -o "$FRAME"
fi
"$BIMROBOT" convert "$FRAME" -o "$PKG" --target both --no-progress --validate
"$VENV/bin/python" -c "
import sys
from bimrobot.export.gazebo.render import render_package
render_package(sys.argv[1], sys.argv[2], title='frame_pkg: the converted steel frame')
" "$PKG" "$DEMO_OUT/frame_world.png"
echo "world: the Gazebo package is in $PKG/ (worlds/, models/<GlobalId>/, launch/, maps/, report.json, README.md);"
echo "       a picture of its world is $DEMO_OUT/frame_world.png"
