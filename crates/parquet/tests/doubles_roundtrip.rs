//! The double columns `write_parquet` encodes itself read back, through the
//! `parquet` crate's own reader, as the values, nulls and statistics written: for
//! every codec, page and row-group boundaries that cut bytes of the validity
//! bitmap, columns with no nulls, only nulls or some, required columns, and
//! values whose order is delicate (±0, subnormals, the extremes, NaN).

use std::sync::Arc;

use arrow::array::{Array, ArrayRef, Float64Array, StringArray};
use arrow::datatypes::{DataType, Field, Schema};
use arrow::record_batch::RecordBatch;
use clearance_parquet::{Codec, PAGE_ROWS, WriteOptions, write_parquet};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use parquet::file::statistics::Statistics;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn value(rng: &mut ChaCha8Rng) -> f64 {
    match rng.random_range(0..40) {
        4 => f64::NAN,
        0 => 0.0,
        1 => -0.0,
        2 => f64::MIN_POSITIVE / 8.0,
        3 => {
            if rng.random() {
                f64::MAX
            } else {
                -f64::MAX
            }
        }
        _ => (rng.random::<f64>() - 0.5) * 10f64.powi(rng.random_range(-12..12)),
    }
}

/// A column of `n` rows where each row is null with probability `p_null`.
fn column(rng: &mut ChaCha8Rng, n: usize, p_null: f64) -> Float64Array {
    (0..n).map(|_| (!rng.random_bool(p_null)).then(|| value(rng))).collect()
}

/// Total order extremes of the valid values that are numbers, `None` when there are none.
fn expected_range(a: &Float64Array) -> Option<(f64, f64)> {
    let mut v: Vec<f64> = a.iter().flatten().filter(|v| !v.is_nan()).collect();
    v.sort_by(f64::total_cmp);
    Some((*v.first()?, *v.last()?))
}

#[test]
fn double_columns_read_back_exactly_with_their_statistics() {
    const P: usize = PAGE_ROWS;
    let mut rng = ChaCha8Rng::seed_from_u64(2026);
    let dir = tempfile::tempdir().unwrap();
    for (case, (n, row_group_rows)) in
        [(0, 100), (1, 100), (7, 100), (P, 65536), (P + 1, 65536), (3 * P + 5, 65536), (5000, 1001), (4 * P, 3 * P - 3)]
            .into_iter()
            .enumerate()
    {
        for codec in [Codec::None, Codec::Lz4, Codec::Zstd] {
            let fields = vec![
                Field::new("label", DataType::Utf8, false),
                Field::new("dense", DataType::Float64, true),
                Field::new("sparse", DataType::Float64, true),
                Field::new("some", DataType::Float64, true),
                Field::new("empty", DataType::Float64, true),
                Field::new("required", DataType::Float64, false),
            ];
            let schema = Arc::new(Schema::new(fields));
            let columns: Vec<ArrayRef> = vec![
                Arc::new(StringArray::from_iter_values((0..n).map(|i| if i % 3 == 0 { "a" } else { "b" }))),
                Arc::new(column(&mut rng, n, 0.0)),
                Arc::new(column(&mut rng, n, 0.9)),
                Arc::new(column(&mut rng, n, 0.02)),
                Arc::new(column(&mut rng, n, 1.0)),
                Arc::new(column(&mut rng, n, 0.0)),
            ];
            let batch = RecordBatch::try_new(schema.clone(), columns).unwrap();
            let path = dir.path().join(format!("case{case}-{}.parquet", codec.name()));
            let opts = WriteOptions { row_group_rows, codec, ..WriteOptions::default() };
            write_parquet(&path, schema.clone(), std::slice::from_ref(&batch), &opts, &[]).unwrap();

            let what = format!("{n} rows, row groups of {row_group_rows}, {}", codec.name());
            let file = std::fs::File::open(&path).unwrap();
            let reader = ParquetRecordBatchReaderBuilder::try_new(file).unwrap();
            let meta = reader.metadata().clone();
            let read: Vec<RecordBatch> = reader.build().unwrap().collect::<Result<_, _>>().unwrap();
            let read = arrow::compute::concat_batches(&schema, &read).unwrap();
            assert_eq!(read.num_rows(), n, "{what}");
            for (c, field) in schema.fields().iter().enumerate() {
                let (a, b) = (batch.column(c), read.column(c));
                assert_eq!(a.nulls(), b.nulls(), "{what}: nulls of {}", field.name());
                if let (Some(a), Some(b)) =
                    (a.as_any().downcast_ref::<Float64Array>(), b.as_any().downcast_ref::<Float64Array>())
                {
                    for i in (0..n).filter(|&i| a.is_valid(i)) {
                        assert_eq!(a.value(i).to_bits(), b.value(i).to_bits(), "{what}: {} row {i}", field.name());
                    }
                } else {
                    assert_eq!(a, b, "{what}: {}", field.name());
                }
            }

            // Each row group's statistics describe its rows.
            let mut first = 0;
            for rg in meta.row_groups() {
                let rows = rg.num_rows() as usize;
                for (c, field) in schema.fields().iter().enumerate().skip(1) {
                    let part = batch.column(c).slice(first, rows);
                    let part = part.as_any().downcast_ref::<Float64Array>().unwrap();
                    let Some(Statistics::Double(s)) = rg.column(c).statistics() else {
                        panic!("{what}: no double statistics for {}", field.name())
                    };
                    assert_eq!(s.null_count_opt(), Some(part.null_count() as u64), "{what}: {}", field.name());
                    let got = s.min_opt().zip(s.max_opt()).map(|(a, b)| (a.to_bits(), b.to_bits()));
                    let want = expected_range(part).map(|(a, b)| (a.to_bits(), b.to_bits()));
                    assert_eq!(got, want, "{what}: range of {} in rows {first}..", field.name());
                }
                first += rows;
            }
            assert_eq!(first, n, "{what}");
        }
    }
}
