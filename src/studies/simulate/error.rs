//! Why a simulation experiment stopped, once it was planned ([`super::config`] refuses plans).

/// Why measuring the inputs, simulating or writing the results failed.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// A failure described in one message: a probe, a child simulation, the measured runs
    /// of a validation.
    #[error("{0}")]
    Failed(String),
    /// Creating a folder.
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// Writing a CSV record.
    #[error(transparent)]
    Csv(#[from] csv::Error),
    /// Writing a result file.
    #[error(transparent)]
    Write(#[from] crate::util::fs::WriteError),
    /// A probe's scheduler setting was refused.
    #[error(transparent)]
    Spec(#[from] crate::sched::SpecError),
    /// A probe's scheduler run failed.
    #[error(transparent)]
    Sched(#[from] crate::sched::SchedError),
    /// The probe's tracer did not build.
    #[error(transparent)]
    Tracer(#[from] crate::core::tracer::TracerError),
    /// The validation's measured `runs.csv` did not read.
    #[error(transparent)]
    Results(#[from] crate::studies::experiment::results::ResultsError),
}
