"""Window G (diag2): median wall, summed busy time and end imbalance per configuration; 1 px
against 4² and scatter against scanline. Usage: diag2_ana.py RUNS.csv"""
import csv, statistics, collections, sys
d = collections.defaultdict(lambda: collections.defaultdict(list))
for r in csv.DictReader(open(sys.argv[1])):
    k = (r['scene'], r['workers'], r['label'])
    d[k]['wall'].append(float(r['wall_s'])); d[k]['work'].append(float(r['work_s'])); d[k]['imb'].append(float(r['imbalance_s']))
m = {k: {c: statistics.median(v) for c, v in x.items()} for k, x in d.items()}
for k in sorted(m):
    print(f"{k[0]:11s} P={k[1]} {k[2]:45s} wall {m[k]['wall']*1e3:7.2f}  work {m[k]['work']*1e3:7.2f}  imbalance {m[k]['imb']*1e3:6.3f}  n={len(d[k]['wall'])}")
for sc in ['skewed_low', 'skewed_mid']:
    for P in ['1', '2']:
        for rule in ['self_scheduling', 'adaptive_factoring', 'awf']:
            for o in ['', ' order=scatter', ' order=scanline']:
                a = m.get((sc, P, f'{rule} chunk=1{o}')); b = m.get((sc, P, f'{rule} chunk=4{o}'))
                if a and b:
                    print(f"{sc:11s} P={P} {rule:19s}{o or ' (default order)':16s} wall ratio {a['wall']/b['wall']:.3f}  extra busy {(a['work']-b['work'])/15360*1e9:6.1f} ns/item")
