//! Why a diagnosis cannot run.

/// Why a diagnosis cannot run.
#[derive(Clone, Debug, PartialEq)]
pub enum DiagnoseError {
    /// Fewer IMU samples than a regression needs.
    TooShort {
        /// Samples in the recording.
        samples: usize,
    },
    /// Fewer encoder reads than the angle interpolation needs.
    TooFewEncoderReads {
        /// Reads in the recording.
        reads: usize,
    },
    /// An IMU sample with a NaN or infinite value.
    NonFiniteImu {
        /// Its index.
        index: usize,
        /// Its time, s.
        t_s: f64,
    },
    /// An encoder read with a NaN or infinite value.
    NonFiniteEncoder {
        /// Its index.
        index: usize,
    },
    /// Too few (or invalid) regression blocks.
    TooFewBlocks {
        /// Blocks the recording makes.
        blocks: usize,
        /// Block length asked for, s.
        block_s: f64,
    },
    /// The model file is not valid (what is wrong, with its key).
    Model(String),
    /// Runs compared sample by sample have different lengths.
    DifferentLengths,
}

impl std::fmt::Display for DiagnoseError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            DiagnoseError::TooShort { samples } => write!(
                f,
                "{samples} IMU samples: too short to diagnose (need at least 200)"
            ),
            DiagnoseError::TooFewEncoderReads { reads } => {
                write!(f, "{reads} encoder reads: need at least 5")
            }
            DiagnoseError::NonFiniteImu { index, t_s } => {
                write!(f, "imu sample {index} (t = {t_s} s) is not finite")
            }
            DiagnoseError::NonFiniteEncoder { index } => {
                write!(f, "encoder read {index} is not finite")
            }
            DiagnoseError::TooFewBlocks { blocks, block_s } => write!(
                f,
                "{blocks} blocks of {block_s} s: the regression needs at least 50 (a shorter block or a longer recording)"
            ),
            DiagnoseError::Model(m) => write!(f, "model: {m}"),
            DiagnoseError::DifferentLengths => f.write_str("the runs have different lengths"),
        }
    }
}

impl std::error::Error for DiagnoseError {}
