use super::*;

fn row(config: &str, rep: u32) -> RunRow {
    let mut r = RunRow::example();
    r.config = config.into();
    r.repetition = rep;
    r.scheduler = "master".into();
    r.label = "master chunk=1 B=2".into();
    r.chunk = Some("1".into());
    r.wall_s = 0.25;
    r
}

#[test]
fn rows_round_trip_and_torn_tails_are_dropped() {
    let mut bytes = RunRow::header().join(",").into_bytes();
    bytes.push(b'\n');
    bytes.extend(row("a", 0).to_line());
    bytes.extend(row("a", 1).to_line());
    let whole = bytes.len() as u64;
    let (rows, valid) = parse_runs(&bytes).unwrap();
    assert_eq!(rows, vec![row("a", 0), row("a", 1)]);
    assert_eq!(valid, whole);
    // Every possible cut of a third line leaves exactly the two whole rows.
    let third = row("b", 0).to_line();
    for cut in 0..third.len() {
        let mut b = bytes.clone();
        b.extend_from_slice(&third[..cut]);
        let (rows, valid) = parse_runs(&b).unwrap();
        assert_eq!(rows.len(), 2, "cut at {cut}");
        assert_eq!(valid, whole, "cut at {cut}");
    }
    // A last line that ends in a newline but has too few columns is dropped too.
    let mut b = bytes.clone();
    b.extend_from_slice(b"x,y\n");
    assert_eq!(parse_runs(&b).unwrap().1, whole);
    // ... but the same damage in the middle is corruption, not a torn write.
    let mut b = bytes.clone();
    b.extend_from_slice(b"x,y\n");
    b.extend(row("c", 0).to_line());
    assert!(parse_runs(&b).unwrap_err().to_string().contains("line 4"));
}

/// The columns added with MPI, before [`SAMPLE_COLUMNS`] and `slow`.
const MPI_COLUMNS: usize = 3;
/// The columns added with adaptive repetitions and the speed probe, before
/// [`PREDICTION_COLUMNS`].
const SAMPLE_COLUMNS: usize = 7;
/// The cost model's columns, before [`CHECK_COLUMNS`].
const PREDICTION_COLUMNS: usize = 4;
/// The GPU image check's columns, before the per-source ones.
const CHECK_COLUMNS: usize = 2;
/// The per-source settings and shares, at the end of the row.
fn source_columns() -> usize {
    sourcing_columns().count()
}

#[test]
fn a_runs_file_from_before_the_mpi_columns_is_read_and_upgraded_on_resume() {
    let cols = RunRow::header();
    let old = MPI_COLUMNS + SAMPLE_COLUMNS + PREDICTION_COLUMNS + CHECK_COLUMNS + source_columns();
    let old_header = cols[..cols.len() - old].join(",");
    let strip = |r: &RunRow| {
        let line = String::from_utf8(r.to_line()).unwrap();
        let fields: Vec<&str> = line.trim_end().split(',').collect();
        fields[..fields.len() - old].join(",") + "\n"
    };
    let text = format!(
        "{old_header}\n{}{}",
        strip(&row("a", 0)),
        strip(&row("a", 1))
    );
    let (rows, valid) = parse_runs(text.as_bytes()).unwrap();
    assert_eq!(rows, vec![row("a", 0), row("a", 1)]);
    assert_eq!(rows[0].sources, "local");
    assert_eq!(valid, text.len() as u64);
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("runs.csv");
    std::fs::write(&p, &text).unwrap();
    let (mut f, rows) = RunsFile::open(&p, false).unwrap();
    assert_eq!(rows.len(), 2);
    let mut r = row("b", 0);
    r.sources = "mpi".into();
    r.ranks = Some(3);
    r.transport = Some("shared_memory".into());
    f.append(&r).unwrap();
    let back = std::fs::read_to_string(&p).unwrap();
    assert!(back.starts_with(&(cols.join(",") + "\n")), "{back}");
    assert_eq!(read_runs(&p).unwrap().0, vec![row("a", 0), row("a", 1), r]);
}

#[test]
fn a_runs_file_from_before_the_prediction_columns_reads_them_empty() {
    let cols = RunRow::header();
    let later = PREDICTION_COLUMNS + CHECK_COLUMNS + source_columns();
    assert_eq!(cols[cols.len() - later], "predicted_wall_s");
    let old_header = cols[..cols.len() - later].join(",");
    let line = String::from_utf8(row("a", 0).to_line()).unwrap();
    let fields: Vec<&str> = line.trim_end().split(',').collect();
    let text = format!(
        "{old_header}\n{}\n",
        fields[..fields.len() - later].join(",")
    );
    let (rows, _) = parse_runs(text.as_bytes()).unwrap();
    assert_eq!(rows, vec![row("a", 0)]);
    assert_eq!(rows[0].predicted_wall_s, None);
    // And a row with a prediction round-trips.
    let mut p = row("b", 0);
    p.predicted_wall_s = Some(0.125);
    p.predicted_handout_s = Some(0.001);
    let mut bytes = (cols.join(",") + "\n").into_bytes();
    bytes.extend(p.to_line());
    assert_eq!(parse_runs(&bytes).unwrap().0, vec![p]);
}

#[test]
fn per_source_columns_derive_from_the_kinds_round_trip_and_read_empty_in_old_files() {
    let cols = RunRow::header();
    let n = source_columns();
    let tail: Vec<&str> = cols[cols.len() - n..].iter().map(String::as_str).collect();
    assert_eq!(
        &tail[..4],
        ["gpu_chunk", "gpu_buffer", "balance", "threads_items"]
    );
    assert!(tail.contains(&"gpu_busy_s") && tail.contains(&"mpi_pixels"));
    // A row of a threads+gpu run round-trips with its settings and shares.
    let mut r = row("g", 0);
    r.sources = "threads+gpu".into();
    r.image_z = Some(-0.5);
    r.agrees = Some(true);
    let worker = |source, items: u64, busy_s: f64| crate::core::metrics::WorkerStats {
        items,
        pixels: 16 * items,
        busy_s,
        source: Some(source),
        ..Default::default()
    };
    let shares = crate::sched::Share::of(&crate::core::metrics::RunStats {
        workers: vec![
            worker(crate::sched::SourceKind::Threads, 3, 0.25),
            worker(crate::sched::SourceKind::Gpu, 5, 0.125),
        ],
        ..Default::default()
    });
    r.sourcing = [Some("4096".to_string()), None, Some("true".into())]
        .into_iter()
        .chain(crate::sched::Share::cells(&shares))
        .collect();
    let mut bytes = (cols.join(",") + "\n").into_bytes();
    bytes.extend(r.to_line());
    let back = parse_runs(&bytes).unwrap().0;
    assert_eq!(back, vec![r.clone()]);
    assert_eq!(back[0].sourcing("gpu_chunk"), Some("4096"));
    assert_eq!(back[0].sourcing("gpu_items"), Some("5"));
    assert_eq!(back[0].shares(), shares.to_vec());
    // Its config key differs from the same row on threads alone; a threads row's does not
    // change with the new columns.
    let plain = row("g", 0);
    assert_ne!(r.config_key(), plain.config_key());
    assert!(!plain.config_key().contains("sources"));
    // A file from before the columns reads them as empty.
    let old_header = cols[..cols.len() - n].join(",");
    let line = String::from_utf8(plain.to_line()).unwrap();
    let fields: Vec<&str> = line.trim_end().split(',').collect();
    let text = format!("{old_header}\n{}\n", fields[..fields.len() - n].join(","));
    let rows = parse_runs(text.as_bytes()).unwrap().0;
    assert_eq!(rows, vec![plain]);
    assert!(rows[0].shares().iter().all(Option::is_none));
}

#[test]
fn open_truncates_the_partial_row_and_appends_after_it() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("runs.csv");
    {
        let (mut f, rows) = RunsFile::open(&p, false).unwrap();
        assert!(rows.is_empty());
        f.append(&row("a", 0)).unwrap();
    }
    let line = row("a", 1).to_line();
    let mut tail = std::fs::OpenOptions::new().append(true).open(&p).unwrap();
    tail.write_all(&line[..line.len() / 2]).unwrap();
    drop(tail);
    let (mut f, rows) = RunsFile::open(&p, false).unwrap();
    assert_eq!(rows, vec![row("a", 0)]);
    assert!(f.is_done("a", 0) && !f.is_done("a", 1));
    f.append(&row("a", 1)).unwrap();
    let (rows, _) = read_runs(&p).unwrap();
    assert_eq!(rows, vec![row("a", 0), row("a", 1)]);
    let (_, rows) = RunsFile::open(&p, true).unwrap();
    assert!(rows.is_empty());
    assert_eq!(read_runs(&p).unwrap().0, vec![]);
}

/// Every row of a published run recomputes its own config id: the key is a function of
/// the row's columns alone, and the scheme has not moved since that run (master rows with
/// `returns` and `passes`, shared-scheduler rows without).
#[test]
fn published_ids_recompute_from_their_rows() {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("results/published/master_passes/runs.csv");
    let rows = read_runs(&path).unwrap().0;
    assert!(rows.len() > 50, "{} rows", rows.len());
    assert!(rows.iter().any(|r| r.param("passes") == Some("workers")));
    for r in &rows {
        assert_eq!(hex(fnv(r.config_key().as_bytes())), r.config, "{}", r.label);
    }
}

/// A parameter newer than [`KEYED_BY_POSITION`] adds nothing to the key at its default or
/// where the kind lacks it, and `|name=value` off its default.
#[test]
fn a_newer_parameter_keys_only_off_its_default() {
    let default = |name: &str| (name == "new_knob").then(|| "4".to_string());
    let key = |v: Option<&'static str>| {
        named_params_key(
            [("buffer", Some("2")), ("new_knob", v), ("grab", None)].into_iter(),
            default,
        )
    };
    assert_eq!(key(None), "");
    assert_eq!(key(Some("4")), "");
    assert_eq!(key(Some("8")), "|new_knob=8");
    // Every name keyed by position is a parameter column still.
    for name in KEYED_BY_POSITION {
        assert!(param_columns().iter().any(|p| p.name == name), "{name}");
    }
    // And a kind's default reads back through its id.
    assert_eq!(default_of("master", "buffer").as_deref(), Some("2"));
    assert_eq!(default_of("no_such_kind", "buffer"), None);
}
