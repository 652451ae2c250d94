"""Per scene, equal workers: median over rounds of the paired ratios of Σ busy time (work_s)
and wall time: each rule over self_scheduling 2² (same items, scanline order) and 2² over the
best fixed chunk (by median wall). Reads runs.csv of the folder given."""
import csv, sys, statistics as st
from collections import defaultdict
rows = [r for r in csv.DictReader(open(sys.argv[1] + "/runs.csv")) if r["scheduler"] != "serial" and r["slow"] in ("", "none")]
by = defaultdict(dict)  # (scene, label) -> rep -> (wall, work)
for r in rows:
    by[(r["scene"], r["label"])][int(r["repetition"])] = (float(r["wall_s"]), float(r["work_s"]))
def ratio(a, b, k):
    reps = sorted(set(a) & set(b))
    return st.median(a[i][k] / b[i][k] for i in reps)
for scene in sorted({s for s, _ in by}):
    fixed = {l: v for (s, l), v in by.items() if s == scene and l.startswith("self_scheduling")}
    best = min(fixed, key=lambda l: st.median(w for w, _ in fixed[l].values()))
    ss2 = fixed["self_scheduling chunk=2"]
    line = f"{scene:14s} best {best.split('=')[1]:>3s}  ss2/best wall {ratio(ss2, fixed[best], 0):.3f} busy {ratio(ss2, fixed[best], 1):.3f}"
    for rule in ("adaptive_factoring chunk=2", "awf chunk=2"):
        a = by[(scene, rule)]
        line += f" | {rule.split()[0][:4]}/ss2 wall {ratio(a, ss2, 0):.3f} busy {ratio(a, ss2, 1):.3f}"
    print(line)
