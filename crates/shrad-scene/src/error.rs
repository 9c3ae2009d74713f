use std::path::PathBuf;

/// Everything that can go wrong while reading or building a scene. Every variant names the
/// file (or built-in) it came from and what is wrong, so a user can fix the input.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read at all.
    #[error("{path}: cannot read file")]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The file was read but its content is wrong.
    #[error("{path}: {message}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong, with line or element where known.
        message: String,
    },
    /// The file's extension is not one shrad reads.
    #[error("{path}: unknown scene format (expected .gltf, .glb, .obj or .toml, or a built-in name: {builtins})")]
    UnknownFormat {
        /// The file.
        path: PathBuf,
        /// The built-in names, for the message.
        builtins: String,
    },
    /// A file the scene names (a glTF buffer's URI) could not be read.
    #[error("{path}: {message}")]
    Unreadable {
        /// The scene file.
        path: PathBuf,
        /// Which reference, the file it names and the OS's reason.
        message: String,
        /// The OS's kind of error (not found, permission denied, ...).
        kind: std::io::ErrorKind,
    },
    /// An output file could not be written (nothing was left behind).
    #[error(transparent)]
    Write(#[from] crate::WriteError),
}

impl SceneError {
    /// Shorthand for [`SceneError::Invalid`].
    pub fn invalid(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        SceneError::Invalid {
            path: path.into(),
            message: message.into(),
        }
    }
}
