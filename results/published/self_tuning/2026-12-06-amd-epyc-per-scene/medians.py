"""Each equal-workers configuration's median wall over the fastest fixed chunk's, per scene
(`st_*/summary.csv`; python3 medians.py). ss = self_scheduling in scanline order, AF =
adaptive_factoring and awf in scatter order, all over the items named (2 = 2² tiles)."""
import csv, pathlib
here = pathlib.Path(__file__).parent
for d in sorted(here.glob("st_*")):
    rows = [r for r in csv.DictReader(open(d / "summary.csv")) if "slow" not in r["label"]]
    med = {r["label"]: float(r["wall_median_s"]) for r in rows}
    best = min(v for k, v in med.items() if k.startswith("self_scheduling"))
    short = lambda k: k.replace("self_scheduling", "ss").replace("adaptive_factoring", "AF").replace(" chunk=", "")
    print(f"{d.name[3:]:13}", " ".join(f"{short(k)}={v / best:.3f}" for k, v in sorted(med.items()) if k != "serial"))
