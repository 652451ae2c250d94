#!/usr/bin/env python3
"""Wall error per local-thread configuration in every validation.csv under a folder (default:
this snapshot), and per simulation: configurations within 5 %, and over every configuration but
the per-ray master the mean, mean |.| and largest |.| error.
   python3 scripts/compare.py [FOLDER]"""
import csv, glob, os, statistics as st, sys
root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..")
sims = sorted(glob.glob(os.path.join(root, "set*", "*", "validation.csv")))
data = {}
for f in sims:
    tag = os.path.relpath(os.path.dirname(f), root)
    data[tag] = {(r["label"][:48], r["workers"]): (100 * float(r["wall_error"]), 100 * float(r["wall_error_at_serial"]))
                 for r in csv.DictReader(open(f)) if r["sources"] == "threads"}
tags = list(data)
keys = sorted(data[tags[0]])
print(f"{'configuration':54s}" + "".join(f"{t:>15s}" for t in tags))
for k in keys:
    print(f"{k[0]:48s} w={k[1]}  " + " ".join(f"{data[t][k][0]:+6.1f}/{data[t][k][1]:+6.1f}" for t in tags))
for t in tags:
    e = [v[0] for v in data[t].values()]
    a = [v[1] for v in data[t].values()]
    nm = [v[0] for k, v in data[t].items() if not k[0].startswith("master chunk=1 ")]
    print(f"{t}: wall ≤ 5 % {sum(abs(x) <= 5 for x in e)}/{len(e)}, at serial {sum(abs(x) <= 5 for x in a)}/{len(a)};"
          f" without the per-ray master mean {st.mean(nm):+.2f} %, mean |.| {st.mean(map(abs, nm)):.2f}, max |.| {max(map(abs, nm)):.2f}")
