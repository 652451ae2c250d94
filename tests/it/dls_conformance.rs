//! The published DLS kinds against an independent reference: `tests/data/dls_reference.py`,
//! written from LB4OMP's and DLS4LB's code (each formula cites the peer's file:line), generated
//! once into `tests/data/dls_reference.txt`. For every kind, N ∈ {1000, 4096, 65536, 100003}
//! and P ∈ {2, 4, 16, 64}, workers asking in turn and reporting their previous chunk (worker w
//! takes (1 + w mod 3)·(1 + j mod 2) s an item in its chunk after j reported ones, 0.5 s a
//! hand-out), raysched's chunk sequence must match the
//! reference's within ±1 item a chunk and end within one chunk of it.

use raysched::sched::kinds::fixed_size::FixedSize;
use raysched::sched::rule::{ChunkRule, HandOut, Report, WorkerRule};
use raysched::sched::{Policy, SchedulerKind, Slow};

const TABLE: &str = include_str!("../data/dls_reference.txt");

/// Where raysched (and so the reference) departs from LB4OMP on purpose, by the name the
/// reference gives it, and why.
const DEPARTURES: [(&str, &str); 9] = [
    (
        "tss_first_rounded_up",
        "Tzen & Ni and DLS4LB round the first chunk N/(2P) up; LB4OMP rounds it down",
    ),
    (
        "tfss_last_batches_from_tss_floor",
        "past the last TSS chunk LB4OMP repeats f − steps·δ; we floor every TSS chunk at l",
    ),
    (
        "fsc_rounded_up",
        "Kruskal & Weiss's K is a real number; DLS4LB rounds it up, LB4OMP truncates",
    ),
    (
        "awf_b_batches_from_items_left",
        "Cariño & Banicescu and DLS4LB size a batch from the items left; LB4OMP halves N/(2P)",
    ),
    (
        "awf_c_first_chunk_from_items_left",
        "AWF-C sizes every request from the items left; LB4OMP sizes each first chunk from N",
    ),
    (
        "awf_weights_rounded_up",
        "⌈w·chunk⌉ as LB4OMP; DLS4LB rounds to nearest (+0.55), within the ±1 anyway",
    ),
    (
        "fiss_at_least_two_stages",
        "LB4OMP's B = P − 1 divides by zero at P = 2; we take B ≥ 2",
    ),
    (
        "viss_at_least_one",
        "for N < P² LB4OMP's first chunk is 0 and its loop ends with items undone",
    ),
    (
        "pls_gss_from_items_left",
        "GSS sizes from the items left; LB4OMP's closed form drifts from them at the tail",
    ),
];

fn rule_of(kind: &str, n: usize, p: usize) -> Box<dyn ChunkRule> {
    if kind == "fsc" {
        // LB4OMP's FSC reads h and σ from a profiling run: here both 1 s.
        return Box::new(FixedSize::profiled(n, p, 1.0, 1.0, false));
    }
    let k = SchedulerKind::from_id(kind).unwrap_or_else(|e| panic!("{kind}: {e}"));
    match Policy::defaults(k).rule(n, p, Slow::NONE) {
        HandOut::ByWorkers(WorkerRule::Pool(pool)) => pool.rule,
        _ => panic!("{kind} is not a pool kind"),
    }
}

/// Workers in turn, each reporting its previous chunk before asking again.
fn play(rule: &mut dyn ChunkRule, n: usize, p: usize) -> Vec<usize> {
    let (mut handed, mut out, mut last, mut w) = (0, Vec::new(), vec![0usize; p], 0);
    let mut reported = vec![0usize; p];
    while handed < n {
        if last[w] > 0 {
            // Half speed every other chunk: a chunk-index-weighted mean (AWF's π) then differs
            // from the plain one, so dropping the weighting fails the test.
            let r = Report {
                items: last[w],
                secs: last[w] as f64 * (1.0 + (w % 3) as f64) * (1.0 + (reported[w] % 2) as f64),
                grab_secs: 0.5,
                ..Default::default()
            };
            rule.report(w, &r);
            reported[w] += 1;
        }
        let c = rule.next(w, n - handed).clamp(1, n - handed);
        out.push(c);
        last[w] = c;
        handed += c;
        w = (w + 1) % p;
    }
    out
}

/// Why `got` is not within ±1 a chunk of `want`, if it is not. The last chunk of each is
/// what was left, so only the chunks before the shorter one's last are held to ±1.
fn differs(got: &[usize], want: &[usize]) -> Option<String> {
    if got.len().abs_diff(want.len()) > 1 {
        return Some(format!(
            "{} chunks, the reference {}",
            got.len(),
            want.len()
        ));
    }
    let m = got.len().min(want.len()).saturating_sub(1);
    (0..m)
        .find(|&i| got[i].abs_diff(want[i]) > 1)
        .map(|i| format!("chunk {i}: {} where the reference has {}", got[i], want[i]))
}

fn table() -> Vec<(&'static str, usize, usize, Vec<usize>)> {
    TABLE
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| {
            let mut f = l.split(' ');
            let kind = f.next().unwrap();
            let n = f.next().unwrap().parse().unwrap();
            let p = f.next().unwrap().parse().unwrap();
            (kind, n, p, f.map(|c| c.parse().unwrap()).collect())
        })
        .collect()
}

#[test]
fn published_kinds_match_the_independent_reference_within_one_item_a_chunk() {
    let rows = table();
    let kinds: std::collections::BTreeSet<&str> = rows.iter().map(|r| r.0).collect();
    for want in [
        "tss",
        "tfss",
        "fsc",
        "fac",
        "factoring",
        "awf_b",
        "awf_c",
        "awf_d",
        "awf_e",
        "mfsc",
        "fiss",
        "viss",
        "pls",
        "rnd",
        "tap",
    ] {
        assert!(kinds.contains(want), "{want} missing from the table");
    }
    assert_eq!(rows.len(), kinds.len() * 16, "a 4 × 4 grid per kind");
    let mut bad = Vec::new();
    for (kind, n, p, want) in &rows {
        let got = play(rule_of(kind, *n, *p).as_mut(), *n, *p);
        assert_eq!(got.iter().sum::<usize>(), *n);
        if let Some(why) = differs(&got, want) {
            bad.push(format!("{kind} N={n} P={p}: {why}"));
        }
    }
    assert!(
        bad.is_empty(),
        "{} off the reference:\n{}",
        bad.len(),
        bad.join("\n")
    );
}

#[test]
fn the_departures_listed_here_are_the_references() {
    let header = TABLE.lines().next().unwrap();
    let named: Vec<&str> = header
        .split("departures: ")
        .nth(1)
        .unwrap()
        .split(' ')
        .collect();
    let ours: Vec<&str> = DEPARTURES.iter().map(|d| d.0).collect();
    assert_eq!(named, ours);
}

#[test]
fn the_comparison_catches_a_chunk_two_items_off_and_a_sequence_one_chunk_longer() {
    assert_eq!(differs(&[5, 4, 3], &[5, 5, 2]), None);
    assert!(differs(&[5, 6, 1], &[5, 4, 3]).is_some());
    assert!(differs(&[3, 3, 3, 1], &[5, 5]).is_some());
}
