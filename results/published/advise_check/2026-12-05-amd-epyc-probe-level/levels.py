import re,sys,os
runs=[(v, v) for v in ("probe3", "p16", "p4", "warm1", "warm2")]
for name,d in runs:
    for e in ("advise_check","skewed","heterogeneous"):
        t=open(f"{d}/{e}/report.md").read()
        sec=t.split("## Cost model: predicted against measured")[1].split("\n## ")[0]
        parts=re.split(r"\n### ",sec)[1:]
        out=[]
        for p in parts:
            scene=p.split()[0]
            lv=re.search(r"The probe's level: it put the image's work at [0-9.]* ms, ([-+0-9.]*) %",p)
            er=re.search(r"Error at the measured best [^:]*: ([-+0-9.]*) %",p)
            out.append(f"{scene} {lv.group(1) if lv else '–'}/{er.group(1) if er else '–'}")
        print(name,e,"; ".join(out))
