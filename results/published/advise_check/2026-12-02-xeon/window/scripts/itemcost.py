"""Per-item cost c = (t_pixel_items - t_row_items) / (16384 - 128) from criterion's median
estimate in each bench run; old/new ratio per alternation pair."""
import re, sys, glob, statistics
W = sys.argv[1]
unit = {'ns': 1e-9, 'µs': 1e-6, 'us': 1e-6, 'ms': 1e-3, 's': 1.0}
def parse(f):
    t = open(f).read()
    out = {}
    for name in ['pixel_items', 'row_items']:
        m = re.search(r'skewed_low_1spp_' + name + r'\s*\n?\s*time:\s*\[([\d.]+) (\S+) ([\d.]+) (\S+) ([\d.]+) (\S+)\]', t)
        out[name] = [float(m.group(i)) * unit[m.group(i + 1)] for i in (1, 3, 5)]
    return out
res = {}
for b in ['OLD', 'NEW']:
    for k in (1, 2, 3):
        f = f'{W}/bench_{b}_{k}.txt'
        r = parse(f)
        c = [(r['pixel_items'][i] - r['row_items'][i]) / (16384 - 128) for i in range(3)]
        res[(b, k)] = (r, c)
        print(f"{b} {k}: pixel items {r['pixel_items'][1]*1e3:.3f} ms [{r['pixel_items'][0]*1e3:.3f}-{r['pixel_items'][2]*1e3:.3f}], rows {r['row_items'][1]*1e3:.3f} ms [{r['row_items'][0]*1e3:.3f}-{r['row_items'][2]*1e3:.3f}], c = {c[1]*1e9:.1f} ns")
ratios_c = [res[('NEW', k)][1][1] / res[('OLD', k)][1][1] for k in (1, 2, 3)]
ratios_px = [res[('NEW', k)][0]['pixel_items'][1] / res[('OLD', k)][0]['pixel_items'][1] for k in (1, 2, 3)]
ratios_row = [res[('NEW', k)][0]['row_items'][1] / res[('OLD', k)][0]['row_items'][1] for k in (1, 2, 3)]
print("c new/old per pair:", ' '.join(f'{r:.3f}' for r in ratios_c), f"median {statistics.median(ratios_c):.3f}")
print("pixel-item frame new/old per pair:", ' '.join(f'{r:.3f}' for r in ratios_px))
print("row-item frame new/old per pair:", ' '.join(f'{r:.3f}' for r in ratios_row))
