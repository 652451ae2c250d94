"""Per configuration of a timeline experiment: where its last worker's time went."""
import csv, sys, os, collections
d = sys.argv[1]
labels = {r['config']: r['label'] for r in csv.DictReader(open(os.path.join(d, 'summary.csv')))}
for f in sorted(os.listdir(os.path.join(d, 'timelines'))):
    cfg = f[:-4]
    rows = list(csv.DictReader(open(os.path.join(d, 'timelines', f))))
    spans = collections.defaultdict(list)
    for r in rows:
        spans[r['worker']].append((int(r['start_ns']), int(r['end_ns']), int(r['item'])))
    work = {w: s for w, s in spans.items() if w != '4294967295'}
    end = max(e for s in work.values() for _, e, _ in s)
    hot = max((e - s, s, e, it, w) for w, ss in work.items() for s, e, it in ss)
    out = [f"{labels.get(cfg, cfg):48s} wall(spans) {end/1e6:6.2f} ms; hot item {hot[3]} on w{hot[4]} {hot[0]/1e6:5.2f} ms, starts {hot[1]/1e6:5.2f} ms"]
    for w in sorted(work):
        ss = sorted(work[w])
        busy = sum(e - s for s, e, _ in ss)
        gaps = [b[0] - a[1] for a, b in zip(ss, ss[1:]) if b[0] > a[1]]
        first = ss[0][0]
        out.append(f"   w{w}: items {len(ss)}, busy {busy/1e6:5.2f}, first start {first/1e6:5.2f}, gaps {len(gaps)} sum {sum(gaps)/1e6:5.2f} ms max {max(gaps, default=0)/1e6:5.2f}, end {ss[-1][1]/1e6:5.2f}")
    m = spans.get('4294967295', [])
    out.append(f"   master passes that handed out: {len(m)}")
    print("\n".join(out))
