//! What loading a scene read but did not use as written: a property that changes no image, an integrator
//! read as the path tracer or replaced. `caustica info` lists the notes; `render` prints them.

use std::fmt;
use std::path::PathBuf;

/// What a note is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NoteKind {
    /// A property that changes no image in caustica, left out.
    Ignored,
    /// Something read differently from what it names (an integrator read as, or replaced by, the path
    /// tracer): the image is the one caustica's reading gives.
    Reading,
}

/// One note, at the place in the scene files it is about.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneNote {
    pub kind: NoteKind,
    pub file: PathBuf,
    pub line: usize,
    pub message: String,
}

impl fmt::Display for SceneNote {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}: {}", self.file.display(), self.line, self.message)
    }
}
