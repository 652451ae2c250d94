//! The catalogue of published loop-scheduling techniques raysched is compared against: every
//! technique of LB4OMP (Korndörfer, Eleliemy, Mohammed & Ciorba, IEEE TPDS 33(4), 2022) and
//! every selection method of Auto4OMP (Mohammed & Ciorba 2022), with its paper. Which kinds
//! play each, and whether as published or as a variant, comes from the registry
//! ([`super::SchedulerKind::published`]); the reference page's table is generated from both.

/// One published technique.
#[derive(Clone, Copy, Debug)]
pub struct Technique {
    /// Its name in LB4OMP / Auto4OMP.
    pub name: &'static str,
    /// Which peer ships it.
    pub peer: &'static str,
    /// The paper that defines it.
    pub paper: &'static str,
    /// Why no kind plays it (read only where none does).
    pub absent: &'static str,
}

const fn t(name: &'static str, peer: &'static str, paper: &'static str) -> Technique {
    Technique {
        name,
        peer,
        paper,
        absent: "",
    }
}

const fn missing(
    name: &'static str,
    peer: &'static str,
    paper: &'static str,
    absent: &'static str,
) -> Technique {
    Technique {
        name,
        peer,
        paper,
        absent,
    }
}

/// Every technique, in LB4OMP's order, then Auto4OMP's selection methods.
pub const TECHNIQUES: [Technique; 30] = [
    t("STATIC", "LB4OMP", "OpenMP `schedule(static)`"),
    t("SS", "LB4OMP", "Tang & Yew, ICPP 1986"),
    t("GSS", "LB4OMP", "Polychronopoulos & Kuck, IEEE TC 36(12), 1987"),
    t("TSS", "LB4OMP", "Tzen & Ni, IEEE TPDS 4(1), 1993"),
    t("FSC", "LB4OMP", "Kruskal & Weiss, IEEE TSE 11(10), 1985"),
    t("FAC", "LB4OMP", "Flynn Hummel, Schonberg & Flynn, CACM 35(8), 1992"),
    missing(
        "mFAC",
        "LB4OMP",
        "Korndörfer et al., IEEE TPDS 2022",
        "FAC's chunks with LB4OMP's cheaper synchronisation: the same sequence as `fac`",
    ),
    t("FAC2", "LB4OMP", "Flynn Hummel, Schonberg & Flynn, CACM 35(8), 1992"),
    t("TAP", "LB4OMP", "Lucco, PLDI 1992"),
    t("WF2", "LB4OMP", "Flynn Hummel, Schmidt, Uma & Wein, SPAA 1996"),
    missing(
        "BOLD",
        "LB4OMP",
        "Hagerup, J. Parallel Distrib. Comput. 47, 1997",
        "not built: LB4OMP's BOLD (`kmp_dispatch.cpp` 2369–2443, 5003–5093 at bd45b1e) sizes each chunk from its estimate of the items not yet executed, lowered at every request by the wall time since the previous request of any worker × the workers' summed speed; a raysched rule reads no clock and a report carries only its own worker's chunk and hand-out times, not the time line of all workers that this estimate needs",
    ),
    missing(
        "AWF",
        "LB4OMP",
        "Banicescu, Velusamy & Devaprasad, Cluster Computing 6, 2003",
        "weights updated between time steps: a render is one loop instance",
    ),
    t("AWF-B", "LB4OMP", "Cariño & Banicescu, J. Supercomputing 44(1), 2008"),
    t("AWF-C", "LB4OMP", "Cariño & Banicescu, J. Supercomputing 44(1), 2008"),
    t("AWF-D", "LB4OMP", "Cariño & Banicescu, J. Supercomputing 44(1), 2008"),
    t("AWF-E", "LB4OMP", "Cariño & Banicescu, J. Supercomputing 44(1), 2008"),
    t("AF", "LB4OMP", "Banicescu & Liu, HPC Symposium 2000"),
    t("mAF", "LB4OMP", "Korndörfer et al., IEEE TPDS 33(4), 2022"),
    t("mFSC", "LB4OMP", "Banicescu, Velusamy & Devaprasad, Cluster Computing 6, 2003"),
    t("TFSS", "LB4OMP", "Chronopoulos, Andonie, Benche & Grosu, IEEE Cluster 2001"),
    t("FISS", "LB4OMP", "Philip & Das, PDCS 1997"),
    t("VISS", "LB4OMP", "Philip & Das, PDCS 1997"),
    t("RND", "LB4OMP", "Ciorba, Iwainsky & Buder, IWOMP 2018"),
    t("PLS", "LB4OMP", "Shih, Yang & Tseng, J. Supercomputing 41(3), 2007"),
    t("static_steal", "LB4OMP", "LLVM OpenMP `kmp_sch_static_steal`"),
    t("RandomSel", "Auto4OMP", "Mohammed & Ciorba, Auto4OMP, 2022"),
    t("ExhaustiveSel", "Auto4OMP", "Mohammed & Ciorba, Auto4OMP, 2022"),
    t("BinarySel", "Auto4OMP", "Mohammed & Ciorba, Auto4OMP, 2022"),
    missing(
        "ExpertSel",
        "Auto4OMP",
        "Mohammed & Ciorba, Auto4OMP, 2022",
        "not built: its fuzzy rules are tuned to loop times in seconds and LB4OMP's 12-technique portfolio",
    ),
    missing(
        "RL selectors",
        "Auto4OMP",
        "Mohammed & Ciorba, Auto4OMP, 2022 (LB4OMP `runtime/src/reinforcement-learning`)",
        "not built: Q-learning, SARSA and kin need many loop instances to learn over",
    ),
];
