"""AF and AWF at their default 2² items against the best fixed chunk, from the three
report.md files ("Self-sizing rules against the best fixed chunk"; python3 rules.py)."""
import re, pathlib
here = pathlib.Path(__file__).parent
for exp in ["advise_check", "skewed", "heterogeneous"]:
    text = (here / exp / "report.md").read_text()
    if "## Self-sizing rules" not in text:
        continue
    sec = text.split("## Self-sizing rules against the best fixed chunk", 1)[1].split("\n## ", 1)[0]
    for part in sec.split("\n### ")[1:]:
        scene = part.split(" ", 1)[0]
        for row in part.splitlines():
            m = re.match(r"\| `((adaptive_factoring|awf) chunk=2[^`]*)` \|", row)
            if not m:
                continue
            c = [x.strip() for x in row.strip("|").split("|")]
            print(f"{exp:13} {scene:13} {c[0]:32} wall {c[4]:28} held out {c[9]:28} {c[10]}")
