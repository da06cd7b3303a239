#!/usr/bin/env bash
# The construction knowledge graph (thesis ch. 5, fig. 5.5) of the steel frame and its simulated schedule:
# BOT topology + DiCon activities + live states, as Turtle and JSON-LD, and the SPARQL queries RCAN uses.
set -euo pipefail
out="$DEMO_OUT/graph"
mkdir -p "$out"
# Reuse the frame and schedule of earlier demo steps when they are there, else make them here.
frame="$DEMO_OUT/frame.ifc"
schedule=$(find "$DEMO_OUT" -path "$out" -prune -o -name schedule.csv -print 2>/dev/null | head -n 1)
if [ ! -f "$frame" ] || [ -z "$schedule" ] || \
   ! "$BIMROBOT" graph "$frame" --schedule "$schedule" -o "$out/frame.ttl" 2>/dev/null; then
  frame="$out/frame.ifc"
  schedule="$out/sim/schedule.csv"
  "$BIMROBOT" example steel-frame -o "$frame" >/dev/null
  "$BIMROBOT" simulate "$frame" --fleet fleet2 -o "$out/sim" >/dev/null
  "$BIMROBOT" graph "$frame" --schedule "$schedule" -o "$out/frame.ttl"
fi
echo "model: $frame"
echo "schedule: $schedule"
echo
echo "-- activities ready to start (no predecessor, or all predecessors Completed):"
"$BIMROBOT" query "$out/frame.ttl" ready_activities
first=$(sed -n 2p "$schedule" | cut -d, -f5)
echo
echo "-- activities of component $first (what an RCAN node needs: robot, times, weight, goal):"
"$BIMROBOT" query "$out/frame.ttl" component_activities --bind "globalId=$first" | tee "$out/component_activities.txt"
echo
echo "-- the build goes on: A0001 completes, its component arrives; the graph is updated live:"
"$VENV/bin/python" - "$out" "$first" <<'PY'
import sys
from bimrobot.lbd.graph import ConstructionGraph

out, component = sys.argv[1], sys.argv[2]
graph = ConstructionGraph.open(f"{out}/frame.ttl")
graph.set_activity_state("A0001", "Completed")
for state in ("InTransit", "Arrived"):
    graph.set_component_state(component, state)
ready = [row["activityId"] for row in graph.query("ready_activities")]
print(f"{component} is now {graph.component_state(component)}; ready to start: {' '.join(ready)}")
graph.serialize(f"{out}/frame-after-A0001.jsonld")
PY
echo
echo "output: $out/ (frame.ttl: the graph as built; frame-after-A0001.jsonld: the same graph as JSON-LD after the update;"
echo "        component_activities.txt: one query's answer)"
