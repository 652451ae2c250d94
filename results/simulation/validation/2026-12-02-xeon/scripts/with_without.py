import csv, sys
def load(p): return list(csv.DictReader(open(p)))
d = sys.argv[1]
S, N = load(d + '/sim/validation.csv'), load(d + '/sim_nospin/validation.csv')
key = lambda r: (r['sources'], r['label'], r['workers'])
n = {key(r): r for r in N}
def cnt(rows, src, col, lim): return sum(1 for r in rows if (r['sources']=='threads')==(src=='threads') and abs(float(r[col]))<=lim)
for nm, rows in [('with spin period', S), ('without', N)]:
    print(f"{nm}: threads wall≤5% {cnt(rows,'threads','wall_error',.05)}/24, at level {cnt(rows,'threads','wall_error_at_serial',.05)}/24, speedup≤10% {cnt(rows,'threads','speedup_error',.10)}/24; MPI wall {cnt(rows,'mpi','wall_error',.05)}/8, speedup {cnt(rows,'mpi','speedup_error',.10)}/8")
print("| sources | configuration | workers | measured s (min–max) | simulated s, spin period | error | speedup error | without it: simulated s | error |")
print("|---|---|---|---|---|---|---|---|---|")
for r in S:
    if r['sources'] == 'threads': continue
    o = n[key(r)]
    print(f"| {r['sources']} | {r['label'].replace(' requeue=never wait=block','')} | {r['workers']} | {float(r['measured_wall_s']):.4f} ({float(r['measured_min_s']):.3f}–{float(r['measured_max_s']):.3f}) | {float(r['simulated_wall_s']):.4f} | {100*float(r['wall_error']):+.1f} % | {100*float(r['speedup_error']):+.1f} % | {float(o['simulated_wall_s']):.4f} | {100*float(o['wall_error']):+.1f} % |")
