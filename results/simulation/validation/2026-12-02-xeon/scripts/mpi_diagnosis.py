import csv, statistics as st, sys
def load(p): return list(csv.DictReader(open(p)))
R, S = load(sys.argv[1]), load(sys.argv[2])
ser = st.median(float(r['wall_s']) for r in R if r['scheduler']=='serial' and r['sources']=='local')
print(f"serial median {ser:.4f} s")
print("| ranks | transport | chunk | rendering wall s | Σ busy s | Σ idle per item µs | rank-0 CPU / wall (user, sys) | spinning wall s | spin period per item µs | item cost µs |")
print("|---|---|---|---|---|---|---|---|---|---|")
keys=sorted({(r['ranks'],r['transport'],r['chunk']) for r in R if r['sources']=='mpi'})
for k in keys:
    rows=[r for r in R if r['sources']=='mpi' and (r['ranks'],r['transport'],r['chunk'])==k]
    sp=[r for r in S if r['sources']=='mpi' and (r['ranks'],r['transport'],r['chunk'])==k]
    f=lambda rs,c: st.median(float(r[c]) for r in rs)
    w=int(rows[0]['workers']); n=int(rows[0]['items'])
    idle=f(rows,'idle_s'); cpu=st.median((float(r['user_s'])+float(r['sys_s']))/float(r['wall_s']) for r in rows)
    us=st.median(float(r['user_s'])/float(r['wall_s']) for r in rows); sy=st.median(float(r['sys_s'])/float(r['wall_s']) for r in rows)
    sw=f(sp,'wall_s') if sp else float('nan')
    print(f"| {k[0]} | {k[1]} | {k[2]} | {f(rows,'wall_s'):.4f} | {f(rows,'work_s'):.4f} | {idle/n*1e6:.1f} | {cpu:.2f} ({us:.2f}, {sy:.2f}) | {sw:.4f} | {w*sw/n*1e6:.1f} | {ser/n*1e6:.1f} |")
