#!/bin/bash
# publish.sh SRC DEST: a run folder without .exr, SVG and JSON
src=$1; dst=$2
mkdir -p $dst/plots $dst/images
cp $src/meta.toml $src/report.md $src/runs.csv $src/summary.csv $dst/
cp $src/plots/*.png $dst/plots/ 2>/dev/null
cp $src/images/*.png $dst/images/ 2>/dev/null
