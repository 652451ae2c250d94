//! The measurement loop's state and its steps: the serial baselines, each round's samples
//! appended as rows, images checked against the serial one.

use super::*;

/// The measurement loop's state: where rows go and what has been seen.
pub(in crate::studies::experiment) struct Session<'p, 'r> {
    pub(in crate::studies::experiment) plan: &'p ExperimentPlan,
    pub(in crate::studies::experiment) dir: PathBuf,
    pub(in crate::studies::experiment) runs: RunsFile,
    pub(in crate::studies::experiment) serial: HashMap<usize, SerialInfo>,
    pub(in crate::studies::experiment) progress: Progress,
    pub(in crate::studies::experiment) remote: Option<&'r mut dyn Remote>,
    pub(in crate::studies::experiment) mismatches: usize,
    pub(in crate::studies::experiment) measured: usize,
    pub(in crate::studies::experiment) untimed: usize,
    /// The cost model's prediction per configuration id (`predict = true`).
    pub(in crate::studies::experiment) predictions: HashMap<String, Prediction>,
    /// This round's machine-speed probe, seconds.
    pub(in crate::studies::experiment) probe_s: Option<f64>,
    /// This process measures one round for a parent ([`super::super::isolate`]).
    pub(in crate::studies::experiment) child: bool,
}
impl Session<'_, '_> {
    /// A round's process starts cold (page faults on its first buffers, empty caches): one
    /// untimed render of the round's first configuration, unless that one's own warm-ups come
    /// first anyway.
    pub(in crate::studies::experiment) fn warm_process(
        &mut self,
        first: &ConfigState<'_>,
    ) -> Result<(), RunError> {
        if first.inner.is_none() && self.plan.warmup > 0 {
            return Ok(());
        }
        measure(self.plan, first.config, false, &mut self.remote)?;
        self.untimed += 1;
        Ok(())
    }

    /// One timed sample of `st` (its warm-ups first when it has none yet), appended.
    pub(in crate::studies::experiment) fn sample(
        &mut self,
        st: &mut ConfigState<'_>,
    ) -> Result<(), RunError> {
        let plan = self.plan;
        let c = st.config;
        self.progress.set_message(label_of(plan, c));
        let inner = match st.inner {
            Some(k) => k,
            None => {
                let mut last = None;
                for _ in 0..plan.warmup {
                    last = Some(measure(plan, c, false, &mut self.remote)?.1.wall_s);
                    self.untimed += 1;
                }
                let k = if plan.stats.min_sample_s > 0.0 {
                    let t = match last {
                        Some(t) => t,
                        None => {
                            self.untimed += 1;
                            measure(plan, c, false, &mut self.remote)?.1.wall_s
                        }
                    };
                    inner_count(t, plan.stats.min_sample_s)
                } else {
                    1
                };
                st.inner = Some(k);
                k
            }
        };
        let rep = st.next_rep;
        let want_timeline = plan.timeline && rep == 0 && c.spec.is_some();
        let load_before = crate::util::host::load_average().map(|l| l[0]);
        let cpu0 = crate::util::cpu_time::process_cpu_s();
        let timestamp = meta::now_utc();
        let mut total = 0.0;
        let mut first_hash = None;
        let mut same = true;
        let mut last = None;
        let mut timeline = None;
        for k in 0..inner {
            let (image, mut stats) = measure(plan, c, want_timeline && k == 0, &mut self.remote)?;
            if k == 0 {
                // The first render's timeline: the row keeps the last render's stats.
                timeline = stats.timeline.take();
            }
            total += stats.wall_s;
            let h = image.hash();
            same &= *first_hash.get_or_insert(h) == h;
            last = Some((image, stats));
        }
        let cpu1 = crate::util::cpu_time::process_cpu_s();
        let (image, mut stats) = last.expect("inner ≥ 1");
        stats.wall_s = total / f64::from(inner);
        stats.timeline = timeline;
        let sample = Sample {
            rep,
            inner,
            timestamp,
            cpu: cpu0.zip(cpu1).map(|(a, b)| (b.0 - a.0, b.1 - a.1)),
            load: (load_before, crate::util::host::load_average().map(|l| l[0])),
            same,
        };
        self.record(c, &sample, &image, &stats)?;
        st.walls.push(stats.wall_s);
        st.timed_s += total;
        st.next_rep += 1;
        self.measured += 1;
        self.progress.inc();
        if self.child {
            println!("{}", sample_line(&label_of(plan, c)));
        }
        Ok(())
    }

    /// One measured sample: its row (compared with the serial image), its timeline, and for
    /// the serial baseline's first repetition its image.
    pub(in crate::studies::experiment) fn record(
        &mut self,
        c: &RunConfig,
        sample: &Sample,
        image: &Image,
        stats: &RunStats,
    ) -> Result<(), RunError> {
        let plan = self.plan;
        let rep = sample.rep;
        let hash = hex(image.hash());
        let mut row = RunRow::for_config(plan, c);
        row.repetition = rep;
        row.set_stats(stats);
        row.image_hash = hash.clone();
        row.inner = sample.inner;
        row.timestamp = sample.timestamp.clone();
        row.user_s = sample.cpu.map(|c| c.0);
        row.sys_s = sample.cpu.map(|c| c.1);
        row.load_before = sample.load.0;
        row.load_after = sample.load.1;
        row.probe_s = self.probe_s;
        row.process = Some(std::process::id());
        if let Some(p) = self.predictions.get(&c.id) {
            row.predicted_wall_s = Some(p.wall_s);
            row.predicted_handout_s = Some(p.handout_s);
            row.predicted_refill_s = Some(p.refill_s);
            row.predicted_imbalance_s = Some(p.imbalance_s);
        }
        let serial_image = serial_image_path(&self.dir, plan, c);
        let info = self.serial.entry(c.baseline).or_default();
        match &c.spec {
            None => {
                if info.hash.is_none() {
                    // The image goes first: a row on disk implies its image is too.
                    image
                        .save_with_preview(&serial_image)
                        .map_err(|e| io_err(&serial_image, e))?;
                    info.hash = Some(hash.clone());
                    if plan.gpu.is_some() {
                        info.image = Some(image.clone());
                    }
                }
                info.walls.push(stats.wall_s);
                row.serial_s = stats.wall_s;
            }
            Some(_) => row.serial_s = median(&info.walls),
        }
        row.identical = sample.same && info.hash.as_deref() == Some(hash.as_str());
        if c.sources.has_gpu() {
            if info.image.is_none() {
                // Resumed: the baseline's image is on disk since its first row.
                let img = Image::load_exr(&serial_image).map_err(|e| io_err(&serial_image, e))?;
                info.image = Some(img);
            }
            let check =
                super::super::image_check::compare(image, info.image.as_ref().expect("just set"));
            row.image_z = Some(check.z);
            row.agrees = Some(check.agrees);
        }
        let w = row.workers as f64;
        row.speedup = row.serial_s / row.wall_s;
        row.efficiency = row.speedup / w;
        row.overhead_s = w * row.wall_s - row.serial_s;
        if let Some(t) = &stats.timeline {
            write_atomic(
                &timeline_path(&self.dir, &c.id),
                timeline_text(t, stats).as_bytes(),
            )?;
        }
        if !row.identical && row.agrees != Some(true) {
            self.mismatches += 1;
            let serial = info.hash.as_deref().unwrap_or("?");
            let msg = match row.image_z {
                Some(z) => format!(
                    "IMAGE MISMATCH: {} rep {rep}: mean difference to serial {serial} is {z:+.1}σ (beyond 3σ)",
                    row.label
                ),
                None => format!(
                    "IMAGE MISMATCH: {} rep {rep}: hash {} ≠ serial {serial}",
                    row.label, row.image_hash
                ),
            };
            self.progress.println(&msg);
        }
        self.runs.append(&row).map_err(RunError::from)
    }
}

/// Where the serial image of `c`'s baseline is: `images/serial_<scene>_<baseline config>.exr`.
pub(super) fn serial_image_path(dir: &Path, plan: &ExperimentPlan, c: &RunConfig) -> PathBuf {
    let id = plan
        .configs
        .iter()
        .find(|b| b.spec.is_none() && b.baseline == c.baseline)
        .map_or(c.id.as_str(), |b| b.id.as_str());
    let name = &plan.scene_of(c).scene.name;
    // `with_extension`, as the images were always named: a scene name with a dot loses its tail.
    dir.join("images")
        .join(format!("serial_{}_{id}", slug(name)))
        .with_extension("exr")
}
