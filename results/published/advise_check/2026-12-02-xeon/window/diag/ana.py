"""Window E: per configuration median wall, old vs new binary (two alternations each); per-item
cost at 1 worker c = (t(chunk 1) - t(chunk 4)) / (16384 - 1024) and 1 px over 4² ratios."""
import csv, sys, statistics, collections, glob
W = sys.argv[1]
med = collections.defaultdict(dict)
for b in ['OLD', 'NEW']:
    for k in (1, 2):
        f = glob.glob(f'{W}/{b}_{k}/*/runs.csv')[0]
        walls = collections.defaultdict(list)
        for r in csv.DictReader(open(f)):
            walls[(r['scene'], r['workers'], r['label'])].append(float(r['wall_s']))
        for key, v in walls.items():
            med[key][(b, k)] = statistics.median(v)
print(f"{'scene':12s} {'P':2s} {'configuration':45s} " + ' '.join(f'{b}{k:1d} ms ' for b in ['OLD','NEW'] for k in (1,2)) + " new/old")
for key in sorted(med):
    m = med[key]
    vals = [m.get((b, k), float('nan')) for b in ['OLD', 'NEW'] for k in (1, 2)]
    r = [m[('NEW', k)] / m[('OLD', k)] for k in (1, 2) if ('NEW', k) in m and ('OLD', k) in m]
    print(f"{key[0]:12s} {key[1]:2s} {key[2]:45s} " + ' '.join(f'{v*1e3:7.2f}' for v in vals) + '  ' + ' '.join(f'{x:.3f}' for x in r))
print()
for b in ['OLD', 'NEW']:
    for k in (1, 2):
        for sc in sorted({x[0] for x in med}):
            for P in ['1', '2']:
                def g(lbl):
                    return med.get((sc, P, lbl), {}).get((b, k))
                for s in ['self_scheduling', 'adaptive_factoring', 'awf']:
                    a, c = g(f'{s} chunk=1'), g(f'{s} chunk=4')
                    if a and c:
                        extra = (a - c) * int(P) / (16384 - 1024)
                        print(f"{b}{k} {sc} P={P} {s:20s} 1px/4² {a/c:.3f}  per extra item {extra*1e9:6.1f} ns (worker time)")
