"""diag9: median wall per configuration, and each order's median over scanline's (same rule, scene,
workers). Usage: ana.py runs.csv"""
import csv, statistics, collections, sys
d = collections.defaultdict(list)
for r in csv.DictReader(open(sys.argv[1])):
    d[(r['scene'], r['workers'], r['label'])].append(float(r['wall_s']))
m = {k: statistics.median(v) for k, v in d.items()}
for k in sorted(m):
    v = sorted(d[k])
    print(f"{k[0]:11s} P={k[1]} {k[2]:50s} median {m[k]*1e3:7.2f} ms  range {v[0]*1e3:.2f}-{v[-1]*1e3:.2f}  n={len(v)}")
for sc in sorted({k[0] for k in m}):
    for P in ['1', '2']:
        for rule, dflt in [('self_scheduling', 'scanline'), ('adaptive_factoring', 'scatter_blocks'), ('awf', 'scatter_blocks')]:
            lab = lambda o: f"{rule} chunk=1" + ('' if o == dflt else f" order={o}")
            base = m.get((sc, P, lab('scanline')))
            if base:
                print(f"{sc:11s} P={P} {rule:19s} over scanline: scatter {m[(sc,P,lab('scatter'))]/base:.3f}  scatter_blocks {m[(sc,P,lab('scatter_blocks'))]/base:.3f}")
