#!/bin/bash
# The shipped model's retrain on the 1000 rooms of scripts/bake_rooms_1000.sh (run that first, both shards).
#   scripts/retrain_1000.sh PREV.pt RUN.pt        # PREV.pt: the model to start from (the shipped model of commit 64739b3)
# Merges the four folders' shard manifests, then fine-tunes PREV.pt with the shipped recipe (25 min, one thread; the
# best epoch by the mean of the four folders' validation PSNRs is kept). Resumable: rerun after a kill and the
# training resumes from RUN.pt's last epoch (--resume). OUT (default data, in the repository) is the parent folder of the bakes.
set -e
cd "$(dirname "$0")/.."
OUT="${OUT:-data}"
PREV="$1"
RUN="$2"
if [ -z "$PREV" ] || [ -z "$RUN" ]; then echo "usage: scripts/retrain_1000.sh PREV.pt RUN.pt" >&2; exit 2; fi
DATA="$OUT/artist2 $OUT/interior2 $OUT/studio2 $OUT/diffuse3"
for d in $DATA; do .venv/bin/python cli.py merge "$d"; done
if [ -f "${RUN%.pt}.last.pt" ]; then
  .venv/bin/python cli.py train --data $DATA --out "$RUN" --resume --minutes 25 --threads 1
else
  .venv/bin/python cli.py train --data $DATA --out "$RUN" --init "$PREV" \
    --inputs albedo,normal,depth,direct,direct_soft,lit,scene,world,emission,emit_direct,glow,surround \
    --minutes 25 --crop 128 --batch 8 --lr 5e-4 --threads 1
fi
