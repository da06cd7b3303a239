#!/usr/bin/env bash
# The main job in one command: `bimrobot build` takes the frame from IFC to a robot-built structure
# (Gazebo package with the components on the yard, market-based build simulation, knowledge graph,
# RCAN run of the schedule) into one folder with a README saying what each file is.
set -euo pipefail
frame="$DEMO_OUT/frame.ifc"
if [ ! -f "$frame" ]; then
  "$BIMROBOT" example steel-frame -o "$frame" >/dev/null
fi
"$BIMROBOT" build "$frame" --fleet fleet2 -o "$DEMO_OUT/build" | grep -E '^(==|\$|build:|fleet|== completed)'
echo
echo "build: everything is in $DEMO_OUT/build/; $DEMO_OUT/build/README.md says what each file is and how to open it"
echo "build: watch it in 4D with: $VENV/bin/rerun $DEMO_OUT/build/build.rrd   (or in a browser: $BIMROBOT replay $DEMO_OUT/build -o $DEMO_OUT/view.rrd --serve)"
