"""Median over rounds of wall(config) / wall(self_scheduling chunk=2, scanline), per scene, with
a percentile-bootstrap 95 % interval (seed 1); equal workers (gunzip -k runs.csv.gz; python3 paired.py runs.csv)."""
import csv, random, sys, statistics
from collections import defaultdict
rows = list(csv.DictReader(open(sys.argv[1])))
walls = defaultdict(dict)
for r in rows:
    walls[(r["scene"], r["label"])][int(r["repetition"])] = float(r["wall_s"])
rng = random.Random(1)
for scene in sorted({s for s, _ in walls}):
    base = walls[(scene, "self_scheduling chunk=2")]
    print(scene)
    for (s, label), w in sorted(walls.items()):
        if s != scene or label == "serial":
            continue
        ratios = [w[k] / base[k] for k in w if k in base]
        med = statistics.median(ratios)
        boots = sorted(statistics.median(rng.choices(ratios, k=len(ratios))) for _ in range(2000))
        print(f"  {label:45} {med:.3f} ({boots[50]:.3f}–{boots[1949]:.3f})  n={len(ratios)}")
