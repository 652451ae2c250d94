"""Per configuration of a timeline run: each worker's chunks (runs of consecutive item ids),
its end, and the spread between the workers' ends."""
import csv, sys, os, collections
d = sys.argv[1]
labels = {r['config']: r['label'] for r in csv.DictReader(open(os.path.join(d, 'summary.csv')))}
for f in sorted(os.listdir(os.path.join(d, 'timelines'))):
    cfg = f[:-4]
    rows = list(csv.DictReader(open(os.path.join(d, 'timelines', f))))
    spans = collections.defaultdict(list)
    for r in rows:
        if r['worker'] == '4294967295':
            continue
        spans[r['worker']].append((int(r['start_ns']), int(r['end_ns']), int(r['item'])))
    t0 = min(s for ss in spans.values() for s, _, _ in ss)
    ends = {}
    print(labels.get(cfg, cfg))
    for w in sorted(spans):
        ss = sorted(spans[w])
        chunks = []
        for s, e, it in ss:
            if chunks and it == chunks[-1][3] + 1:
                chunks[-1][1] = e; chunks[-1][2] += 1; chunks[-1][3] = it
            else:
                chunks.append([s, e, 1, it])
        ends[w] = ss[-1][1] - t0
        busy = sum(e - s for s, e, _ in ss)
        cs = " ".join(f"{c[2]}@{(c[0]-t0)/1e6:.1f}-{(c[1]-t0)/1e6:.1f}" for c in chunks[:12])
        tail = " ".join(f"{c[2]}@{(c[0]-t0)/1e6:.1f}-{(c[1]-t0)/1e6:.1f}" for c in chunks[-6:]) if len(chunks) > 12 else ""
        print(f"  w{w}: items {len(ss)} chunks {len(chunks)} busy {busy/1e6:.2f} end {ends[w]/1e6:.2f} ms first {(ss[0][0]-t0)/1e6:.2f}\n     first: {cs}\n     last: {tail}")
    print(f"  end spread {(max(ends.values())-min(ends.values()))/1e6:.2f} ms of {max(ends.values())/1e6:.2f}")
