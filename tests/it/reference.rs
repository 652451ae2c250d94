//! The reference pages under docs/reference/ are the code's own words: regenerated here and
//! compared with the committed text.

use std::path::Path;

#[test]
fn reference_pages_match_the_code() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let bless = std::env::var_os("RAYSCHED_BLESS").is_some();
    let mut stale = Vec::new();
    for (path, text) in raysched::reference::pages() {
        let file = root.join(path);
        if bless {
            std::fs::create_dir_all(file.parent().unwrap()).unwrap();
            std::fs::write(&file, &text).unwrap();
        } else if std::fs::read_to_string(&file).ok().as_deref() != Some(text.as_str()) {
            stale.push(path);
        }
    }
    assert!(
        stale.is_empty(),
        "{stale:?} differ from the code: run RAYSCHED_BLESS=1 cargo test --release --test it reference"
    );
}

#[test]
fn the_scheduler_page_lists_every_kind_and_parameter() {
    let page = raysched::reference::schedulers();
    for k in raysched::sched::SchedulerKind::ALL {
        assert!(page.contains(&format!("## `{}`", k.id())), "{}", k.id());
    }
    for p in raysched::sched::param_columns() {
        assert!(page.contains(&format!("`--{}`", p.flag())), "{}", p.name);
    }
    for o in raysched::sched::Order::ALL {
        assert!(page.contains(&format!("| `{}` |", o.id())), "{}", o.id());
    }
}

#[test]
fn every_published_kind_names_a_catalogued_technique_and_every_missing_one_says_why() {
    use raysched::sched::kinds::literature::TECHNIQUES;
    use raysched::sched::SchedulerKind;
    for k in SchedulerKind::ALL {
        if let Some((name, _)) = k.published() {
            assert!(
                TECHNIQUES.iter().any(|t| t.name == name),
                "{}: {name} is not in the catalogue",
                k.id()
            );
        }
    }
    for t in TECHNIQUES {
        let played = SchedulerKind::ALL
            .into_iter()
            .any(|k| k.published().is_some_and(|(n, _)| n == t.name));
        assert!(
            played || !t.absent.is_empty(),
            "{}: missing without a reason",
            t.name
        );
    }
    let page = raysched::reference::literature();
    assert!(
        page.contains(
            "| TSS | LB4OMP | Tzen & Ni, IEEE TPDS 4(1), 1993 | exact | `trapezoid` (variant), `tss` |"
        ),
        "{page}"
    );
    assert!(page.contains("| BOLD | LB4OMP |") && page.contains("missing: not built"));
}
