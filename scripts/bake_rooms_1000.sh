#!/bin/bash
# The >=1000 rooms the shipped model is retrained on (full bake: every group the default model reads).
# Run both shards side by side from the checkout:  for i in 0 1; do scripts/bake_rooms_1000.sh $i & done; wait
# Resumable: rerun the same command after a kill; finished samples are kept (the shard manifests list them). Then
# `.venv/bin/python cli.py merge DIR` for each folder. Seeds are new (no earlier bake used them). Two steps of half
# each, so that a bake stopped part-way still holds every mode. OUT (default data, in the repository) is the parent folder.
set -e
cd "$(dirname "$0")/.."
OUT="${OUT:-data}"
B="nice -n 5 .venv/bin/python cli.py bake --denoise --ref-samples 16 --shard $1/2"
for step in 1 2; do
  $B --out "$OUT/artist2" --count $((350*step)) --seed 300000 --mode artist
  $B --out "$OUT/interior2" --count $((75*step)) --seed 310000 --mode interior
  $B --out "$OUT/studio2" --count $((50*step)) --seed 320000 --mode studio
  $B --out "$OUT/diffuse3" --count $((25*step)) --seed 330000 --mode diffuse
done
