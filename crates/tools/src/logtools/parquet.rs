//! `dima log export FILE --format parquet -o OUT.parquet`: the rows of [`export::rows`] as an
//! Apache Parquet file, with a first column `run` naming the run, so that the files of a whole
//! fleet are queried together by any Parquet reader (DuckDB, Spark, pandas, polars):
//!
//! ```sql
//! SELECT run, count(*) AS cycles, max(cycle) FROM 'logs/*.parquet' GROUP BY run;
//! ```
//!
//! The columns are those of the CSV export, in its order, after `run`. Every column has one
//! type, the same in every file whatever the run held (a run without a sensor board still has
//! DOUBLE `accel_x_m_s2`, all null), so the files of many runs read as one table:
//!
//! | values | Parquet type |
//! | --- | --- |
//! | counts, numbers, µs targets, percentages (`cycle`, `log_time_ns`, `missed_periods`, `throttle_pct`, `target_*_us`, `itow_ms`, `satellites`, ...) | INT64 |
//! | physical values and times (`t_s`, `*_us` timings, `accel_*`, `pressure_pa`, `action_*`, ...) | DOUBLE |
//! | `fix_ok` | BOOLEAN |
//! | `run`, `mode`, `recorded_mode`, `cause`, `packet`, `refused`, `events` | BYTE_ARRAY, logical type String (UTF8) |
//!
//! A column is OPTIONAL (nullable) exactly where the CSV may leave the cell empty, REQUIRED
//! elsewhere. The file is compressed with zstd.

use std::io::Write;
use std::path::Path;
use std::sync::Arc;

use anyhow::{bail, Context};
use parquet::basic::{Compression, ZstdLevel};
use parquet::data_type::{BoolType, ByteArray, ByteArrayType, DoubleType, Int64Type};
use parquet::file::properties::WriterProperties;
use parquet::file::writer::SerializedFileWriter;
use parquet::schema::parser::parse_message_type;
use serde_json::Value;

use super::export::{self, Channel};

/// Name of the column that names the run.
pub const RUN_COLUMN: &str = "run";

/// Rows in one row group (a 10-minute file at 250 Hz is about two).
const ROW_GROUP_ROWS: usize = 65_536;

/// The Parquet type of a column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// INT64.
    Int64,
    /// DOUBLE.
    Double,
    /// BOOLEAN.
    Boolean,
    /// BYTE_ARRAY with the String logical type (UTF8).
    Utf8,
}

impl Kind {
    /// The type as written in a Parquet message type.
    fn schema_text(self) -> &'static str {
        match self {
            Kind::Int64 => "INT64",
            Kind::Double => "DOUBLE",
            Kind::Boolean => "BOOLEAN",
            Kind::Utf8 => "BYTE_ARRAY",
        }
    }
}

/// One column of the Parquet schema.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Column {
    /// The column's name (the CSV header's).
    pub name: &'static str,
    /// Its Parquet type.
    pub kind: Kind,
    /// Whether a cell may be null (the CSV leaves it empty).
    pub nullable: bool,
}

const fn required(name: &'static str, kind: Kind) -> Column {
    Column {
        name,
        kind,
        nullable: false,
    }
}

const fn nullable(name: &'static str, kind: Kind) -> Column {
    Column {
        name,
        kind,
        nullable: true,
    }
}

use Kind::{Boolean, Double, Int64, Utf8};

/// The columns of `--channel cycle`, after `run`, in the order of [`export::cycle_row`].
const CYCLE: &[Column] = &[
    required("t_s", Double),
    required("log_time_ns", Int64),
    required("cycle", Int64),
    required("mode", Utf8),
    nullable("cause", Utf8),
    required("packet", Utf8),
    required("missed_periods", Int64),
    required("wake_latency_us", Double),
    nullable("request_to_packet_us", Double),
    required("compute_us", Double),
    nullable("servo_write_us", Double),
    nullable("accel_x_m_s2", Double),
    nullable("accel_y_m_s2", Double),
    nullable("accel_z_m_s2", Double),
    nullable("gyro_x_dps", Double),
    nullable("gyro_y_dps", Double),
    nullable("gyro_z_dps", Double),
    nullable("mag_x_ut", Double),
    nullable("mag_y_ut", Double),
    nullable("mag_z_ut", Double),
    nullable("pressure_pa", Double),
    nullable("temperature_c", Double),
    nullable("gnss_age_ms", Double),
    nullable("throttle_pct", Int64),
    nullable("steering_pct", Int64),
    nullable("tail_pct", Int64),
    nullable("speed_setpoint_mm_s", Int64),
    nullable("heading_setpoint_deg", Double),
    required("action_throttle", Double),
    required("action_steering", Double),
    required("action_tail", Double),
    required("target_throttle_us", Int64),
    required("target_steering_us", Int64),
    required("target_tail_us", Int64),
    nullable("gnss_speed_m_s", Double),
    nullable("gnss_heading_deg", Double),
    nullable("gnss_lat_deg", Double),
    nullable("gnss_lon_deg", Double),
    nullable("est_speed_m_s", Double),
    nullable("est_heading_deg", Double),
];

/// The columns of `--channel replay`, after `run`, in the order of [`export::replay_row`].
const REPLAY: &[Column] = &[
    required("t_s", Double),
    required("log_time_ns", Int64),
    required("cycle", Int64),
    required("mode", Utf8),
    nullable("cause", Utf8),
    required("recorded_mode", Utf8),
    nullable("speed_setpoint_mm_s", Int64),
    nullable("heading_setpoint_deg", Double),
    nullable("gnss_speed_m_s", Double),
    nullable("gnss_heading_deg", Double),
    nullable("est_speed_m_s", Double),
    nullable("est_heading_deg", Double),
    nullable("est_yaw_rate_dps", Double),
    required("action_throttle", Double),
    required("action_steering", Double),
    required("action_tail", Double),
    nullable("recorded_action_throttle", Double),
    nullable("recorded_action_steering", Double),
    nullable("recorded_action_tail", Double),
    required("target_throttle_us", Int64),
    required("target_steering_us", Int64),
    required("target_tail_us", Int64),
    required("recorded_target_throttle_us", Int64),
    required("recorded_target_steering_us", Int64),
    required("recorded_target_tail_us", Int64),
];

/// The columns of `--channel gnss`, after `run`.
const GNSS: &[Column] = &[
    required("t_s", Double),
    nullable("itow_ms", Int64),
    required("fix_ok", Boolean),
    nullable("lat_deg", Double),
    nullable("lon_deg", Double),
    nullable("ground_speed_m_s", Double),
    nullable("heading_of_motion_deg", Double),
    nullable("satellites", Int64),
];

/// The columns of `--channel state`, after `run`.
const STATE: &[Column] = &[
    required("t_s", Double),
    required("cycle", Int64),
    required("mode", Utf8),
    nullable("cause", Utf8),
    nullable("refused", Utf8),
    required("events", Utf8),
];

/// The columns of `channel`'s export, after `run`.
pub fn columns(channel: Channel) -> &'static [Column] {
    match channel {
        Channel::Cycle => CYCLE,
        Channel::Gnss => GNSS,
        Channel::State => STATE,
        Channel::Replay => REPLAY,
    }
}

/// The Parquet message type of `channel`'s export: `run`, then [`columns`].
pub fn message_type(channel: Channel) -> String {
    let mut text = format!("message dima_{channel:?} {{\n").to_lowercase();
    let run = required(RUN_COLUMN, Utf8);
    for c in std::iter::once(&run).chain(columns(channel)) {
        let repetition = if c.nullable { "OPTIONAL" } else { "REQUIRED" };
        let logical = if c.kind == Utf8 { " (STRING)" } else { "" };
        text += &format!(
            "  {repetition} {} {}{logical};\n",
            c.kind.schema_text(),
            c.name
        );
    }
    text + "}\n"
}

/// The run's id from its log file: the stem of the run's first file (`dima_log::naming`), so
/// every file of a split run (`dima-20261127T120000Z.mcap`, `dima-20261127T120000Z-2.mcap`)
/// is run `dima-20261127T120000Z`. The log's metadata holds no run id of its own.
pub fn run_id(path: &Path) -> String {
    let first = dima_log::naming::run_place(path).first;
    first
        .file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned())
}

/// The cells of one column, checked against its type: the values present, and for a nullable
/// column the definition level of every row (1 present, 0 null).
struct Cells<T> {
    values: Vec<T>,
    levels: Option<Vec<i16>>,
}

fn cells<T>(
    rows: &[Vec<(&'static str, Value)>],
    index: usize,
    column: &Column,
    convert: impl Fn(&Value) -> Option<T>,
) -> anyhow::Result<Cells<T>> {
    let mut values = Vec::with_capacity(rows.len());
    let mut levels = column.nullable.then(|| Vec::with_capacity(rows.len()));
    for (n, row) in rows.iter().enumerate() {
        let (name, value) = row
            .get(index)
            .with_context(|| format!("row {n} has no column {}", column.name))?;
        if *name != column.name {
            bail!(
                "row {n}: column {index} is {name}, the Parquet schema has {}",
                column.name
            );
        }
        match (value, &mut levels) {
            (Value::Null, Some(levels)) => levels.push(0),
            (Value::Null, None) => bail!("row {n}: {} is empty but not nullable", column.name),
            (value, levels) => {
                let v = convert(value).with_context(|| {
                    format!(
                        "row {n}: {} = {value} is not {:?}",
                        column.name, column.kind
                    )
                })?;
                values.push(v);
                if let Some(levels) = levels {
                    levels.push(1);
                }
            }
        }
    }
    Ok(Cells { values, levels })
}

/// Writes `rows` (from [`export::rows`] for `channel`) as a Parquet file to `out`, with `run`
/// in the `run` column of every row. No rows still make a file, with the schema.
pub fn write<W: Write + Send>(
    rows: &[Vec<(&'static str, Value)>],
    channel: Channel,
    run: &str,
    out: W,
) -> anyhow::Result<()> {
    let schema = Arc::new(parse_message_type(&message_type(channel))?);
    let properties = WriterProperties::builder()
        .set_compression(Compression::ZSTD(ZstdLevel::default()))
        .build();
    let mut writer = SerializedFileWriter::new(out, schema, Arc::new(properties))?;
    let columns = columns(channel);
    for group in rows.chunks(ROW_GROUP_ROWS) {
        let mut row_group = writer.next_row_group()?;
        let mut run_column = row_group.next_column()?.context("the run column")?;
        let run_cells = vec![ByteArray::from(run); group.len()];
        run_column
            .typed::<ByteArrayType>()
            .write_batch(&run_cells, None, None)?;
        run_column.close()?;
        for (index, column) in columns.iter().enumerate() {
            let mut w = row_group.next_column()?.context("a column of the schema")?;
            match column.kind {
                Int64 => {
                    let c = cells(group, index, column, Value::as_i64)?;
                    w.typed::<Int64Type>()
                        .write_batch(&c.values, c.levels.as_deref(), None)?;
                }
                Double => {
                    let c = cells(group, index, column, Value::as_f64)?;
                    w.typed::<DoubleType>()
                        .write_batch(&c.values, c.levels.as_deref(), None)?;
                }
                Boolean => {
                    let c = cells(group, index, column, Value::as_bool)?;
                    w.typed::<BoolType>()
                        .write_batch(&c.values, c.levels.as_deref(), None)?;
                }
                Utf8 => {
                    let c = cells(group, index, column, |v| v.as_str().map(ByteArray::from))?;
                    w.typed::<ByteArrayType>()
                        .write_batch(&c.values, c.levels.as_deref(), None)?;
                }
            }
            w.close()?;
        }
        if let Some((name, _)) = group.first().and_then(|row| row.get(columns.len())) {
            bail!("column {name} is not in the Parquet schema of the {channel:?} export");
        }
        row_group.close()?;
    }
    writer.close()?;
    Ok(())
}

/// Writes `channel`'s rows of `run` (see [`export::rows`]) to the Parquet file `path`.
pub fn export_file(
    run: &super::read::LoggedRun,
    channel: Channel,
    (from_s, to_s): (f64, f64),
    run_id: &str,
    path: &Path,
) -> anyhow::Result<()> {
    let rows = export::rows(run, channel, from_s, to_s);
    let file =
        std::fs::File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    let mut out = std::io::BufWriter::new(file);
    write(&rows, channel, run_id, &mut out)
        .with_context(|| format!("writing {}", path.display()))?;
    out.flush()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use parquet::basic::{LogicalType, Repetition, Type as PhysicalType};
    use parquet::file::reader::{FileReader, SerializedFileReader};
    use parquet::record::Field;
    use serde_json::json;

    use super::*;

    /// A cycle row with every column of the schema, the nullable ones null when `empty`.
    fn cycle_row(cycle: i64, empty: bool) -> Vec<(&'static str, Value)> {
        CYCLE
            .iter()
            .map(|c| {
                let value = match (c.kind, c.nullable && empty) {
                    (_, true) => Value::Null,
                    (Int64, _) => json!(cycle * 10 + 1),
                    (Double, _) => json!(cycle as f64 + 0.25),
                    (Boolean, _) => json!(cycle % 2 == 0),
                    (Utf8, _) => json!(format!("{}-{cycle}", c.name)),
                };
                (c.name, value)
            })
            .collect()
    }

    fn read_back(bytes: Vec<u8>) -> SerializedFileReader<std::fs::File> {
        let path = std::env::temp_dir().join(format!(
            "dima-parquet-unit-{}-{:?}.parquet",
            std::process::id(),
            std::thread::current().id()
        ));
        std::fs::write(&path, bytes).unwrap();
        let reader = SerializedFileReader::new(std::fs::File::open(&path).unwrap()).unwrap();
        std::fs::remove_file(&path).unwrap();
        reader
    }

    #[test]
    fn rows_read_back_with_their_names_types_and_nulls() {
        let rows: Vec<_> = (0..5).map(|n| cycle_row(n, n == 3)).collect();
        let mut bytes = Vec::new();
        write(&rows, Channel::Cycle, "dima-20261127T120000Z", &mut bytes).unwrap();
        assert_eq!(&bytes[..4], b"PAR1");
        let reader = read_back(bytes);

        let meta = reader.metadata().file_metadata();
        assert_eq!(meta.num_rows(), 5);
        let fields = meta.schema_descr().root_schema().get_fields().to_vec();
        assert_eq!(fields.len(), CYCLE.len() + 1);
        assert_eq!(fields[0].name(), "run");
        for (field, column) in fields[1..].iter().zip(CYCLE) {
            let info = field.get_basic_info();
            assert_eq!(field.name(), column.name);
            let physical = match column.kind {
                Int64 => PhysicalType::INT64,
                Double => PhysicalType::DOUBLE,
                Boolean => PhysicalType::BOOLEAN,
                Utf8 => PhysicalType::BYTE_ARRAY,
            };
            assert_eq!(field.get_physical_type(), physical, "{}", column.name);
            let repetition = if column.nullable {
                Repetition::OPTIONAL
            } else {
                Repetition::REQUIRED
            };
            assert_eq!(info.repetition(), repetition, "{}", column.name);
            if column.kind == Utf8 {
                assert_eq!(info.logical_type_ref(), Some(&LogicalType::String));
            }
        }

        let read: Vec<_> = reader
            .get_row_iter(None)
            .unwrap()
            .map(|r| r.unwrap())
            .collect();
        assert_eq!(read.len(), 5);
        let field = |row: usize, name: &str| {
            read[row]
                .get_column_iter()
                .find(|(n, _)| n.as_str() == name)
                .map(|(_, f)| f.clone())
                .unwrap()
        };
        assert_eq!(field(2, "run"), Field::Str("dima-20261127T120000Z".into()));
        assert_eq!(field(2, "cycle"), Field::Long(21));
        assert_eq!(field(2, "t_s"), Field::Double(2.25));
        assert_eq!(field(2, "mode"), Field::Str("mode-2".into()));
        assert_eq!(field(2, "accel_z_m_s2"), Field::Double(2.25));
        assert_eq!(field(2, "throttle_pct"), Field::Long(21));
        assert_eq!(field(3, "accel_z_m_s2"), Field::Null);
        assert_eq!(field(3, "cause"), Field::Null);
        assert_eq!(field(3, "cycle"), Field::Long(31));
    }

    #[test]
    fn the_gnss_export_has_a_boolean_and_no_rows_still_make_a_file() {
        let rows = vec![vec![
            ("t_s", json!(0.1)),
            ("itow_ms", json!(1000)),
            ("fix_ok", json!(true)),
            ("lat_deg", json!(47.5)),
            ("lon_deg", json!(8.5)),
            ("ground_speed_m_s", Value::Null),
            ("heading_of_motion_deg", Value::Null),
            ("satellites", json!(9)),
        ]];
        let mut bytes = Vec::new();
        write(&rows, Channel::Gnss, "r", &mut bytes).unwrap();
        let row = read_back(bytes).get_row_iter(None).unwrap().next();
        let row = row.unwrap().unwrap();
        let fix = row.get_column_iter().find(|(n, _)| n.as_str() == "fix_ok");
        assert_eq!(fix.map(|(_, f)| f.clone()), Some(Field::Bool(true)));

        let mut bytes = Vec::new();
        write(&[], Channel::State, "r", &mut bytes).unwrap();
        let reader = read_back(bytes);
        assert_eq!(reader.metadata().file_metadata().num_rows(), 0);
        let fields = reader
            .metadata()
            .file_metadata()
            .schema_descr()
            .num_columns();
        assert_eq!(fields, STATE.len() + 1);
    }

    #[test]
    fn a_value_of_another_type_or_an_unknown_column_is_an_error() {
        let mut row = cycle_row(1, false);
        row[2].1 = json!("not a number");
        let e = write(&[row], Channel::Cycle, "r", Vec::new()).unwrap_err();
        assert!(format!("{e:#}").contains("cycle"), "{e:#}");

        let mut row = cycle_row(1, false);
        row[1].1 = Value::Null;
        let e = write(&[row], Channel::Cycle, "r", Vec::new()).unwrap_err();
        assert!(format!("{e:#}").contains("not nullable"), "{e:#}");

        let mut row = cycle_row(1, false);
        row.push(("new_column", json!(1)));
        let e = write(&[row], Channel::Cycle, "r", Vec::new()).unwrap_err();
        assert!(format!("{e:#}").contains("new_column"), "{e:#}");
    }

    #[test]
    fn the_run_id_is_the_first_file_stem_of_a_split_run() {
        let id = |p: &str| run_id(Path::new(p));
        assert_eq!(
            id("logs/dima-20261127T120000Z.mcap"),
            "dima-20261127T120000Z"
        );
        assert_eq!(
            id("logs/dima-20261127T120000Z-2.mcap"),
            "dima-20261127T120000Z"
        );
        assert_eq!(id("dima-20261127T120000Z-13.mcap"), "dima-20261127T120000Z");
        assert_eq!(id("car-07.mcap"), "car-07");
        assert_eq!(id("replay.mcap"), "replay");
    }
}
