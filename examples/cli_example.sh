#!/bin/sh
# The qmesh command line: mesh the chapter's case, measure the file, mesh a rotated Q.
# Run: sh examples/cli_example.sh [OUTDIR]   (default: a new temporary folder)
set -eu
out="${1:-$(mktemp -d)}"
mkdir -p "$out"

# Q = diag(0.1, 10) (the default) on the regular 64-gon, aiming for 212 vertices
qmesh mesh --disk 64 --target-vertices 212 --seed 0 --quiet -o "$out/disk64.vtu"

# every measurement of the file: N, quality, interpolation errors, kappa2, share of q_ij >= 0
qmesh report "$out/disk64.vtu" --json > "$out/disk64.json"
qmesh report "$out/disk64.vtu"

# principal conductivities 10 and 0.1 with k1's axis at 30 degrees, on the 32-gon, as gmsh
qmesh mesh --principal 10 0.1 30 --disk 32 --target-vertices 150 --quiet --json \
    -o "$out/rotated.msh" > "$out/rotated.json"
cat "$out/rotated.json"
echo "files in $out"
