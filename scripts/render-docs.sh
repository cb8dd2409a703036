#!/usr/bin/env bash
# Renders every shipped scenario (data/scenarios/*.json) into docs/scenarios/: the driver's
# view at its start pose (<name>.png), the instructor's chase view (<name>_chase.png) and a plan
# view of the whole floor (<name>_plan.png), 640x480 each, and writes docs/scenarios/README.md
# with one line per scenario. docs/scenarios/before/ keeps the stills as the renderer drew them
# before the renderer had shadows (flat-shaded, no shadows): the script leaves them alone.
# Needs forklift-render built (build/bin/, or FORKLIFT_RENDER=path/to/forklift-render).
set -euo pipefail
cd "$(dirname "$0")/.."
render=${FORKLIFT_RENDER:-build/bin/forklift-render}
if [ ! -x "$render" ]; then
  echo "render-docs.sh: $render not found: build it first (cmake --build build --target forklift-render)" >&2
  exit 1
fi
out=docs/scenarios
mkdir -p "$out"
readme=$out/README.md
{
  echo "# Shipped scenarios, as the renderer draws them"
  echo
  echo "Made by \`scripts/render-docs.sh\` with \`forklift-render\` (640x480): for each scenario in"
  echo "\`data/scenarios/\`, the driver's view from the start pose, the instructor's chase view and a"
  echo "plan view of the whole floor (world x to the right, y up). Run the script again after changing"
  echo "a scenario or a mesh."
  echo
  echo "The pictures have shadows (the truck's, the pallets' and the loads' on the floor, from a shadow"
  echo "map round the truck), orange fork tips and a haze with distance. [before/](before/)"
  echo "keeps the driver's and plan views as they were drawn before that: flat-shaded, no shadows."
  echo
} >"$readme"
for scenario in data/scenarios/*.json; do
  name=$(basename "$scenario" .json)
  "$render" --scenario "$scenario" --view driver --out "$out/$name.png" >/dev/null
  "$render" --scenario "$scenario" --view chase --out "$out/${name}_chase.png" >/dev/null
  "$render" --scenario "$scenario" --view plan --out "$out/${name}_plan.png" >/dev/null
  summary=$("$render" --scenario "$scenario" --describe)
  summary=${summary%.}
  line="- **$name**: $summary. [driver's view]($name.png), [chase](${name}_chase.png), [plan](${name}_plan.png)"
  [ -f "$out/before/$name.png" ] && line="$line; before: [driver's view](before/$name.png), [plan](before/${name}_plan.png)"
  echo "$line" >>"$readme"
  echo "render-docs.sh: $name"
done
