"""Each configuration's median wall against the best fixed chunk (self_scheduling, scanline) of
its scene (and slow setting), ratio of medians with a 95 % percentile bootstrap (seeded)."""
import csv, sys, random, statistics, collections
rows = [r for r in csv.DictReader(open(sys.argv[1])) if r['scheduler'] != 'serial']
walls = collections.defaultdict(list)
meta = {}
for r in rows:
    k = (r['scene'], r['slow'] or 'none', r['label'])
    walls[k].append(float(r['wall_s']))
    meta[k] = r
rng = random.Random(1)
def boot(a, b, n=2000):
    out = []
    for _ in range(n):
        out.append(statistics.median(rng.choices(a, k=len(a))) / statistics.median(rng.choices(b, k=len(b))))
    out.sort()
    return out[int(0.025 * n)], out[int(0.975 * n)]
groups = collections.defaultdict(list)
for k in walls:
    groups[k[:2]].append(k)
for g, ks in sorted(groups.items()):
    fixed = [k for k in ks if meta[k]['scheduler'] == 'self_scheduling' and meta[k]['order'] == 'scanline']
    if not fixed:
        continue
    best = min(fixed, key=lambda k: statistics.median(walls[k]))
    bm = statistics.median(walls[best])
    print(f"## {g[0]} slow={g[1]}: best fixed chunk `{best[2]}` {bm*1e3:.2f} ms (n={len(walls[best])})")
    for k in sorted(ks, key=lambda k: statistics.median(walls[k])):
        m = statistics.median(walls[k])
        lo, hi = boot(walls[k], walls[best])
        print(f"  {k[2]:60s} {m*1e3:8.2f} ms  {m/bm:5.2f}x ({lo:.2f}-{hi:.2f})  n={len(walls[k])}")
