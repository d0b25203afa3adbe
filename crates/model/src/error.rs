//! Errors in a job file. Each names the file, the key (a dotted path) and the reason.

use std::fmt;

/// A job file that cannot be run. Nothing may be written when one is returned.
#[derive(Debug, Clone, PartialEq)]
pub struct JobError {
    /// The job file's path as given by the user.
    pub file: String,
    /// Dotted path of the offending key (`grid.psi.n`), or empty for the whole file.
    pub key: String,
    /// What is wrong, and, where possible, what to write instead.
    pub reason: String,
}

impl JobError {
    pub fn new(file: &str, key: impl Into<String>, reason: impl Into<String>) -> Self {
        Self { file: file.to_string(), key: key.into(), reason: reason.into() }
    }
}

impl fmt::Display for JobError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.key.is_empty() {
            write!(f, "{}: {}", self.file, self.reason)
        } else {
            write!(f, "{}: `{}`: {}", self.file, self.key, self.reason)
        }
    }
}

impl std::error::Error for JobError {}
