//! An error with the exit code it maps to.

/// Bad input (scene, config, flag) exits with 2, anything else with 1.
#[derive(Debug)]
pub(crate) struct CliError {
    pub(crate) code: u8,
    pub(crate) error: anyhow::Error,
}

impl CliError {
    /// Bad input: exit code 2.
    pub(crate) fn input(error: impl Into<anyhow::Error>) -> Self {
        Self {
            code: 2,
            error: error.into(),
        }
    }

    /// A failure while running: exit code 1.
    pub(crate) fn runtime(error: impl Into<anyhow::Error>) -> Self {
        Self {
            code: 1,
            error: error.into(),
        }
    }

    /// Bad input described by a message.
    pub(crate) fn message(msg: impl std::fmt::Display) -> Self {
        Self::input(anyhow::anyhow!("{msg}"))
    }
}
