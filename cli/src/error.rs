//! The error type of the command-line tool: the library's, and what only the harness meets.

/// Everything a command can fail on.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Bad input or a file the library could not read or write.
    #[error(transparent)]
    Kdbeam(#[from] kdbeam::Error),
    /// Embree reported an error (only with the `embree` feature).
    #[cfg(feature = "embree")]
    #[error("embree: {0}")]
    Embree(String),
}

impl Error {
    /// [`kdbeam::Error::InvalidParameter`]: `name` is outside its range, as `message` says.
    pub fn invalid(name: &'static str, message: impl Into<String>) -> Error {
        Error::Kdbeam(kdbeam::Error::InvalidParameter {
            name,
            message: message.into(),
        })
    }
}

/// `Result<T, kdbeam_cli::Error>`.
pub type Result<T> = std::result::Result<T, Error>;

impl From<kdbeam::kernels::lanes::IsaError> for Error {
    fn from(e: kdbeam::kernels::lanes::IsaError) -> Error {
        Error::Kdbeam(e.into())
    }
}
