//! Errors in a job file. Each names the file, the key (a dotted path) and the reason.

use std::fmt::{self, Write};

/// A job file that cannot be run. Nothing may be written when one is returned.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}", Message(self))]
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

/// `file: `key`: reason`, or `file: reason` for the whole file.
struct Message<'a>(&'a JobError);

impl fmt::Display for Message<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let e = self.0;
        let (file, key, reason) = (Escaped(&e.file), Escaped(&e.key), Escaped(&e.reason));
        if e.key.is_empty() { write!(f, "{file}: {reason}") } else { write!(f, "{file}: `{key}`: {reason}") }
    }
}

/// Text from the job file (a quoted key, a sweep path, a string value) may hold
/// newlines; written as escapes, they cannot stretch a message past its line.
struct Escaped<'a>(&'a str);

impl fmt::Display for Escaped<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for c in self.0.chars() {
            if c.is_control() { write!(f, "{}", c.escape_default())? } else { f.write_char(c)? }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn newlines_from_the_file_stay_escaped() {
        let e = JobError::new("j.toml", "mass.a\n\nb", "unknown variant `x\ty`");
        assert_eq!(e.to_string(), "j.toml: `mass.a\\n\\nb`: unknown variant `x\\ty`");
    }
}
