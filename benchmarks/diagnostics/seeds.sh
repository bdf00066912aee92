#!/bin/bash
# usage: seeds.sh ROOT TAG "overrides" seeds...
ROOT=$1; TAG=$2; EXTRA=$3; shift 3
for s in "$@"; do
  d=outputs/diagnostics/$TAG/s$s; mkdir -p $(dirname $d)
  PYTHONPATH=$ROOT/src ${PYTHON:-python} -m nct.cli.main seed=$s $EXTRA hydra.run.dir=$d logger=none threads=1 export.gif=false export.tiff=false > $d.log 2>&1
  python3 -c "import json;m=json.load(open('$d/metrics.json'));print('$TAG','s$s',round(m['nct']['median_dice'],4),round(m['fbp']['median_dice'],3),round(m['wall_time_s'],1),m.get('selection',{}).get('winner'))" || tail -3 $d.log
done
