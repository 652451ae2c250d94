"""AF and AWF over 2² items against the best fixed chunk, one experiment per scene
(`st_*/report.md`, "Self-sizing rules against the best fixed chunk"; python3 rules.py)."""
import re, pathlib
here = pathlib.Path(__file__).parent
for d in sorted(here.glob("st_*")):
    text = (d / "report.md").read_text()
    sec = text.split("## Self-sizing rules against the best fixed chunk", 1)[1].split("\n## ", 1)[0]
    for row in sec.splitlines():
        if not row.startswith("| `"):
            continue
        c = [x.strip() for x in row.strip("|").split("|")]
        print(f"{d.name[3:]:13} {c[0]:38} best {c[2]:36} wall {c[4]:27} busy {c[5]:27} held out {c[9]:27} {c[10]}")
