//! Errors of scene loading and validation.
//!
//! Every error says *what* is wrong and *where*: the file, and inside it a line (OBJ, MTL, TOML) or a
//! JSON path (glTF), or the named scene element (`light 'sun'`) for scenes built in code.

use std::fmt;
use std::path::{Path, PathBuf};

/// Where in the input an error was found.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Location {
    /// The file, when the scene came from one.
    pub file: Option<PathBuf>,
    /// 1-based line number (text formats).
    pub line: Option<usize>,
    /// A path inside the document: a JSON path (`meshes[2].primitives[0]`) or a scene element
    /// (`light[1] 'sun'.radius`).
    pub path: Option<String>,
}

impl Location {
    pub fn file(file: impl AsRef<Path>) -> Self {
        Self { file: Some(file.as_ref().to_path_buf()), ..Self::default() }
    }

    pub fn line(file: impl AsRef<Path>, line: usize) -> Self {
        Self { file: Some(file.as_ref().to_path_buf()), line: Some(line), path: None }
    }

    pub fn path(path: impl Into<String>) -> Self {
        Self { path: Some(path.into()), ..Self::default() }
    }

    /// The same location with `file` filled in when it was unknown.
    pub fn in_file(mut self, file: impl AsRef<Path>) -> Self {
        if self.file.is_none() {
            self.file = Some(file.as_ref().to_path_buf());
        }
        self
    }
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut wrote = false;
        if let Some(file) = &self.file {
            write!(f, "{}", file.display())?;
            wrote = true;
        }
        if let Some(line) = self.line {
            write!(f, "{}line {line}", if wrote { ":" } else { "" })?;
            wrote = true;
        }
        if let Some(path) = &self.path {
            write!(f, "{}{path}", if wrote { ": " } else { "" })?;
            wrote = true;
        }
        if !wrote {
            write!(f, "<scene>")?;
        }
        Ok(())
    }
}

/// An error while loading, building or validating a scene.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("{location}: cannot read file: {source}")]
    Io {
        location: Location,
        #[source]
        source: std::io::Error,
    },
    /// The file is not well-formed in its format.
    #[error("{location}: {message}")]
    Parse { location: Location, message: String },
    /// The file is well-formed but a value in it is unusable (NaN, an index out of range, an empty
    /// mesh, an absurd light parameter, ...).
    #[error("{location}: {message}")]
    Invalid { location: Location, message: String },
    /// The file type is not one shadowlab reads.
    #[error("{location}: unsupported scene format (expected .toml, .gltf, .glb or .obj)")]
    UnsupportedFormat { location: Location },
    /// `--scene` named neither a built-in scene nor an existing file.
    #[error("unknown scene '{name}': not a built-in scene ({known}) and no such file")]
    UnknownScene { name: String, known: String },
    /// A built-in scene's option was malformed.
    #[error("scene '{scene}': {source}")]
    Option {
        scene: String,
        #[source]
        source: crate::params::ParamError,
    },
}

impl SceneError {
    pub fn parse(location: Location, message: impl Into<String>) -> Self {
        Self::Parse { location, message: message.into() }
    }

    pub fn invalid(location: Location, message: impl Into<String>) -> Self {
        Self::Invalid { location, message: message.into() }
    }

    pub fn io(file: impl AsRef<Path>, source: std::io::Error) -> Self {
        Self::Io { location: Location::file(file), source }
    }

    /// The location of the error, when it has one.
    pub fn location(&self) -> Option<&Location> {
        match self {
            Self::Io { location, .. }
            | Self::Parse { location, .. }
            | Self::Invalid { location, .. }
            | Self::UnsupportedFormat { location } => Some(location),
            Self::UnknownScene { .. } | Self::Option { .. } => None,
        }
    }

    /// Fills in the file of the location when the error did not know it.
    pub fn in_file(self, file: impl AsRef<Path>) -> Self {
        match self {
            Self::Io { location, source } => Self::Io { location: location.in_file(file), source },
            Self::Parse { location, message } => Self::Parse { location: location.in_file(file), message },
            Self::Invalid { location, message } => Self::Invalid { location: location.in_file(file), message },
            Self::UnsupportedFormat { location } => Self::UnsupportedFormat { location: location.in_file(file) },
            other => other,
        }
    }
}

pub type Result<T, E = SceneError> = std::result::Result<T, E>;
