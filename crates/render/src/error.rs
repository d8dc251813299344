//! Errors a user can cause by the scene they give us, located in the source file.

use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A position in a scene source file (1-based line and column).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SourceLoc {
    /// The file (XML, or a mesh file referenced by it).
    pub file: Arc<PathBuf>,
    /// 1-based line; 0 when unknown (e.g. binary mesh files).
    pub line: u32,
    /// 1-based column; 0 when unknown.
    pub col: u32,
}

impl SourceLoc {
    /// A location in `file` with unknown line.
    pub fn file_only(file: &Path) -> Self {
        SourceLoc {
            file: Arc::new(file.to_path_buf()),
            line: 0,
            col: 0,
        }
    }
}

impl fmt::Display for SourceLoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.line > 0 {
            write!(f, "{}:{}:{}", self.file.display(), self.line, self.col)
        } else {
            write!(f, "{}", self.file.display())
        }
    }
}

/// A scene that cannot be loaded or built: bad XML, missing file, unknown plugin, bad parameter, bad mesh.
#[derive(Debug, Clone)]
pub struct SceneError {
    /// Where in the input the problem is, when known.
    pub loc: Option<SourceLoc>,
    /// What is wrong, in words a user can act on.
    pub message: String,
}

impl SceneError {
    /// An error at a known location.
    pub fn at(loc: &SourceLoc, message: impl Into<String>) -> Self {
        SceneError {
            loc: Some(loc.clone()),
            message: message.into(),
        }
    }

    /// An error with no better location than the file.
    pub fn in_file(file: &Path, message: impl Into<String>) -> Self {
        SceneError {
            loc: Some(SourceLoc::file_only(file)),
            message: message.into(),
        }
    }
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.loc {
            Some(loc) => write!(f, "{loc}: {}", self.message),
            None => write!(f, "{}", self.message),
        }
    }
}

impl std::error::Error for SceneError {}

/// Result type for scene loading.
pub type SceneResult<T> = Result<T, SceneError>;
