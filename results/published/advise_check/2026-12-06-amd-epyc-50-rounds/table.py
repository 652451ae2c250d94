"""The per-scene table of README.md from the three report.md files (python3 table.py)."""
import re, sys, pathlib
here = pathlib.Path(__file__).parent
def pct(s):
    return s.replace("-", "−")
for exp in ["advise_check", "skewed", "heterogeneous"]:
    text = (here / exp / "report.md").read_text()
    sec = text.split("## Cost model: predicted against measured", 1)[1].split("\n## ", 1)[0]
    for part in sec.split("\n### ")[1:]:
        scene = part.split(" ", 1)[0]
        pick = re.search(r"^The model's pick `([^`]*)`[^\n]*?(is the measured best|took ([0-9.]+)× \(95 % CI ([0-9.–]+)\)[^(]*\((statistically tied with it|not tied with it))", part, re.M)
        err = re.search(r"Error at the measured best `([^`]*)`: ([-+0-9.]+) %; across the \d+ configurations: median \|error\| ([0-9.]+) %, largest ([0-9.]+) %", part)
        lvl = re.search(r"work at [0-9.]+ ms, ([-+0-9.]+) % off .*?error at the measured best is ([-+0-9.]+) %, median \|error\| ([0-9.]+) %, largest ([0-9.]+) %", part)
        if pick.group(2) == "is the measured best":
            p = f"`{pick.group(1)}`: the measured best"
        else:
            tied = "tied" if pick.group(5).startswith("stat") else "**not tied**"
            p = f"`{pick.group(1)}`: {pick.group(3)}× ({pick.group(4)}), {tied}"
        print(f"| {exp}, {scene} | {p} | {pct(err.group(2))} % | {pct(lvl.group(2))} % | {err.group(3)} / {err.group(4)} % | {lvl.group(3)} / {lvl.group(4)} % | {pct(lvl.group(1))} % |")
