//! A part file whose pages are encoded as their rows are computed (`PoseSchema::part`,
//! `PageWriter::write`, `write_part`), read back through the `parquet` crate's own
//! reader, holds exactly the rows `PoseSchema::batch` makes of the same poses:
//! values, nulls, one row group, one page per `PAGE_ROWS` rows of each double
//! column, and statistics that describe the rows, for every column set and codec.
//! Pages are filled on the rayon pool with their rows put in reverse.

use arrow::array::{Array, Float64Array, StringArray};
use arrow::record_batch::RecordBatch;
use clearance_grid::Sample;
use clearance_model::Mode;
use clearance_parquet::{
    Codec, ColumnSet, PAGE_ROWS, PageWriter, PoseSchema, Precision, TAIL_PAGE_ROWS, WriteOptions, page_spans,
    write_part,
};
use clearance_solver::{PoseResult, Status};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::file::reader::{FileReader, SerializedFileReader};
use parquet::file::statistics::Statistics;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// Rows of every status, with values of every sign and size, infinite condition
/// numbers and kinds without an error, so that each column has pages with no
/// nulls, some, and (for `t` on a grid page) only nulls.
fn rows(n: usize) -> Vec<(Sample, PoseResult)> {
    let mut rng = ChaCha8Rng::seed_from_u64(4096);
    let v = |rng: &mut ChaCha8Rng| (rng.random::<f64>() - 0.5) * 10f64.powi(rng.random_range(-9..3));
    (0..n)
        .map(|i| {
            let s = Sample {
                index: 1000 + i as u64,
                // The first page is a grid (no time), the others a trajectory.
                t: (i >= PAGE_ROWS).then_some(i as f64 * 1e-3),
                z: [2.0 + v(&mut rng), 0.0, 0.0],
                psi: [v(&mut rng), 0.0, 0.0],
                theta: [v(&mut rng), 0.0, 0.0],
            };
            let mut r = PoseResult { x: v(&mut rng), y: v(&mut rng), phi: v(&mut rng), ..PoseResult::default() };
            // Runs of every status in the first page, as a workspace's edge gives
            // them; later pages all ok, so that their only nulls are infinities.
            r.status =
                if i < PAGE_ROWS && (i / 300) % 7 == 3 { Status::ALL[rng.random_range(0..4)] } else { Status::Ok };
            r.q = [v(&mut rng), v(&mut rng), v(&mut rng)];
            r.cond_a = if rng.random_bool(0.01) { f64::INFINITY } else { v(&mut rng).abs() };
            r.cond_jp = v(&mut rng).abs();
            r.kind_ok = [rng.random_bool(0.95), true, rng.random_bool(0.99), true];
            for e in r.errors.iter_mut().chain([&mut r.total]) {
                e.dp.x = v(&mut rng);
                e.dp.z = -0.0;
                e.dalpha.y = v(&mut rng);
                e.euler = [v(&mut rng), 0.0, v(&mut rng)];
            }
            r.margins.r_axial[1] = v(&mut rng);
            r.margins.s[2] = v(&mut rng);
            r.reactions.m_r[2].z = v(&mut rng);
            r.reactions.f_s[0].x = v(&mut rng);
            (s, r)
        })
        .collect()
}

fn read(path: &std::path::Path) -> RecordBatch {
    let file = std::fs::File::open(path).unwrap();
    let reader = ParquetRecordBatchReaderBuilder::try_new(file).unwrap().build().unwrap();
    let batches: Vec<RecordBatch> = reader.collect::<Result<_, _>>().unwrap();
    arrow::compute::concat_batches(&batches[0].schema(), &batches).unwrap()
}

/// Total-order extremes of the valid values, `None` when there are none.
fn expected_range(a: &Float64Array) -> Option<(u64, u64)> {
    let mut v: Vec<f64> = a.iter().flatten().collect();
    v.sort_by(f64::total_cmp);
    Some((v.first()?.to_bits(), v.last()?.to_bits()))
}

#[test]
fn parts_encoded_page_by_page_read_back_as_the_batch() {
    let n = 2 * PAGE_ROWS + 77;
    let rows = rows(n);
    let dir = tempfile::tempdir().unwrap();
    for set in [ColumnSet::Minimal, ColumnSet::Standard, ColumnSet::Full] {
        let schema = PoseSchema::new(set, false);
        let expected = schema.batch(Mode::Dynamic, &rows);
        for codec in [Codec::None, Codec::Lz4, Codec::Zstd] {
            let what = format!("{set:?}, {}", codec.name());
            let mut part = schema.part(Mode::Dynamic, n);
            part.pages(&schema).into_par_iter().enumerate().for_each(|(p, page)| {
                let mut buf = schema.page_buffer();
                let (first, len) = (page.first(), page.rows());
                assert_eq!((first, len), page_spans(n)[p], "page {p}");
                page.write(&mut buf, codec, Vec::new(), |sink| {
                    for i in (0..len).rev() {
                        let (s, r) = &rows[first + i];
                        sink.put(i, s, r);
                    }
                })
                .unwrap();
            });
            let path = dir.path().join(format!("{set:?}-{}.parquet", codec.name()));
            let opts = WriteOptions { codec, ..WriteOptions::default() };
            write_part(&path, &schema, &part, &opts, &[("clearance.variant".into(), "7".into())]).unwrap();

            let got = read(&path);
            assert_eq!(got.num_rows(), n, "{what}");
            for (field, want) in expected.schema().fields().iter().zip(expected.columns()) {
                let have = got.column_by_name(field.name()).unwrap_or_else(|| panic!("{what}: {}", field.name()));
                assert_eq!(have.as_ref(), want.as_ref(), "{what}: {}", field.name());
            }
            assert!(expected.columns().iter().any(|c| c.null_count() > 0), "{what}: some nulls to write");

            let reader = SerializedFileReader::new(std::fs::File::open(&path).unwrap()).unwrap();
            let meta = reader.metadata();
            assert_eq!(meta.num_row_groups(), 1, "{what}");
            let kv = meta.file_metadata().key_value_metadata().unwrap();
            assert!(kv.iter().any(|k| k.key == "clearance.variant" && k.value.as_deref() == Some("7")), "{what}");
            let rg = reader.get_row_group(0).unwrap();
            // The labels: the extremes of the values, and a dictionary page.
            for name in ["mode", "status"] {
                let c = expected.schema().index_of(name).unwrap();
                let want = expected.column(c).as_any().downcast_ref::<StringArray>().unwrap();
                let Some(Statistics::ByteArray(s)) = meta.row_group(0).column(c).statistics() else {
                    panic!("{what}: no string statistics for {name}")
                };
                let utf8 = |b: Option<&parquet::data_type::ByteArray>| b.map(|b| b.as_utf8().unwrap().to_string());
                let (lo, hi) = (want.iter().flatten().min(), want.iter().flatten().max());
                assert_eq!(utf8(s.min_opt()), lo.map(String::from), "{what}: min of {name}");
                assert_eq!(utf8(s.max_opt()), hi.map(String::from), "{what}: max of {name}");
                assert_eq!(s.null_count_opt(), Some(0), "{what}: nulls of {name}");
                assert!(meta.row_group(0).column(c).dictionary_page_offset().is_some(), "{what}: {name}");
            }
            if set == ColumnSet::Standard && codec == Codec::Zstd {
                let status = expected.column_by_name("status").unwrap().as_any().downcast_ref::<StringArray>().unwrap();
                let distinct: std::collections::BTreeSet<_> = status.iter().flatten().collect();
                assert_eq!(distinct.len(), 4, "every status among the rows");
            }
            for (c, field) in expected.schema().fields().iter().enumerate() {
                let Some(want) = expected.column(c).as_any().downcast_ref::<Float64Array>() else { continue };
                let name = field.name();
                let Some(Statistics::Double(s)) = meta.row_group(0).column(c).statistics() else {
                    panic!("{what}: no double statistics for {name}")
                };
                assert_eq!(s.null_count_opt(), Some(want.null_count() as u64), "{what}: nulls of {name}");
                let range = s.min_opt().zip(s.max_opt()).map(|(a, b)| (a.to_bits(), b.to_bits()));
                assert_eq!(range, expected_range(want), "{what}: range of {name}");
                let pages = rg.get_column_page_reader(c).unwrap().collect::<Result<Vec<_>, _>>().unwrap().len();
                assert_eq!(pages, page_spans(n).len(), "{what}: pages of {name}");
            }
        }
    }
}

/// A group's members written page by page together (`PageWriter::write_members`:
/// the columns a member shares bit for bit with the first copied from its encoding)
/// give the same files, byte for byte, as each member written alone: members that
/// scale one kind, another, none, and all, in every codec and precision.
#[test]
fn members_written_together_give_the_files_written_alone() {
    let n = 2 * PAGE_ROWS + 77;
    let rows: Vec<(Sample, PoseResult)> = rows(n)
        .into_iter()
        .map(|(s, mut r)| {
            r.envelope = std::array::from_fn(|k| std::array::from_fn(|c| r.errors[k].dp.x * (1.0 + c as f64)));
            r.contribution = std::array::from_fn(|k| std::array::from_fn(|j| r.errors[k].dalpha.y * (1.0 + j as f64)));
            (s, r)
        })
        .collect();
    let scales = [[1.0, 1.0, 1.0, 1.0], [1.0, 2.0, 1.0, 1.0], [1.0, 1.0, 1.0, 1.0], [0.5, 3.0, 0.0, 1e-3]];
    let members: Vec<Vec<PoseResult>> =
        scales.iter().map(|scale| rows.iter().map(|(_, r)| r.scaled(scale)).collect()).collect();
    let dir = tempfile::tempdir().unwrap();
    for precision in [Precision::Double, Precision::Single] {
        let schema = PoseSchema::new(ColumnSet::Full, false).with_precision(precision);
        for codec in [Codec::None, Codec::Zstd] {
            let what = format!("{precision:?}, {}", codec.name());
            let opts = WriteOptions { codec, ..WriteOptions::default() };
            let mut together: Vec<_> = members.iter().map(|_| schema.part(Mode::Kinetostatic, n)).collect();
            let mut writers: Vec<_> = together.iter_mut().map(|p| p.pages(&schema).into_iter()).collect();
            let mut buf = schema.page_buffer();
            while let Some(pages) = writers.iter_mut().map(|w| w.next()).collect::<Option<Vec<_>>>() {
                let (first, len) = (pages[0].first(), pages[0].rows());
                let results = PageWriter::write_members(pages, &mut buf, codec, Vec::new, |m, sink| {
                    for i in 0..len {
                        sink.put(i, &rows[first + i].0, &members[m][first + i]);
                    }
                    m
                });
                let results: Vec<usize> = results.into_iter().map(Result::unwrap).collect();
                assert_eq!(results, (0..members.len()).collect::<Vec<_>>(), "{what}: each member's fill");
            }
            drop(writers);
            let mut files = Vec::new();
            for (m, part) in together.iter().enumerate() {
                let alone = dir.path().join(format!("alone-{m}.parquet"));
                let mut single = schema.part(Mode::Kinetostatic, n);
                for page in single.pages(&schema) {
                    let (first, len) = (page.first(), page.rows());
                    page.write(&mut schema.page_buffer(), codec, Vec::new(), |sink| {
                        for i in 0..len {
                            sink.put(i, &rows[first + i].0, &members[m][first + i]);
                        }
                    })
                    .unwrap();
                }
                write_part(&alone, &schema, &single, &opts, &[]).unwrap();
                let with = dir.path().join(format!("together-{m}.parquet"));
                write_part(&with, &schema, part, &opts, &[]).unwrap();
                let bytes = std::fs::read(&with).unwrap();
                assert!(bytes == std::fs::read(&alone).unwrap(), "{what}: member {m} differs from its file alone");
                files.push(bytes);
            }
            assert!(files[0] == files[2], "{what}: members with the same scale");
            assert!(files[0] != files[1] && files[1] != files[3], "{what}: members that scale a kind differ");
        }
    }
}

#[test]
fn a_part_with_a_page_never_computed_is_refused_and_leaves_no_file() {
    let rows = rows(PAGE_ROWS + 5);
    let schema = PoseSchema::new(ColumnSet::Standard, false);
    let mut part = schema.part(Mode::Kinetostatic, rows.len());
    // Only the first page is written.
    let page = part.pages(&schema).into_iter().next().unwrap();
    page.write(&mut schema.page_buffer(), Codec::Zstd, Vec::new(), |sink| {
        for (i, (s, r)) in rows[..PAGE_ROWS].iter().enumerate() {
            sink.put(i, s, r);
        }
    })
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("part.parquet");
    let err = write_part(&path, &schema, &part, &WriteOptions::default(), &[]).unwrap_err();
    assert!(anyhow_chain(&err).contains("page 1"), "{err:?}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0, "nothing left behind");
}

fn anyhow_chain(e: &dyn std::error::Error) -> String {
    let mut out = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        out += &format!(": {c}");
        cause = c.source();
    }
    out
}

/// A part's pages cover its rows in order: of `PAGE_ROWS` rows, but what would be
/// the last such page cut into pages of `TAIL_PAGE_ROWS` (whole bytes of validity
/// bits each).
#[test]
fn pages_are_full_but_the_last_few() {
    assert!(page_spans(0).is_empty());
    assert_eq!(page_spans(5), vec![(0, 5)]);
    assert_eq!(page_spans(TAIL_PAGE_ROWS + 1), vec![(0, TAIL_PAGE_ROWS), (TAIL_PAGE_ROWS, 1)]);
    for n in [1, 77, PAGE_ROWS - 1, PAGE_ROWS, PAGE_ROWS + 1, 3 * PAGE_ROWS + 5, 16 * PAGE_ROWS, 65_536 + 999] {
        let spans = page_spans(n);
        let mut next = 0;
        for &(first, rows) in &spans {
            assert_eq!(first, next, "{n} rows: pages in order, no gap");
            assert!(first % 8 == 0 && rows > 0, "{n} rows: page at {first}");
            next = first + rows;
        }
        assert_eq!(next, n, "{n} rows: every row in a page");
        let full = spans.iter().take_while(|s| s.1 == PAGE_ROWS && n - s.0 > PAGE_ROWS).count();
        assert_eq!(full, (n - 1) / PAGE_ROWS, "{n} rows: full pages up to the last");
        assert!(spans[full..].iter().all(|s| s.1 <= TAIL_PAGE_ROWS), "{n} rows: short pages after");
    }
}
