//! The file a Parquet writer fills: written past the page cache where the file
//! system allows it.
//!
//! A buffered `write` copies every byte into the page cache before the disk sees
//! it; on this machine that copy was 13 % of a one-thread end-to-end run
//! (`perf`, benches/README.md). With `O_DIRECT` the disk takes the bytes straight
//! from an aligned staging buffer, so the copy costs a user-space `memcpy` into
//! that buffer instead. Only local disk file systems get it ([`local_disk`]); one
//! that refuses the flag at `open` or at a `write` gets the file buffered instead,
//! so the choice never shows in the bytes written. `WriteOptions::direct_io`
//! off (the binary's `CLEARANCE_BUFFERED_IO`) makes every file buffered, for a file
//! system that accepts direct I/O and then misbehaves with it.

use std::fs::File;
use std::io::{self, Write};
use std::path::Path;

/// Alignment of direct I/O buffers, offsets and lengths: a page, which covers the
/// 512-byte and 4 KiB logical blocks of the disks we meet.
const ALIGN: usize = 4096;

/// Bytes handed to the disk per direct `write`.
const STAGING: usize = 1 << 20;

/// A staging buffer whose start is aligned to [`ALIGN`] (a plain `Vec`, over-allocated
/// and sliced at the first aligned byte).
struct Staging {
    bytes: Vec<u8>,
    start: usize,
    len: usize,
}

thread_local! {
    /// The staging buffer of the last direct file this thread closed, for its next:
    /// a fresh one is a megabyte to zero, for each part and for each small file
    /// beside it.
    static SPARE: std::cell::Cell<Option<Staging>> = const { std::cell::Cell::new(None) };
}

impl Staging {
    /// A buffer holding no bytes yet (its memory may hold an earlier file's).
    fn new() -> Self {
        if let Some(mut spare) = SPARE.take() {
            spare.len = 0;
            return spare;
        }
        let bytes = vec![0u8; STAGING + ALIGN];
        let start = bytes.as_ptr().align_offset(ALIGN);
        Self { bytes, start, len: 0 }
    }

    fn buf(&mut self) -> &mut [u8] {
        &mut self.bytes[self.start..self.start + STAGING]
    }
}

/// Whether the directory of `path` is on a local disk file system (ext2/3/4, XFS,
/// Btrfs), where direct writes go straight to the device. On network and cluster
/// file systems a direct write can wait for a round trip each time, and the page
/// cache is what lets writing overlap; tmpfs has no disk to bypass to.
#[cfg(target_os = "linux")]
fn local_disk(path: &Path) -> bool {
    use std::os::unix::ffi::OsStrExt;
    const LOCAL: [u64; 3] = [0xEF53, 0x5846_5342, 0x9123_683E];
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let Ok(c) = std::ffi::CString::new(dir.as_os_str().as_bytes()) else { return false };
    let mut fs = std::mem::MaybeUninit::<libc::statfs>::uninit();
    // SAFETY: `c` is a NUL-terminated path and `fs` a buffer of the size statfs fills.
    if unsafe { libc::statfs(c.as_ptr(), fs.as_mut_ptr()) } != 0 {
        return false;
    }
    // SAFETY: statfs returned 0, so it filled the buffer.
    let kind = unsafe { fs.assume_init() }.f_type as u64 & 0xFFFF_FFFF;
    LOCAL.contains(&kind)
}

/// A file opened for writing, direct where possible. Call [`Output::finish`] once
/// everything is written: a direct file's tail is still in memory until then.
pub(crate) struct Output {
    file: File,
    /// `Some` while the file is written with `O_DIRECT`.
    staging: Option<Staging>,
    /// Bytes accepted so far (the file's length once finished).
    accepted: u64,
}

impl Output {
    /// Creates (or truncates) `path`; past the page cache when `direct` and the
    /// file system is a local disk.
    pub fn create(path: &Path, direct: bool) -> io::Result<Self> {
        #[cfg(target_os = "linux")]
        if direct && local_disk(path) {
            use std::os::unix::fs::OpenOptionsExt;
            let direct = std::fs::OpenOptions::new()
                .write(true)
                .create(true)
                .truncate(true)
                .custom_flags(libc::O_DIRECT)
                .open(path);
            match direct {
                Ok(file) => return Ok(Self { file, staging: Some(Staging::new()), accepted: 0 }),
                Err(e) if e.raw_os_error() == Some(libc::EINVAL) => {}
                Err(e) => return Err(e),
            }
        }
        Ok(Self { file: File::create(path)?, staging: None, accepted: 0 })
    }

    /// Whether the bytes bypass the page cache.
    pub fn is_direct(&self) -> bool {
        self.staging.is_some()
    }

    pub fn file(&self) -> &File {
        &self.file
    }

    /// Writes `len` bytes of the staging buffer (a multiple of [`ALIGN`]). A file
    /// system that accepted `O_DIRECT` at `open` but refuses this write (`EINVAL`:
    /// stricter alignment) gets the same bytes buffered, and the rest of the file too.
    fn write_staged(&mut self, len: usize) -> io::Result<()> {
        let Some(staging) = self.staging.as_mut() else { return Ok(()) };
        let data = &staging.buf()[..len];
        // By hand rather than `write_all`: on a refusal, only what was not yet
        // written goes again, buffered.
        let mut done = 0;
        while done < len {
            match self.file.write(&data[done..]) {
                Ok(0) => return Err(io::ErrorKind::WriteZero.into()),
                Ok(n) => done += n,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) if e.raw_os_error() == Some(libc::EINVAL) => {
                    let rest = data[done..].to_vec();
                    self.leave_direct()?;
                    return self.file.write_all(&rest);
                }
                Err(e) => return Err(e),
            }
        }
        Ok(())
    }

    /// Turns `O_DIRECT` off for the rest of the file.
    fn leave_direct(&mut self) -> io::Result<()> {
        self.staging = None;
        #[cfg(target_os = "linux")]
        {
            use std::os::fd::AsRawFd;
            let fd = self.file.as_raw_fd();
            // SAFETY: `fd` is this open file's descriptor; F_GETFL/F_SETFL only read
            // and change its status flags.
            let flags = unsafe { libc::fcntl(fd, libc::F_GETFL) };
            if flags < 0 || unsafe { libc::fcntl(fd, libc::F_SETFL, flags & !libc::O_DIRECT) } < 0 {
                return Err(io::Error::last_os_error());
            }
        }
        Ok(())
    }

    /// Writes the tail a direct file still holds: padded to [`ALIGN`] for the disk,
    /// then cut back to the bytes accepted.
    pub fn finish(&mut self) -> io::Result<()> {
        let Some(staging) = self.staging.as_mut() else { return Ok(()) };
        let len = staging.len;
        if len == 0 {
            return Ok(());
        }
        let padded = len.next_multiple_of(ALIGN);
        staging.buf()[len..padded].fill(0);
        staging.len = 0;
        self.write_staged(padded)?;
        self.file.set_len(self.accepted)
    }
}

impl Drop for Output {
    fn drop(&mut self) {
        if let Some(staging) = self.staging.take() {
            SPARE.set(Some(staging));
        }
    }
}

impl Write for Output {
    fn write(&mut self, data: &[u8]) -> io::Result<usize> {
        let Some(staging) = self.staging.as_mut() else {
            let n = self.file.write(data)?;
            self.accepted += n as u64;
            return Ok(n);
        };
        let n = data.len().min(STAGING - staging.len);
        let at = staging.len;
        staging.buf()[at..at + n].copy_from_slice(&data[..n]);
        staging.len += n;
        self.accepted += n as u64;
        if staging.len == STAGING {
            staging.len = 0;
            self.write_staged(STAGING)?;
        }
        Ok(n)
    }

    /// Whole staged blocks go out as soon as they fill; a partial one waits for
    /// [`Output::finish`], since a direct write cannot be shorter than a block.
    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bytes of awkward sizes, some larger than the staging buffer, end up in the
    /// file exactly, direct or not: under `target/` (a disk: direct), in the temp dir
    /// and in /dev/shm (tmpfs: buffered) where they exist.
    #[test]
    fn writes_exactly_the_bytes_given() {
        let name = format!("clearance-output-{}", std::process::id());
        let target = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target");
        let shm = Path::new("/dev/shm");
        let mut dirs = vec![std::env::temp_dir().join(&name), target.join(&name)];
        if shm.is_dir() {
            dirs.push(shm.join(&name));
        }
        for dir in dirs {
            std::fs::create_dir_all(&dir).unwrap();
            let path = dir.join("f.bin");
            let mut expected = Vec::new();
            let mut out = Output::create(&path, true).unwrap();
            #[cfg(target_os = "linux")]
            assert_eq!(out.is_direct(), local_disk(&path), "{}", dir.display());
            let mut state = 7u64;
            for size in [1usize, 4095, 4097, STAGING - 3, 10, 3 * STAGING + 17, 0, 12345] {
                let chunk: Vec<u8> = (0..size)
                    .map(|_| {
                        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                        (state >> 56) as u8
                    })
                    .collect();
                out.write_all(&chunk).unwrap();
                expected.extend_from_slice(&chunk);
            }
            out.finish().unwrap();
            drop(out);
            assert_eq!(std::fs::read(&path).unwrap(), expected, "{}", dir.display());
            std::fs::remove_dir_all(&dir).unwrap();
        }
    }
}
