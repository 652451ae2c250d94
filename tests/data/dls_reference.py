#!/usr/bin/env python3
"""Independent reference chunk sequences for raysched's published DLS kinds.

Written from the peers' code, not from raysched's rules: LB4OMP
(github unibas-dmi-hpc/LB4OMP, runtime/src/kmp_dispatch.cpp at commit bd45b1e) and DLS4LB
(github unibas-dmi-hpc/DLS4LB, DLS.c). Each formula cites file:line. Where raysched follows
the paper (or fixes a peer's undefined case) the reference does the same, and the departure is
named in DEPARTURES; tests/it/dls_conformance.rs lists the same names with their reasons and
checks the two lists agree.

Workers ask in turn (0, 1, ..., P-1, 0, ...). Before asking again a worker reports its previous
chunk: n items in n * (1 + w % 3) * (1 + j % 2) s of work, j the chunks it reported before
(workers of speeds 1, 1/2, 1/3, each at half speed every other chunk, so that a mean weighted
by the chunk index differs from the plain mean), its hand-out taking 0.5 s. Output: tests/data/dls_reference.txt, one line per (kind, N, P):
`kind N P c1 c2 ...`. Run: python3 tests/data/dls_reference.py > tests/data/dls_reference.txt
"""
import math

GRID_N = [1000, 4096, 65536, 100003]
GRID_P = [2, 4, 16, 64]
GRAB_SECS = 0.5

DEPARTURES = [
    "tss_first_rounded_up",
    "tfss_last_batches_from_tss_floor",
    "fsc_rounded_up",
    "awf_b_batches_from_items_left",
    "awf_c_first_chunk_from_items_left",
    "awf_weights_rounded_up",
    "fiss_at_least_two_stages",
    "viss_at_least_one",
    "pls_gss_from_items_left",
]


def item_secs(w, j):
    return (1.0 + w % 3) * (1.0 + j % 2)


def play(n, p, next_chunk, report=None):
    """Workers in turn; each chunk clamped to 1..=remaining, as every raysched executor does."""
    out, handed, last, reported, w = [], 0, [0] * p, [0] * p, 0
    while handed < n:
        if report and last[w] > 0:
            report(w, last[w], last[w] * item_secs(w, reported[w]), GRAB_SECS)
            reported[w] += 1
        c = max(1, min(next_chunk(w, n - handed), n - handed))
        out.append(c)
        last[w] = c
        handed += c
        w = (w + 1) % p
    return out


def tss(n, p, min_chunk=1):
    # kmp_dispatch.cpp:1882-1909: F = tc/(2P) (integer: rounded down; departure
    # tss_first_rounded_up: Tzen & Ni and DLS4LB DLS.c:589 round it up), L = chunk capped at F,
    # N = ceil(2tc/(F+L)) at least 2, delta = (F-L)/(N-1) on integers.
    f = max(1, -(-n // (2 * p)))
    l = min(max(1, min_chunk), f)
    cycles = max(2, -(-2 * n // (f + l)))
    delta = (f - l) // (cycles - 1)
    # kmp_dispatch.cpp:3991-4004: chunk `index` starts at index*(2F-(index-1)*delta)/2 and ends
    # before (index+1)*(2F-index*delta)/2: its size is F - index*delta. Beyond N cycles the
    # peer stops; the last chunk takes what is left (DLS.c:242-249 keeps min_chunk).
    k = [0]

    def nxt(w, r):
        c = max(l, f - k[0] * delta)
        k[0] += 1
        return c

    return play(n, p, nxt)


def tfss(n, p):
    # kmp_dispatch.cpp:2253-2266: tss_chunk = ceil(tc/(2P)), steps = ceil(2tc/(tss_chunk+1)),
    # delta = (tss_chunk-1)/(steps-1) stored in an integer (parm2).
    f = math.ceil(n / (2 * p))
    steps = math.ceil(2.0 * n / (f + 1))
    delta = (f - 1) // (steps - 1) if steps > 1 else 0
    counter = [0]

    def nxt(w, r):
        # kmp_dispatch.cpp:4753-4769: batch c = counter/P; temp = f - c*P*delta, the mean of
        # temp, temp-delta, ..., temp-(P-1)*delta on integers, at least min_chunk. The peer
        # falls back to f - steps*delta once temp < 0 (departure
        # tfss_last_batches_from_tss_floor: raysched floors each TSS chunk at l = 1 instead).
        c = counter[0] // p
        counter[0] += 1
        chunks = [max(1, f - (c * p + i) * delta) for i in range(p)]
        return max(1, sum(chunks) // p)

    return play(n, p, nxt)


def fsc(n, p, h, sigma):
    # kmp_dispatch.cpp:1945-1956 and DLS.c:644-646: K = (sqrt(2) N h / (sigma P sqrt(ln P)))^(2/3);
    # LB4OMP truncates to int, DLS4LB rounds up (departure fsc_rounded_up: as DLS4LB).
    k = math.ceil((math.sqrt(2.0) * n * h / (sigma * p * math.sqrt(math.log(p)))) ** (2.0 / 3.0))
    return play(n, p, lambda w, r: k)


def fac(n, p, cv):
    # kmp_dispatch.cpp:2030-2033: b0 = P sigma/(2 mu) / sqrt(N), x0 = 1 + b0^2 + b0 sqrt(b0^2+2),
    # first chunk ceil(N/(x0 P)), handed to the first P requests (q_counter = P, 2053-2058).
    # kmp_dispatch.cpp:4171-4174: later batches b = P sigma/(2 mu)/sqrt(R),
    # x = 2 + b^2 + b sqrt(b^2+4), chunk ceil(R/(x P)), R left when the batch starts.
    state = {"q": 0, "cs": 0, "first": True}

    def nxt(w, r):
        if state["q"] == 0:
            b = p * cv / 2.0 / math.sqrt(r)
            if state["first"]:
                x = 1 + b * b + b * math.sqrt(b * b + 2)
                state["first"] = False
            else:
                x = 2 + b * b + b * math.sqrt(b * b + 4)
            state["cs"] = max(1, math.ceil(r / (x * p)))
            state["q"] = p
        state["q"] -= 1
        return state["cs"]

    return play(n, p, nxt)


def fac2(n, p):
    # DLS.c:251-260: at a batch start tChunk = (rem + 2P - 1)/(2P), P chunks of it.
    state = {"left": 0, "cs": 0}

    def nxt(w, r):
        if state["left"] == 0:
            state["cs"] = max(1, (r + 2 * p - 1) // (2 * p))
            state["left"] = p
        state["left"] -= 1
        return state["cs"]

    return play(n, p, nxt)


def awf(n, p, batched, elapsed):
    # DLS.c:905-912 (B, C) and 938-945 (D, E): a worker's mu is
    # sum_j j*t_j / sum_j j*n_j, t_j the chunk's work time (B, C) or its elapsed time, hand-out
    # included (D, E); kmp_dispatch.cpp:5173-5176 (sum_time += chunk_index*diff,
    # sum_iters += chunk_index*cs) is the same sum.
    # kmp_dispatch.cpp:5177-5212: the weight over the K workers with a mu:
    # raw = mean(pi)/pi, weight = raw*K/sum(raw); a worker without one keeps weight 1.
    sums = [[0.0, 0.0, 1] for _ in range(p)]
    batch = {"left": 0, "base": 0}

    def report(w, items, secs, grab):
        t = secs + grab if elapsed else secs
        s = sums[w]
        s[0] += s[2] * t
        s[1] += s[2] * items
        s[2] += 1

    def weight(w):
        pis = [s[0] / s[1] for s in sums if s[1] > 0]
        if sums[w][1] == 0 or not pis:
            return 1.0
        mean = sum(pis) / len(pis)
        raw = [mean / x for x in pis]
        return (mean / (sums[w][0] / sums[w][1])) * len(pis) / sum(raw)

    def nxt(w, r):
        if batched:
            # DLS.c:294-298: at a batch start (batchRem == 0) tChunk = ceil(rem/(2P)), the batch
            # P of it (departure awf_b_batches_from_items_left: LB4OMP 5225-5232 halves
            # ceil(N/(2P)) per batch instead).
            if batch["left"] == 0:
                batch["base"] = max(1, (r + 2 * p - 1) // (2 * p))
                batch["left"] = p
            batch["left"] -= 1
            base = batch["base"]
        else:
            # DLS.c:321 and kmp_dispatch.cpp:5407: ceil(R/(2P)) at each request (departure
            # awf_c_first_chunk_from_items_left: LB4OMP 5404-5405 sizes each worker's first
            # chunk from N).
            base = max(1, (r + 2 * p - 1) // (2 * p))
        # kmp_dispatch.cpp:5235: ceil(weight * cs); DLS.c:299 rounds to nearest
        # (departure awf_weights_rounded_up: as LB4OMP).
        return max(1, math.ceil(weight(w) * base - 1e-9))

    return play(n, p, nxt, report)


def mfsc(n, p):
    # kmp_dispatch.cpp:2243-2244 and DLS.c:639-640: t = ceil(N/P),
    # chunk = (int)(0.55 + t ln 2 / ln t).
    t = (n + p - 1) // p
    k = int(0.55 + t * math.log(2.0) / math.log(1.0 * t)) if t > 2 else 1
    return play(n, p, lambda w, r: max(1, k))


def fiss(n, p):
    # kmp_dispatch.cpp:2223-2233: B = P - 1 stages (departure fiss_at_least_two_stages: B = 1,
    # P = 2, divides by zero; raysched and this reference take B = 2), X = 2 + B,
    # chunk0 = floor(N/(X P)), delta = floor(2N(1 - B/X) / (P B (B - 1))).
    b = max(2, p - 1)
    x = 2.0 + b
    c0 = math.floor(n / (x * p))
    delta = max(0, math.floor(2 * n * (1 - (b / x)) / (p * b * (b - 1))))
    counter = [0]

    def nxt(w, r):
        # kmp_dispatch.cpp:4678-4680: batch counter/P, chunk0 + batch*delta.
        c = counter[0] // p
        counter[0] += 1
        return max(1, c0 + c * delta)

    return play(n, p, nxt)


def viss(n, p):
    # kmp_dispatch.cpp:2214-2216: viss_param = P, parm1 = ceil(tc/(viss_param*P)) of an integer
    # division (rounded down). 4631-4638: batch c = counter/P; c > 0:
    # floor(parm1 (1 - 0.5^(c+1)) / (1 - 0.5)), else parm1. (departure viss_at_least_one: for
    # N < P^2 the peer's chunk is 0 and its loop ends with items undone; raysched takes 1.)
    c0 = n // (p * p)
    counter = [0]

    def nxt(w, r):
        c = counter[0] // p
        counter[0] += 1
        if c > 0:
            k = math.floor(c0 * ((1 - 0.5 ** (c + 1)) / (1 - 0.5)))
        else:
            k = c0
        return max(1, k)

    return play(n, p, nxt)


def pls(n, p, swr=0.5):
    # kmp_dispatch.cpp:2274-2277: static_part = ceil(tc*ratio/P), ratio 0.5.
    static = math.ceil(n * swr / p)
    counter = [0]

    def nxt(w, r):
        c = counter[0]
        counter[0] += 1
        if c < p:
            return static
        # kmp_dispatch.cpp:4811-4816 writes GSS in closed form,
        # ceil((1 - 1/P)^s (N - P static)/P); departure pls_gss_from_items_left: GSS as
        # defined (Polychronopoulos & Kuck), ceil(R/P) of the items actually left.
        return max(1, -(-r // p))

    return play(n, p, nxt)


def tap(n, p, cv, alpha):
    # kmp_dispatch.cpp:1995-2005: v = alpha sigma / mu (profiled mu, sigma; KMP_ALPHA's alpha,
    # kmp_global.cpp:574 default 1.0), dbl_parm2 = 1/P, dbl_parm3 = v^2/2, dbl_parm4 = v^2/4.
    # kmp_dispatch.cpp:4117-4121: t = remaining/P, chunk = ceil(t + v^2/2 - v sqrt(2t + v^2/4)),
    # at least the minimum chunk (1 here).
    v = alpha * cv

    def nxt(w, r):
        t = r * (1.0 / p)
        return max(1, math.ceil(t + v * v / 2.0 - v * math.sqrt(2 * t + v * v / 4.0)))

    return play(n, p, nxt)


def splitmix64(state):
    # Steele, Lea & Flood 2014 (the constants of java.util.SplittableRandom).
    m = (1 << 64) - 1
    s = (state + 0x9E3779B97F4A7C15) & m
    z = s
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & m
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & m
    return s, z ^ (z >> 31)


def rnd(n, p):
    # kmp_dispatch.cpp:4593-4595: chunk = rand % (max - start + 1) + start, start 1; raysched's
    # upper bound is ceil(N/(2P)) and its generator SplitMix64 seeded 0x5eed0fa11c4a7 (the
    # peer's rand_r is seeded from the clock, so only the bounds carry over).
    lo, hi = 1, max(1, -(-n // (2 * p)))
    st = [0x5EED0FA11C4A7]

    def nxt(w, r):
        st[0], x = splitmix64(st[0])
        return lo + x % (hi - lo + 1)

    return play(n, p, nxt)


KINDS = {
    "tss": tss,
    "tfss": tfss,
    "fsc": lambda n, p: fsc(n, p, 1.0, 1.0),
    "fac": lambda n, p: fac(n, p, 1.0),
    "factoring": fac2,
    "awf_b": lambda n, p: awf(n, p, True, False),
    "awf_c": lambda n, p: awf(n, p, False, False),
    "awf_d": lambda n, p: awf(n, p, True, True),
    "awf_e": lambda n, p: awf(n, p, False, True),
    "mfsc": mfsc,
    "fiss": fiss,
    "viss": viss,
    "pls": pls,
    "rnd": rnd,
    "tap": lambda n, p: tap(n, p, 1.0, 1.0),
}

if __name__ == "__main__":
    print("# generated by tests/data/dls_reference.py; departures: " + " ".join(DEPARTURES))
    for kind, f in KINDS.items():
        for n in GRID_N:
            for p in GRID_P:
                seq = f(n, p)
                assert sum(seq) == n, (kind, n, p)
                print(kind, n, p, " ".join(map(str, seq)))
