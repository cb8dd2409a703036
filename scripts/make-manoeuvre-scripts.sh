#!/usr/bin/env bash
# Regenerates data/manoeuvres/: each paper manoeuvre as a cab script and its scenario.
set -euo pipefail
cd "$(dirname "$0")/.."
mkdir -p data/manoeuvres
for n in 1 2 3 4 5 10 11 12 14 15 17 18; do
  build/bin/forklift-sim script "$n" --out "data/manoeuvres/manoeuvre_$n.csv" --scenario-out "data/manoeuvres/manoeuvre_$n.json"
done
