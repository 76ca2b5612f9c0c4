//! The sweep's rows: one per sample and scenario, with the requirement's figure and every
//! parameter's value, written as CSV with every digit (`{:e}`, the shortest text that reads
//! back to the same number) so that rows from different threads, batches or machines can be
//! compared bit for bit.

use std::io::Write;

use antenna_fmus::parameters::UncertainParameter;

/// The columns before the parameters' values.
pub const LEADING_COLUMNS: [&str; 9] =
    ["sample", "scenario", "requirement", "elevation_deg", "figure", "unit", "limit", "passed", "error"];

/// One scenario of one sample.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    pub sample: u64,
    pub scenario: String,
    /// The requirement's label, `Req. 1` ...
    pub requirement: String,
    pub elevation_deg: f64,
    /// The figure judged against the limit; NaN if the run never settled or failed.
    pub figure: f64,
    pub unit: String,
    pub limit: f64,
    pub passed: bool,
    /// Why the run failed (empty if it ran): a failed run is a row, not the end of the sweep.
    pub error: String,
    /// Every parameter's value in table order (`None`: the scenario's own wind seed).
    pub values: Vec<Option<f64>>,
}

/// The header line's fields.
pub fn header(parameters: &[UncertainParameter]) -> Vec<String> {
    LEADING_COLUMNS.iter().map(|c| c.to_string()).chain(parameters.iter().map(|p| p.name.clone())).collect()
}

/// A number with all its digits.
fn exact(value: f64) -> String {
    format!("{value:e}")
}

/// Writes rows as CSV.
pub struct RowWriter<W: Write> {
    writer: csv::Writer<W>,
}

impl<W: Write> RowWriter<W> {
    /// A writer that starts with the header.
    pub fn new(out: W, parameters: &[UncertainParameter]) -> Result<Self, csv::Error> {
        let mut writer = csv::Writer::from_writer(out);
        writer.write_record(header(parameters))?;
        Ok(RowWriter { writer })
    }

    pub fn write(&mut self, row: &Row) -> Result<(), csv::Error> {
        let leading = [
            row.sample.to_string(),
            row.scenario.clone(),
            row.requirement.clone(),
            exact(row.elevation_deg),
            exact(row.figure),
            row.unit.clone(),
            exact(row.limit),
            row.passed.to_string(),
            row.error.clone(),
        ];
        let values = row.values.iter().map(|v| v.map_or(String::new(), exact));
        self.writer.write_record(leading.into_iter().chain(values))
    }

    pub fn flush(&mut self) -> std::io::Result<()> {
        self.writer.flush()
    }

    pub fn into_inner(self) -> Result<W, csv::Error> {
        self.writer.into_inner().map_err(|e| csv::Error::from(e.into_error()))
    }
}

/// Why the rows cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum RowsError {
    #[error("{origin}: {source}")]
    Csv { origin: String, source: csv::Error },
    #[error("{origin}: the header must start with `{}`", LEADING_COLUMNS.join(","))]
    Header { origin: String },
    #[error("{origin}:{line}: {message}")]
    Field { origin: String, line: u64, message: String },
}

/// Reads the rows of a sweep CSV one at a time, calling `each` with the parameter names (the
/// columns after the leading ones) and the row: a sweep of any size is read in constant memory.
pub fn read_rows(
    reader: impl std::io::Read,
    origin: &str,
    mut each: impl FnMut(&[String], Row),
) -> Result<Vec<String>, RowsError> {
    let csv_error = |source| RowsError::Csv { origin: origin.to_string(), source };
    let mut reader = csv::Reader::from_reader(reader);
    let header = reader.headers().map_err(csv_error)?.clone();
    if header.len() < LEADING_COLUMNS.len() || header.iter().zip(LEADING_COLUMNS).any(|(a, b)| a != b) {
        return Err(RowsError::Header { origin: origin.to_string() });
    }
    let names: Vec<String> = header.iter().skip(LEADING_COLUMNS.len()).map(str::to_string).collect();
    let mut record = csv::StringRecord::new();
    while reader.read_record(&mut record).map_err(csv_error)? {
        let line = record.position().map_or(0, |p| p.line());
        let bad = |message: String| RowsError::Field { origin: origin.to_string(), line, message };
        let number = |i: usize| -> Result<f64, RowsError> {
            let text = record.get(i).unwrap_or("");
            text.parse().map_err(|_| bad(format!("{} = `{text}` is not a number", LEADING_COLUMNS[i])))
        };
        let values = (LEADING_COLUMNS.len()..record.len())
            .map(|i| match record.get(i).unwrap_or("") {
                "" => Ok(None),
                text => text.parse().map(Some).map_err(|_| bad(format!("{} = `{text}` is not a number", &header[i]))),
            })
            .collect::<Result<Vec<_>, _>>()?;
        let row = Row {
            sample: record[0].parse().map_err(|_| bad(format!("sample = `{}` is not an index", &record[0])))?,
            scenario: record[1].to_string(),
            requirement: record[2].to_string(),
            elevation_deg: number(3)?,
            figure: number(4)?,
            unit: record[5].to_string(),
            limit: number(6)?,
            passed: &record[7] == "true",
            error: record[8].to_string(),
            values,
        };
        each(&names, row);
    }
    Ok(names)
}

#[cfg(test)]
mod tests {
    use super::*;
    use antenna_fmus::parameters::parameters;

    #[test]
    fn rows_read_back_to_the_bit() {
        let table = parameters();
        let row = Row {
            sample: 7,
            scenario: "step-30arcmin-el45".into(),
            requirement: "Req. 4".into(),
            elevation_deg: 45.0,
            figure: 0.1 + 0.2,
            unit: "s".into(),
            limit: 4.0,
            passed: true,
            error: String::new(),
            values: table
                .iter()
                .enumerate()
                .map(|(i, _)| if i == 3 { None } else { Some(1.0 / (i as f64 + 3.0)) })
                .collect(),
        };
        let mut writer = RowWriter::new(Vec::new(), &table).unwrap();
        writer.write(&row).unwrap();
        let bytes = writer.into_inner().unwrap();
        let mut read = Vec::new();
        let names = read_rows(bytes.as_slice(), "test", |_, r| read.push(r)).unwrap();
        assert_eq!(names.len(), table.len());
        assert_eq!(read, vec![row]);
    }
}
