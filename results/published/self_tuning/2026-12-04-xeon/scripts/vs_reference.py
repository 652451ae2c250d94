import csv, sys, random, statistics as st
rows=list(csv.DictReader(open(sys.argv[1])))
ref_label=sys.argv[2] if len(sys.argv)>2 else 'self_scheduling chunk=1'
g={}
for r in rows:
    if r['scheduler']=='serial': continue
    key=(r['scene'], r['workers'], r.get('slow',''))
    g.setdefault(key,{}).setdefault(r['label'],{})[int(r['repetition'])]=float(r['wall_s'])
def ratio(a,b,seed=1):
    reps=sorted(set(a)&set(b))
    x=[a[i] for i in reps]; y=[b[i] for i in reps]
    v=st.median(x)/st.median(y)
    R=random.Random(seed); bs=[]
    for _ in range(2000):
        idx=[R.randrange(len(reps)) for _ in reps]
        bs.append(st.median([x[i] for i in idx])/st.median([y[i] for i in idx]))
    bs.sort(); return v, bs[50], bs[1949]
for key in sorted(g):
    cfg=g[key]
    if ref_label not in cfg: continue
    print(f"== {key[0]} workers={key[1]} slow={key[2]}  ref `{ref_label}` {st.median(cfg[ref_label].values())*1e3:.2f} ms")
    for lab in sorted(cfg, key=lambda l: st.median(cfg[l].values())):
        v,lo,hi=ratio(cfg[lab],cfg[ref_label])
        print(f"   {lab:55s} {st.median(cfg[lab].values())*1e3:8.2f} ms  {v:.3f} ({lo:.3f}-{hi:.3f})")
