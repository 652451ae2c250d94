"""Per scene: |error| of predicted vs measured median, largest overall and without the per-ray master."""
import csv, sys, statistics, collections
for f in sys.argv[1:]:
    walls = collections.defaultdict(list); pred = {}
    for r in csv.DictReader(open(f)):
        if r['scheduler'] == 'serial' or not r['predicted_wall_s']:
            continue
        k = (r['scene'], r['label'])
        walls[k].append(float(r['wall_s'])); pred[k] = float(r['predicted_wall_s'])
    by = collections.defaultdict(list)
    for k in walls:
        e = pred[k] / statistics.median(walls[k]) - 1
        by[k[0]].append((abs(e), e, k[1]))
    for s, v in by.items():
        v.sort(reverse=True)
        nm = [x for x in v if not x[2].startswith('master chunk=1 ')]
        print(f"{'/'.join(f.split('/')[-3:-1]):22s} {s:12s} n={len(v)} median {statistics.median([x[0] for x in v])*100:.1f} % largest {v[0][1]*100:+.1f} % ({v[0][2]}); without per-ray master: largest {nm[0][1]*100:+.1f} % ({nm[0][2]})")
