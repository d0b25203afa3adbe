//! A column chunk's bytes as a list of buffers, read as one.

use bytes::Bytes;
use parquet::errors::ParquetError;
use parquet::file::reader::{ChunkReader, Length};

/// The bytes of a column chunk as a list of buffers, in file order, for
/// [`append_column`](parquet::file::writer::SerializedRowGroupWriter::append_column):
/// the pages of a chunk encoded block by block need not be copied together first.
pub(crate) struct Segments<'a>(pub(super) Vec<&'a [u8]>);

impl Segments<'_> {
    fn total(&self) -> u64 {
        self.0.iter().map(|b| b.len() as u64).sum()
    }
}

impl Length for Segments<'_> {
    fn len(&self) -> u64 {
        self.total()
    }
}

impl<'a> ChunkReader for Segments<'a> {
    type T = SegmentsRead<'a>;

    fn get_read(&self, start: u64) -> Result<SegmentsRead<'a>, ParquetError> {
        let mut read = SegmentsRead { segments: self.0.clone().into(), skip: start };
        read.seek();
        Ok(read)
    }

    fn get_bytes(&self, start: u64, length: usize) -> Result<Bytes, ParquetError> {
        let mut out = Vec::with_capacity(length);
        std::io::Read::read_to_end(&mut std::io::Read::take(self.get_read(start)?, length as u64), &mut out)?;
        if out.len() != length {
            return Err(ParquetError::EOF(format!("{length} bytes from {start} past the end of the chunk")));
        }
        Ok(out.into())
    }
}

/// A reader over [`Segments`].
pub(crate) struct SegmentsRead<'a> {
    segments: std::collections::VecDeque<&'a [u8]>,
    /// Bytes still to skip before the first one read.
    skip: u64,
}

impl SegmentsRead<'_> {
    fn seek(&mut self) {
        while let Some(front) = self.segments.front_mut() {
            if (front.len() as u64) > self.skip {
                *front = &front[self.skip as usize..];
                self.skip = 0;
                return;
            }
            self.skip -= front.len() as u64;
            self.segments.pop_front();
        }
    }
}

impl std::io::Read for SegmentsRead<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        while let Some(front) = self.segments.front_mut() {
            if front.is_empty() {
                self.segments.pop_front();
                continue;
            }
            let n = front.len().min(buf.len());
            buf[..n].copy_from_slice(&front[..n]);
            *front = &front[n..];
            return Ok(n);
        }
        Ok(0)
    }
}
