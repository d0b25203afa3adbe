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
//!
//! A direct `write` returns when the device has the bytes, so the thread that calls
//! it waits on the disk. A pool worker that waits computes nothing: on two cores a
//! 6-UPS run's workers spent 48 ms of its 0.6 s in such writes, and the pool idled
//! beside them (`perf trace`). A file written with a [`Landing`]
//! ([`Output::in_background`]) hands its full staging buffers to a thread of its own,
//! which writes them, the tail, and renames the file into place; the caller goes on
//! as soon as the bytes are copied, and [`Landing::wait`] waits for every such file
//! and reports the first failure.

use std::fs::File;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Condvar, Mutex, mpsc};

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

    fn data(&self, len: usize) -> &[u8] {
        &self.bytes[self.start..self.start + len]
    }
}

/// A megabyte of bytes is not worth printing ([`Landing`] keeps spare buffers).
impl std::fmt::Debug for Staging {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Staging").field("len", &self.len).finish_non_exhaustive()
    }
}

/// The staging buffers handed to background writes and not yet written, at most:
/// the memory a run's files in flight may hold beyond the one each open file fills
/// (a part file is some 10 to 40 MB).
const IN_FLIGHT: usize = 32;

/// The files of a run written in the background (those its `WriteOptions::landing`
/// names and that are not durable): how many are not yet in place, the buffers they
/// hold, and the first failure.
#[derive(Debug, Default)]
pub struct Landing {
    state: Mutex<Flights>,
    changed: Condvar,
}

#[derive(Debug, Default)]
struct Flights {
    /// Background files whose thread has not ended.
    files: usize,
    /// Staging buffers handed over and not yet written.
    buffers: usize,
    /// Written buffers, for the next files.
    free: Vec<Staging>,
    failure: Option<(PathBuf, io::Error)>,
}

impl Landing {
    pub fn new() -> Arc<Self> {
        Arc::new(Self::default())
    }

    /// Waits until every file written with this landing is in place (or failed), and
    /// returns the first failure: the file it was writing, and why.
    pub fn wait(&self) -> Result<(), (PathBuf, io::Error)> {
        let mut state = self.lock();
        while state.files > 0 {
            state = self.changed.wait(state).unwrap_or_else(|e| e.into_inner());
        }
        state.failure.take().map_or(Ok(()), Err)
    }

    /// The first failure so far, without waiting (reported once, here or by
    /// [`Landing::wait`]): for a run to stop at its next file rather than at its end.
    pub fn failure(&self) -> Result<(), (PathBuf, io::Error)> {
        self.lock().failure.take().map_or(Ok(()), Err)
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Flights> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Waits until fewer than [`IN_FLIGHT`] buffers are handed over, and counts one
    /// more. The threads that write them never wait on the landing, so the wait ends.
    fn reserve(&self) {
        let mut state = self.lock();
        while state.buffers >= IN_FLIGHT {
            state = self.changed.wait(state).unwrap_or_else(|e| e.into_inner());
        }
        state.buffers += 1;
    }

    /// A buffer to fill: one written before, or a new one.
    fn spare(&self) -> Staging {
        match self.lock().free.pop() {
            Some(mut s) => {
                s.len = 0;
                s
            }
            None => Staging::new(),
        }
    }

    /// A buffer handed over is written (or dropped after a failure).
    fn written(&self, staging: Staging) {
        let mut state = self.lock();
        state.buffers -= 1;
        state.free.push(staging);
        self.changed.notify_all();
    }

    /// A buffer a file no longer needs, for the next.
    fn keep(&self, staging: Staging) {
        self.lock().free.push(staging);
    }

    fn failed(&self, path: &Path, e: io::Error) {
        let mut state = self.lock();
        if state.failure.is_none() {
            state.failure = Some((path.to_path_buf(), e));
        }
    }
}

/// What a file's background thread is sent.
enum Block {
    /// The first `len` bytes of a staging buffer.
    Bytes(Staging, usize),
    /// The file is `len` bytes long: cut it there and rename it to `path`.
    Close { len: u64, path: PathBuf },
}

/// The thread writing one file in the background, and how to reach it.
struct Lane {
    tx: mpsc::Sender<Block>,
}

impl Lane {
    /// Starts the thread that writes `file` (direct, at `at`) for `landing`.
    fn start(mut file: File, at: PathBuf, landing: Arc<Landing>) -> io::Result<Self> {
        let (tx, rx) = mpsc::channel::<Block>();
        landing.lock().files += 1;
        let ours = Arc::clone(&landing);
        let spawned = std::thread::Builder::new().name("clearance-write".into()).spawn(move || {
            // Counts the file out however the thread ends; a panic is the file's failure.
            let _leaving = Leaving(Arc::clone(&ours), at.clone());
            let mut direct = true;
            let mut error: Option<io::Error> = None;
            for block in rx {
                match block {
                    Block::Bytes(staging, len) => {
                        if error.is_none() {
                            error = write_block(&mut file, &mut direct, staging.data(len)).err();
                        }
                        ours.written(staging);
                    }
                    Block::Close { len, path } => {
                        let closed = match error.take() {
                            Some(e) => Err(e),
                            None => put_in_place(&file, Some(len), direct, false, &at, &path),
                        };
                        if let Err(e) = closed {
                            let _ = std::fs::remove_file(&at);
                            ours.failed(&path, e);
                        }
                    }
                }
            }
        });
        match spawned {
            Ok(_) => Ok(Self { tx }),
            Err(e) => {
                landing.lock().files -= 1;
                Err(e)
            }
        }
    }

    /// Sends `block` to the file's thread; an error where the thread has ended (it
    /// ends only when this sender is dropped, or on a panic).
    fn send(&self, block: Block) -> io::Result<()> {
        self.tx.send(block).map_err(|_| io::Error::other("the thread writing the file has ended"))
    }
}

/// A background file's thread, counted out of its landing when it ends.
struct Leaving(Arc<Landing>, PathBuf);

impl Drop for Leaving {
    fn drop(&mut self) {
        let mut state = self.0.lock();
        if std::thread::panicking() && state.failure.is_none() {
            state.failure = Some((self.1.clone(), io::Error::other("the thread writing it panicked")));
        }
        state.files -= 1;
        self.0.changed.notify_all();
    }
}

/// Finishes `file`, written at `from`, and renames it to `to`: cut to `len` (a direct
/// file's tail was padded to a block), then, when `durable`, on the disk, else, if it
/// went through the page cache (not `direct`), the disk asked to start taking it.
fn put_in_place(file: &File, len: Option<u64>, direct: bool, durable: bool, from: &Path, to: &Path) -> io::Result<()> {
    if let Some(len) = len {
        file.set_len(len)?;
    }
    if durable {
        file.sync_all()?;
    } else if !direct {
        start_writeback(file);
    }
    std::fs::rename(from, to)
}

/// Writes `data` (a multiple of [`ALIGN`] while `direct`) to `file`. A file system
/// that accepted `O_DIRECT` at `open` but refuses this write (`EINVAL`: stricter
/// alignment) gets the same bytes buffered, and the rest of the file too (`direct`
/// turns false).
fn write_block(file: &mut File, direct: &mut bool, data: &[u8]) -> io::Result<()> {
    // By hand rather than `write_all`: on a refusal, only what was not yet written
    // goes again, buffered.
    let mut done = 0;
    while done < data.len() {
        match file.write(&data[done..]) {
            Ok(0) => return Err(io::ErrorKind::WriteZero.into()),
            Ok(n) => done += n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) if *direct && e.raw_os_error() == Some(libc::EINVAL) => {
                leave_direct(file)?;
                *direct = false;
                return file.write_all(&data[done..]);
            }
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

/// Turns `O_DIRECT` off for the rest of the file.
fn leave_direct(file: &File) -> io::Result<()> {
    #[cfg(target_os = "linux")]
    {
        use std::os::fd::AsRawFd;
        let fd = file.as_raw_fd();
        // SAFETY: `fd` is this open file's descriptor; F_GETFL/F_SETFL only read
        // and change its status flags.
        let flags = unsafe { libc::fcntl(fd, libc::F_GETFL) };
        if flags < 0 || unsafe { libc::fcntl(fd, libc::F_SETFL, flags & !libc::O_DIRECT) } < 0 {
            return Err(io::Error::last_os_error());
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = file;
    Ok(())
}

/// Asks the kernel to start writing the file's dirty pages now, without waiting.
fn start_writeback(file: &File) {
    #[cfg(target_os = "linux")]
    {
        use std::os::fd::AsRawFd;
        // SAFETY: a valid descriptor; the call only schedules I/O on it.
        unsafe {
            libc::sync_file_range(file.as_raw_fd(), 0, 0, libc::SYNC_FILE_RANGE_WRITE);
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = file;
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

/// A file opened for writing, direct where possible. [`Output::complete`] writes what
/// it still holds and renames it into place.
#[derive(Default)]
pub(crate) struct Output {
    /// `None` once a background thread writes it (or in a taken-out shell).
    file: Option<File>,
    /// Where it is written (the temporary name).
    path: PathBuf,
    /// `Some` while the file is written with `O_DIRECT` (and its tail not yet
    /// handed to its thread).
    staging: Option<Staging>,
    /// Whether the file was opened with `O_DIRECT` and still is.
    direct: bool,
    /// Bytes accepted so far (the file's length once finished).
    accepted: u64,
    /// Where a direct file's full buffers go to be written in the background.
    landing: Option<Arc<Landing>>,
    /// The thread writing this file, from its first full buffer.
    lane: Option<Lane>,
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
                Ok(file) => return Ok(Self::new(file, path, Some(Staging::new()))),
                Err(e) if e.raw_os_error() == Some(libc::EINVAL) => {}
                Err(e) => return Err(e),
            }
        }
        Ok(Self::new(File::create(path)?, path, None))
    }

    /// A file written through `staging` (direct), or straight (buffered).
    fn new(file: File, path: &Path, staging: Option<Staging>) -> Self {
        let direct = staging.is_some();
        Self { file: Some(file), path: path.to_path_buf(), staging, direct, accepted: 0, landing: None, lane: None }
    }

    /// Writes a direct file's full buffers on a thread of its own, reporting to
    /// `landing`, and lets [`Output::complete`] finish it there (when not durable).
    /// A buffered file is written as before: its `write` costs a copy, not a wait.
    pub fn in_background(mut self, landing: Option<&Arc<Landing>>) -> Self {
        if self.staging.is_some() {
            self.landing = landing.cloned();
        }
        self
    }

    /// Whether the bytes bypass the page cache.
    #[cfg(test)]
    pub fn is_direct(&self) -> bool {
        self.direct
    }

    /// The writer's file, moved out (a shell stays behind): for [`Output::complete`]
    /// after a `parquet` writer that owns it has written its footer.
    pub fn take(&mut self) -> Self {
        std::mem::take(self)
    }

    /// Writes `len` bytes of the staging buffer (a multiple of [`ALIGN`]): here, or,
    /// for a background file, by its thread (started with the first full buffer; a
    /// file that never fills one is written here), with a fresh buffer in its place
    /// when `more` is to come.
    fn write_staged(&mut self, len: usize, more: bool) -> io::Result<()> {
        if let Some(landing) = &self.landing
            && (more || self.lane.is_some())
        {
            if self.lane.is_none() {
                let file = self.file.take().expect("a file not yet handed over");
                self.lane = Some(Lane::start(file, self.path.clone(), Arc::clone(landing))?);
            }
            landing.reserve();
            let full = if more { self.staging.replace(landing.spare()) } else { self.staging.take() };
            return self.lane.as_ref().expect("started above").send(Block::Bytes(full.expect("a direct file"), len));
        }
        let (Some(staging), Some(file)) = (self.staging.as_ref(), self.file.as_mut()) else { return Ok(()) };
        write_block(file, &mut self.direct, staging.data(len))?;
        if !self.direct {
            self.release();
        }
        Ok(())
    }

    /// Lets the staging buffer go: to the landing's, or kept for this thread's next
    /// file.
    fn release(&mut self) {
        if let Some(staging) = self.staging.take() {
            match &self.landing {
                Some(landing) => landing.keep(staging),
                None => SPARE.set(Some(staging)),
            }
        }
    }

    /// Writes the tail a direct file still holds: padded to [`ALIGN`] for the disk
    /// (the file is cut back to the bytes accepted after).
    fn write_tail(&mut self) -> io::Result<()> {
        let Some(staging) = self.staging.as_mut() else { return Ok(()) };
        let len = staging.len;
        if len == 0 {
            return Ok(());
        }
        let padded = len.next_multiple_of(ALIGN);
        staging.buf()[len..padded].fill(0);
        staging.len = 0;
        self.write_staged(padded, false)
    }

    /// Finishes the file (at its temporary name, where it was created) and renames it
    /// to `path`: its tail written and its length cut to the bytes accepted, then, when
    /// `durable`, on the disk (else, if it went through the page cache, the disk asked
    /// to start taking it).
    /// A background file ([`Output::in_background`]) that is not durable does all this
    /// on its thread: the call returns at once, and its [`Landing`] has any failure
    /// (the temporary file then removed). On an error returned here, the caller
    /// removes the temporary file.
    pub fn complete(mut self, path: &Path, durable: bool) -> io::Result<()> {
        debug_assert!(!(durable && self.landing.is_some()), "a durable file is not written in the background");
        let staged = self.staging.is_some();
        self.write_tail()?;
        if let Some(lane) = self.lane.take() {
            return lane.send(Block::Close { len: self.accepted, path: path.to_path_buf() });
        }
        let file = self.file.as_ref().expect("a file written here");
        put_in_place(file, staged.then_some(self.accepted), self.direct, durable, &self.path, path)
    }
}

impl Drop for Output {
    fn drop(&mut self) {
        self.release();
    }
}

impl Write for Output {
    fn write(&mut self, data: &[u8]) -> io::Result<usize> {
        let Some(staging) = self.staging.as_mut() else {
            let file = self.file.as_mut().ok_or_else(|| io::Error::other("write after the file was finished"))?;
            let n = file.write(data)?;
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
            self.write_staged(STAGING, true)?;
        }
        Ok(n)
    }

    /// Whole staged blocks go out as soon as they fill; a partial one waits for
    /// [`Output::complete`], since a direct write cannot be shorter than a block.
    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The test directories: the temp dir, `target/` (a disk: direct), and /dev/shm
    /// (tmpfs: buffered) where it exists.
    fn dirs(test: &str) -> Vec<PathBuf> {
        let name = format!("clearance-output-{test}-{}", std::process::id());
        let target = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target");
        let shm = Path::new("/dev/shm");
        let mut dirs = vec![std::env::temp_dir().join(&name), target.join(&name)];
        if shm.is_dir() {
            dirs.push(shm.join(&name));
        }
        dirs
    }

    /// Bytes of awkward sizes, some larger than the staging buffer, end up in the
    /// file exactly, direct or not, written here or in the background (then in place
    /// once the landing is waited for), and the temporary name is gone.
    #[test]
    fn writes_exactly_the_bytes_given() {
        for dir in dirs("exact") {
            std::fs::create_dir_all(&dir).unwrap();
            for background in [false, true] {
                let (tmp, path) = (dir.join(".f.bin.tmp"), dir.join("f.bin"));
                let landing = Landing::new();
                let mut expected = Vec::new();
                let mut out = Output::create(&tmp, true).unwrap().in_background(background.then_some(&landing));
                #[cfg(target_os = "linux")]
                assert_eq!(out.is_direct(), local_disk(&tmp), "{}", dir.display());
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
                out.complete(&path, false).unwrap();
                landing.wait().unwrap();
                assert_eq!(std::fs::read(&path).unwrap(), expected, "{} {background}", dir.display());
                assert!(!tmp.exists());
                let state = landing.lock();
                assert_eq!((state.files, state.buffers), (0, 0), "every thread ended, every buffer back");
            }
            std::fs::remove_dir_all(&dir).unwrap();
        }
    }

    /// A background file that cannot be put in place (its name is taken by a
    /// directory) is reported by the landing, with its name and the cause, and its
    /// temporary file is removed; a small file, written here, fails here.
    #[test]
    fn a_failure_in_the_background_is_reported_by_the_landing() {
        for dir in dirs("failure") {
            let (tmp, path) = (dir.join(".f.bin.tmp"), dir.join("f.bin"));
            std::fs::create_dir_all(path.join("occupied")).unwrap();
            let landing = Landing::new();
            let mut out = Output::create(&tmp, true).unwrap().in_background(Some(&landing));
            let direct = out.is_direct();
            out.write_all(&vec![1u8; 2 * STAGING + 5]).unwrap();
            let now = out.complete(&path, false);
            // Seen without waiting once the file's thread has met it.
            let seen = loop {
                let files = landing.lock().files;
                match landing.failure() {
                    Err(e) => break Err(e),
                    Ok(()) if files == 0 => break Ok(()),
                    Ok(()) => std::thread::yield_now(),
                }
            };
            let later = seen.and_then(|()| landing.wait());
            if direct {
                assert!(now.is_ok(), "{}: the rename is left to the file's thread", dir.display());
                let (failed, cause) = later.expect_err("the rename fails");
                assert_eq!(failed, path);
                assert!(cause.raw_os_error().is_some(), "{cause}");
                assert!(!tmp.exists(), "the file's thread removed its temporary file");
            } else {
                assert!(now.is_err() && later.is_ok(), "{}: a buffered file is finished here", dir.display());
                // The caller removes the temporary file of a failure it sees.
                std::fs::remove_file(&tmp).unwrap();
            }
            assert!(landing.wait().is_ok(), "a failure is reported once");
            std::fs::remove_dir_all(&dir).unwrap();
        }
    }
}
