//! Input timelines: a CSV table of signal values over time (seed 003's `tu`), where each value
//! holds until a later row changes it.
//!
//! ```text
//! # time in seconds or as an IEC literal; an empty cell keeps the previous value
//! time,START,STOP,SPEED
//! 0,0,0,0
//! T#1.5s,TRUE,,-3
//! 2,false,1,
//! ```
//!
//! `petriplc sim` drives net signals, which carry whole numbers. The soft PLC's `timeline`
//! module also drives f32 points: it reads with [`Timeline::parse_decimal`], which accepts
//! decimal values too (`1.5`, `-2e-3`, `nan`, `inf`).
//!
//! The file is parsed by hand rather than with a CSV library: the format has no quoting, and
//! hand-parsing lets every error point at the exact line and column of the offending cell.

use std::fmt;
use std::path::Path;
use std::time::Duration;

use petriplc_net::time::{format_seconds, parse_duration, TimeError};

/// What is wrong with a timeline file, with where.
#[derive(Debug, thiserror::Error)]
pub enum TimelineError {
    /// The file could not be read (missing, a folder or device, too large).
    #[error(transparent)]
    Io(#[from] petriplc_files::FileError),
    /// `line` and `column` are 1-based; `column` counts characters.
    #[error("{file}:{line}:{column}: {problem}")]
    Syntax {
        file: String,
        line: usize,
        column: usize,
        problem: TimelineProblem,
    },
}

impl TimelineError {
    /// The problem, when the file could be read.
    pub fn problem(&self) -> Option<&TimelineProblem> {
        match self {
            TimelineError::Io(_) => None,
            TimelineError::Syntax { problem, .. } => Some(problem),
        }
    }
    /// The 1-based line and column, when the file could be read.
    pub fn position(&self) -> Option<(usize, usize)> {
        match self {
            TimelineError::Io(_) => None,
            TimelineError::Syntax { line, column, .. } => Some((*line, *column)),
        }
    }
}

/// One problem in a timeline's text; the message says how to fix it.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum TimelineProblem {
    #[error("the timeline has no header; its first line must be `time,SIG1,SIG2,...`")]
    NoHeader,
    #[error(
        "byte {byte:#04x} is not UTF-8 text; save the timeline as UTF-8 (plain ASCII will do)"
    )]
    NotUtf8 { byte: u8 },
    #[error(
        "the first header cell is `{found}`; it must be `time` (header: `time,SIG1,SIG2,...`)"
    )]
    NotTime { found: String },
    #[error("the header names no signals; add one column per signal: `time,SIG1,SIG2,...`")]
    NoSignals,
    #[error("header cell {index} is empty; name every column after the signal it drives")]
    EmptyColumnName { index: usize },
    #[error("column `{name}` appears twice in the header (cells {first} and {second}); give each signal one column")]
    DuplicateColumn {
        name: String,
        first: usize,
        second: usize,
    },
    #[error("the row has {found} cells but the header has {expected}; add or remove commas (an empty cell keeps the previous value)")]
    CellCount { expected: usize, found: usize },
    #[error("the time cell is empty; every row starts with its time in seconds (`1.5`) or as an IEC literal (`T#1.5s`)")]
    MissingTime,
    #[error("bad time: {0}")]
    BadTime(TimeError),
    #[error("`{text}` is not a value for `{column}`: write 0/1, TRUE/FALSE or an integer, or leave the cell empty to keep the previous value")]
    BadValue { column: String, text: String },
    #[error("`{text}` is not a value for `{column}`: write 0/1, TRUE/FALSE, an integer or a decimal number (1.5, -2e-3), or leave the cell empty to keep the previous value")]
    BadDecimal { column: String, text: String },
    #[error("`{text}` for `{column}` is not a finite number: the PLC refuses NaN and infinities from outside, so that no point ever holds one (docs/runtime.md, \"What the PLC does with bad values\"); write a number")]
    NotFinite { column: String, text: String },
    #[error("time {}s comes before {}s on line {previous_line}; sort the rows by time (equal times are allowed)", format_seconds(*time), format_seconds(*previous))]
    DecreasingTime {
        time: Duration,
        previous: Duration,
        previous_line: usize,
    },
}

/// Where in the file the first byte that is not UTF-8 is.
fn not_utf8(file: &str, e: std::string::FromUtf8Error) -> TimelineError {
    let at = e.utf8_error().valid_up_to();
    let bytes = e.as_bytes();
    // The text before it is valid UTF-8: count lines and characters in it.
    let before = std::str::from_utf8(&bytes[..at]).unwrap_or_default();
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    TimelineError::Syntax {
        file: file.to_string(),
        line: before.matches('\n').count() + 1,
        column: before[line_start..].chars().count() + 1,
        problem: TimelineProblem::NotUtf8 { byte: bytes[at] },
    }
}

/// What a timeline of decimal values does with NaN and infinities (`nan`, `inf`, `1e999`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NonFinite {
    /// Refused where written (the default: no point holds one from outside the PLC).
    Refuse,
    /// Taken as values, to test how a program copes with them.
    Accept,
}

/// A parsed timeline: column names and, per column, the times its value changes.
#[derive(Clone, Debug, PartialEq)]
pub struct Timeline {
    source: String,
    columns: Vec<String>,
    /// Per column: (time, value) for every row whose cell is not empty, in time order (with
    /// decimals allowed: every cell holding a whole number).
    changes: Vec<Vec<(Duration, i64)>>,
    /// With decimals allowed ([`Timeline::parse_decimal`]): every non-empty cell's value.
    reals: Option<Vec<Vec<(Duration, f64)>>>,
    rows: usize,
    end: Duration,
}

impl Timeline {
    /// Parses timeline text; `source_name` (usually the file name) prefixes error messages.
    pub fn parse(text: &str, source_name: &str) -> Result<Timeline, TimelineError> {
        Timeline::parse_values(text, source_name, None)
    }

    /// Like [`Timeline::parse`], also accepting decimal values (for float points), which
    /// [`Timeline::decimal_changes`] and [`Timeline::decimal_at`] give.
    /// NaN and infinities are refused ([`TimelineProblem::NotFinite`]).
    pub fn parse_decimal(text: &str, source_name: &str) -> Result<Timeline, TimelineError> {
        Timeline::parse_values(text, source_name, Some(NonFinite::Refuse))
    }

    /// [`Timeline::parse_decimal`], choosing what NaN and infinities are.
    pub fn parse_decimal_with(
        text: &str,
        source_name: &str,
        non_finite: NonFinite,
    ) -> Result<Timeline, TimelineError> {
        Timeline::parse_values(text, source_name, Some(non_finite))
    }

    /// `decimal`: decimal values allowed, and what NaN and infinities are then.
    fn parse_values(
        text: &str,
        source_name: &str,
        decimal: Option<NonFinite>,
    ) -> Result<Timeline, TimelineError> {
        let non_finite = decimal.unwrap_or(NonFinite::Refuse);
        let decimal = decimal.is_some();
        let err = |line: usize, column: usize, problem: TimelineProblem| TimelineError::Syntax {
            file: source_name.to_string(),
            line,
            column,
            problem,
        };
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let mut lines = text
            .split('\n')
            .enumerate()
            .map(|(i, l)| (i + 1, l.strip_suffix('\r').unwrap_or(l)))
            .filter(|(_, l)| {
                let t = l.trim();
                !t.is_empty() && !t.starts_with('#')
            });

        let Some((header_line, header)) = lines.next() else {
            let last = text.split('\n').count().max(1);
            return Err(err(last, 1, TimelineProblem::NoHeader));
        };
        let cells = split_cells(header);
        let (time_col, time_name) = cells[0];
        if !time_name.eq_ignore_ascii_case("time") {
            let found = time_name.to_string();
            return Err(err(
                header_line,
                time_col,
                TimelineProblem::NotTime { found },
            ));
        }
        if cells.len() == 1 {
            let column = header.chars().count() + 1;
            return Err(err(header_line, column, TimelineProblem::NoSignals));
        }
        let mut columns: Vec<String> = Vec::with_capacity(cells.len() - 1);
        for (index, &(col, name)) in cells.iter().enumerate().skip(1) {
            if name.is_empty() {
                let problem = TimelineProblem::EmptyColumnName { index: index + 1 };
                return Err(err(header_line, col, problem));
            }
            if let Some(first) = columns.iter().position(|c| c == name) {
                let problem = TimelineProblem::DuplicateColumn {
                    name: name.to_string(),
                    first: first + 2,
                    second: index + 1,
                };
                return Err(err(header_line, col, problem));
            }
            columns.push(name.to_string());
        }

        let mut changes = vec![Vec::new(); columns.len()];
        let mut reals = vec![Vec::new(); columns.len()];
        let mut last: Option<(Duration, usize)> = None;
        let mut rows = 0;
        for (line_no, line) in lines {
            let cells = split_cells(line);
            if cells.len() != columns.len() + 1 {
                // Point at the first surplus cell, or at the end of a short row.
                let column = cells
                    .get(columns.len() + 1)
                    .map_or(line.chars().count() + 1, |c| c.0);
                let problem = TimelineProblem::CellCount {
                    expected: columns.len() + 1,
                    found: cells.len(),
                };
                return Err(err(line_no, column, problem));
            }
            let (time_col, time_text) = cells[0];
            if time_text.is_empty() {
                return Err(err(line_no, time_col, TimelineProblem::MissingTime));
            }
            let time = parse_duration(time_text)
                .map_err(|e| err(line_no, time_col, TimelineProblem::BadTime(e)))?;
            if let Some((previous, previous_line)) = last.filter(|(p, _)| time < *p) {
                let problem = TimelineProblem::DecreasingTime {
                    time,
                    previous,
                    previous_line,
                };
                return Err(err(line_no, time_col, problem));
            }
            last = Some((time, line_no));
            for (i, &(col, cell)) in cells[1..].iter().enumerate() {
                if cell.is_empty() {
                    continue;
                }
                if decimal {
                    let value = parse_decimal(cell).ok_or_else(|| {
                        let problem = TimelineProblem::BadDecimal {
                            column: columns[i].clone(),
                            text: cell.to_string(),
                        };
                        err(line_no, col, problem)
                    })?;
                    if !value.is_finite() && non_finite == NonFinite::Refuse {
                        let problem = TimelineProblem::NotFinite {
                            column: columns[i].clone(),
                            text: cell.to_string(),
                        };
                        return Err(err(line_no, col, problem));
                    }
                    reals[i].push((time, value));
                    // Whole numbers also as integers, for integer points.
                    if value.fract() == 0.0 && value.abs() < 9.0e15 {
                        changes[i].push((time, value as i64));
                    } else if let Some(v) = parse_value(cell) {
                        changes[i].push((time, v));
                    }
                    continue;
                }
                let value = parse_value(cell).ok_or_else(|| {
                    let problem = TimelineProblem::BadValue {
                        column: columns[i].clone(),
                        text: cell.to_string(),
                    };
                    err(line_no, col, problem)
                })?;
                changes[i].push((time, value));
            }
            rows += 1;
        }
        Ok(Timeline {
            source: source_name.to_string(),
            columns,
            changes,
            reals: decimal.then_some(reals),
            rows,
            end: last.map_or(Duration::ZERO, |(t, _)| t),
        })
    }

    /// Reads and parses a timeline file.
    pub fn read_file(path: impl AsRef<Path>) -> Result<Timeline, TimelineError> {
        let (text, file) = Timeline::read_text(path.as_ref())?;
        Timeline::parse(&text, &file)
    }

    /// Reads and parses a timeline file, accepting decimal values
    /// ([`Timeline::parse_decimal`]).
    pub fn read_file_decimal(
        path: impl AsRef<Path>,
        non_finite: NonFinite,
    ) -> Result<Timeline, TimelineError> {
        let (text, file) = Timeline::read_text(path.as_ref())?;
        Timeline::parse_decimal_with(&text, &file, non_finite)
    }

    fn read_text(path: &Path) -> Result<(String, String), TimelineError> {
        let file = path.display().to_string();
        let bytes = petriplc_files::read(path, petriplc_files::TIMELINE)?;
        let text = String::from_utf8(bytes).map_err(|e| not_utf8(&file, e))?;
        Ok((text, file))
    }

    /// With decimals allowed: every (time, value) a column is set to, whole or not.
    pub fn decimal_changes(&self, column: usize) -> Option<&[(Duration, f64)]> {
        self.reals.as_ref()?.get(column).map(Vec::as_slice)
    }

    /// With decimals allowed: the value of `column` at `t` (see [`Timeline::value_at`]).
    pub fn decimal_at(&self, column: usize, t: Duration) -> Option<f64> {
        let ch = self.decimal_changes(column)?;
        let n = ch.partition_point(|&(time, _)| time <= t);
        n.checked_sub(1).map(|i| ch[i].1)
    }

    /// Where the timeline came from, as given to [`Timeline::parse`].
    pub fn source(&self) -> &str {
        &self.source
    }
    /// The signal columns, without `time`.
    pub fn columns(&self) -> &[String] {
        &self.columns
    }
    pub fn column_index(&self, name: &str) -> Option<usize> {
        self.columns.iter().position(|c| c == name)
    }
    /// The number of data rows.
    pub fn rows(&self) -> usize {
        self.rows
    }
    /// The time of the last row (zero when there is none).
    pub fn end(&self) -> Duration {
        self.end
    }
    /// Every (time, value) a column is set to, in time order.
    pub fn changes(&self, column: usize) -> &[(Duration, i64)] {
        self.changes.get(column).map_or(&[], Vec::as_slice)
    }

    /// The value of `column` at time `t`: the last non-empty cell at or before `t`; `None`
    /// before the first row that sets it (or for a column that does not exist).
    pub fn value_at(&self, column: usize, t: Duration) -> Option<i64> {
        let ch = self.changes.get(column)?;
        let n = ch.partition_point(|&(time, _)| time <= t);
        n.checked_sub(1).map(|i| ch[i].1)
    }

    /// A cursor for reading every column at increasing times in amortised constant time.
    pub fn cursor(&self) -> TimelineCursor<'_> {
        TimelineCursor {
            timeline: self,
            state: CursorState::new(self),
        }
    }
}

impl fmt::Display for Timeline {
    /// Writes the timeline back as canonical CSV (empty cells where a value is unchanged).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "time")?;
        for c in &self.columns {
            write!(f, ",{c}")?;
        }
        writeln!(f)?;
        if let Some(reals) = &self.reals {
            return write_rows(f, reals);
        }
        write_rows(f, &self.changes)
    }
}

/// The rows of a timeline: at each time some column changes, its last value at that time.
fn write_rows<V: fmt::Display + Copy>(
    f: &mut fmt::Formatter<'_>,
    changes: &[Vec<(Duration, V)>],
) -> fmt::Result {
    {
        let mut next = vec![0; changes.len()];
        loop {
            let t = changes
                .iter()
                .zip(&next)
                .filter_map(|(ch, &i)| ch.get(i).map(|c| c.0))
                .min();
            let Some(t) = t else { break };
            write!(f, "{}", format_seconds(t))?;
            for (ch, i) in changes.iter().zip(next.iter_mut()) {
                // Several rows at one time: only the last value at that time is observable.
                let mut value = None;
                while let Some(&(_, v)) = ch.get(*i).filter(|c| c.0 == t) {
                    value = Some(v);
                    *i += 1;
                }
                match value {
                    Some(v) => write!(f, ",{v}")?,
                    None => write!(f, ",")?,
                }
            }
            writeln!(f)?;
        }
        Ok(())
    }
}

/// A timeline read at non-decreasing times.
#[derive(Clone, Debug)]
pub struct TimelineCursor<'a> {
    timeline: &'a Timeline,
    state: CursorState,
}

impl TimelineCursor<'_> {
    /// Moves to time `t` and returns every column's value there (see [`Timeline::value_at`]).
    /// Going back in time is allowed but restarts from the first row.
    pub fn seek(&mut self, t: Duration) -> &[Option<i64>] {
        self.state.seek(self.timeline, t)
    }
    /// The values at the last time sought (all `None` before the first seek).
    pub fn values(&self) -> &[Option<i64>] {
        &self.state.values
    }
}

/// A cursor's position without the borrow, for owners of the timeline (the simulation keeps
/// its timeline and cursor side by side).
#[derive(Clone, Debug, Default)]
pub(crate) struct CursorState {
    next: Vec<usize>,
    values: Vec<Option<i64>>,
    at: Option<Duration>,
    /// The earliest time a column changes after `at` (`None`: no change left).
    due: Option<Duration>,
    /// The columns the last seek set (in column order).
    pub(crate) changed: Vec<usize>,
}

impl CursorState {
    pub(crate) fn new(timeline: &Timeline) -> Self {
        CursorState {
            next: vec![0; timeline.columns.len()],
            values: vec![None; timeline.columns.len()],
            at: None,
            due: timeline
                .changes
                .iter()
                .filter_map(|c| c.first())
                .map(|c| c.0)
                .min(),
            changed: Vec::new(),
        }
    }

    /// Every column's value as of the last seek.
    pub(crate) fn values(&self) -> &[Option<i64>] {
        &self.values
    }

    pub(crate) fn seek(&mut self, timeline: &Timeline, t: Duration) -> &[Option<i64>] {
        if self.at.is_some_and(|at| t < at) || self.next.len() != timeline.columns.len() {
            *self = CursorState::new(timeline);
        }
        self.at = Some(t);
        self.changed.clear();
        // Between changes (most scans) nothing is to be read.
        if self.due.is_none_or(|due| t < due) {
            return &self.values;
        }
        let mut due = None::<Duration>;
        for (c, ((ch, next), value)) in timeline
            .changes
            .iter()
            .zip(&mut self.next)
            .zip(&mut self.values)
            .enumerate()
        {
            let before = *next;
            while let Some(&(time, v)) = ch.get(*next) {
                if time > t {
                    due = Some(due.map_or(time, |d| d.min(time)));
                    break;
                }
                *value = Some(v);
                *next += 1;
            }
            if *next != before {
                self.changed.push(c);
            }
        }
        self.due = due;
        &self.values
    }
}

/// Splits a line at commas into (1-based character column, trimmed cell) pairs.
fn split_cells(line: &str) -> Vec<(usize, &str)> {
    let mut out = Vec::new();
    let mut column = 1;
    for raw in line.split(',') {
        let lead = raw.len() - raw.trim_start().len();
        let cell = raw.trim();
        // An empty cell points at where it starts, a filled one at its first character.
        let offset = if cell.is_empty() {
            0
        } else {
            raw[..lead].chars().count()
        };
        out.push((column + offset, cell));
        column += raw.chars().count() + 1;
    }
    out
}

/// A whole value (see `parse_value`) or a decimal number (`f64`'s syntax: `1.5`, `-2e-3`,
/// `nan`, `inf`).
fn parse_decimal(cell: &str) -> Option<f64> {
    match parse_value(cell) {
        Some(v) => Some(v as f64),
        None => cell.parse().ok(),
    }
}

/// `0`/`1`, `TRUE`/`FALSE` in any case, or a (possibly signed) integer.
fn parse_value(cell: &str) -> Option<i64> {
    if cell.eq_ignore_ascii_case("true") {
        Some(1)
    } else if cell.eq_ignore_ascii_case("false") {
        Some(0)
    } else {
        cell.parse().ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn secs(s: f64) -> Duration {
        Duration::from_secs_f64(s)
    }

    /// Parses `input` and renders it as `columns | t: values` lines, or as the error message.
    fn check(input: &str, expect: &str) {
        let got = match Timeline::parse(input, "tl.csv") {
            Ok(tl) => {
                let mut s = tl.columns().join(",");
                let mut times: Vec<Duration> = tl.changes.iter().flatten().map(|c| c.0).collect();
                times.sort();
                times.dedup();
                for t in times {
                    let vals: Vec<String> = (0..tl.columns().len())
                        .map(|c| tl.value_at(c, t).map_or("-".into(), |v| v.to_string()))
                        .collect();
                    s += &format!(" | {}: {}", format_seconds(t), vals.join(","));
                }
                s
            }
            Err(e) => e.to_string(),
        };
        assert_eq!(got, expect, "input:\n{input}");
    }

    #[test]
    fn parses_values_times_and_holds() {
        check(
            "# keys of seed 003\n\
             time, A ,B,C\n\
             \n\
             0,0,FALSE,-3\n\
             T#1.5s, true ,,+7\n\
             \t# comment after data\n\
             2,,1,\n",
            "A,B,C | 0: 0,0,-3 | 1.5: 1,0,7 | 2: 1,1,7",
        );
        check("time,A\r\n0.25,1\r\n", "A | 0.25: 1");
        check("\u{feff}TIME,A\n1,0\n1,1\n", "A | 1: 1");
        check("time,A\n", "A");
        check("time,A,B\n0,,\n3,5,\n", "A,B | 3: 5,-");
    }

    #[test]
    fn reports_every_problem_with_position() {
        check(
            "",
            "tl.csv:1:1: the timeline has no header; its first line must be `time,SIG1,SIG2,...`",
        );
        check(
            "# only\n\n# comments\n",
            "tl.csv:4:1: the timeline has no header; its first line must be `time,SIG1,SIG2,...`",
        );
        check(
            "t,A\n",
            "tl.csv:1:1: the first header cell is `t`; it must be `time` (header: `time,SIG1,SIG2,...`)",
        );
        check(
            "time\n0\n",
            "tl.csv:1:5: the header names no signals; add one column per signal: `time,SIG1,SIG2,...`",
        );
        check(
            "time,A,,B\n",
            "tl.csv:1:8: header cell 3 is empty; name every column after the signal it drives",
        );
        check(
            "time,A,B, A\n",
            "tl.csv:1:11: column `A` appears twice in the header (cells 2 and 4); give each signal one column",
        );
        check(
            "time,A,B\n0,1,0,1\n",
            "tl.csv:2:7: the row has 4 cells but the header has 3; add or remove commas (an empty cell keeps the previous value)",
        );
        check(
            "time,A,B\n0,1\n",
            "tl.csv:2:4: the row has 2 cells but the header has 3; add or remove commas (an empty cell keeps the previous value)",
        );
        check(
            "time,A\n ,1\n",
            "tl.csv:2:1: the time cell is empty; every row starts with its time in seconds (`1.5`) or as an IEC literal (`T#1.5s`)",
        );
        check(
            "time,A\nsoon,1\n",
            "tl.csv:2:1: bad time: `soon` is not a duration: write a number with a unit (`30s`, `500ms`, `1m30s`), plain seconds (`1.5`) or an IEC literal (`T#1m30s`)",
        );
        check(
            "time,A\n-1,1\n",
            "tl.csv:2:1: bad time: `-1` is not a duration: write a number with a unit (`30s`, `500ms`, `1m30s`), plain seconds (`1.5`) or an IEC literal (`T#1m30s`)",
        );
        check(
            "time,A,B\n0,1,  yes\n",
            "tl.csv:2:7: `yes` is not a value for `B`: write 0/1, TRUE/FALSE or an integer, or leave the cell empty to keep the previous value",
        );
        check(
            "time,A\n0,1.5\n",
            "tl.csv:2:3: `1.5` is not a value for `A`: write 0/1, TRUE/FALSE or an integer, or leave the cell empty to keep the previous value",
        );
        check(
            "time,A\n0,99999999999999999999\n",
            "tl.csv:2:3: `99999999999999999999` is not a value for `A`: write 0/1, TRUE/FALSE or an integer, or leave the cell empty to keep the previous value",
        );
        check(
            "time,A\n0,0\n# gap\n2,1\nT#1s,0\n",
            "tl.csv:5:1: time 1s comes before 2s on line 4; sort the rows by time (equal times are allowed)",
        );
    }

    #[test]
    fn a_file_that_is_not_utf8_is_refused_at_its_line() {
        let path = std::env::temp_dir().join(format!("petriplc-{}-latin1.csv", std::process::id()));
        std::fs::write(&path, b"time,A\n0,1\n1,caf\xe9\n").unwrap();
        let e = Timeline::read_file(&path).unwrap_err();
        let _ = std::fs::remove_file(&path);
        assert_eq!(e.position(), Some((3, 6)));
        assert_eq!(e.problem(), Some(&TimelineProblem::NotUtf8 { byte: 0xe9 }));
        assert!(e.to_string().ends_with(
            "latin1.csv:3:6: byte 0xe9 is not UTF-8 text; save the timeline as UTF-8 (plain ASCII will do)"
        ), "{e}");
    }

    #[test]
    fn decimals_for_float_points() {
        let tl =
            Timeline::parse_decimal("time,A,B\n0,1.5,2\n1,0.25,-2e-3\n2,-7,3.0\n", "d").unwrap();
        assert_eq!(tl.decimal_at(0, secs(0.5)), Some(1.5));
        assert_eq!(tl.decimal_at(0, secs(1.0)), Some(0.25));
        assert_eq!(tl.decimal_at(0, secs(2.0)), Some(-7.0));
        assert_eq!(tl.decimal_at(1, secs(1.0)), Some(-0.002));
        // Whole values, however written, are also there as integers.
        assert_eq!(tl.changes(1), &[(secs(0.0), 2), (secs(2.0), 3)]);
        assert_eq!(tl.decimal_changes(7), None);
        assert_eq!(tl.to_string(), "time,A,B\n0,1.5,2\n1,0.25,-0.002\n2,-7,3\n");
        let e = Timeline::parse_decimal("time,A\n0,warm\n", "d").unwrap_err();
        assert_eq!(e.to_string(), "d:2:3: `warm` is not a value for `A`: write 0/1, TRUE/FALSE, an integer or a decimal number (1.5, -2e-3), or leave the cell empty to keep the previous value");
        // Issue 27: NaN and infinities, however spelled, are refused where they are written.
        for cell in ["nan", "NaN", "inf", "-inf", "+Infinity", "1e999"] {
            let e = Timeline::parse_decimal(&format!("time,A\n0,1\n1,{cell}\n"), "d").unwrap_err();
            assert_eq!(
                e.to_string(),
                format!("d:3:3: `{cell}` for `A` is not a finite number: the PLC refuses NaN and infinities from outside, so that no point ever holds one (docs/runtime.md, \"What the PLC does with bad values\"); write a number")
            );
        }
        // The simulation's timelines stay whole.
        assert!(Timeline::parse("time,A\n0,1.5\n", "d").is_err());
        assert_eq!(
            Timeline::parse("time,A\n0,1\n", "d")
                .unwrap()
                .decimal_at(0, secs(0.0)),
            None
        );
    }

    #[test]
    fn error_accessors_and_io() {
        let e = Timeline::parse("time,A\n0,x\n", "f").unwrap_err();
        assert_eq!(e.position(), Some((2, 3)));
        assert!(matches!(
            e.problem(),
            Some(TimelineProblem::BadValue { .. })
        ));
        let e = Timeline::read_file("/nonexistent/petriplc/tl.csv").unwrap_err();
        assert!(e.problem().is_none());
        assert!(petriplc_testnet::error_chain(&e)
            .starts_with("cannot read /nonexistent/petriplc/tl.csv: no such file"));
    }

    #[test]
    fn value_at_holds_until_the_next_row() {
        let tl = Timeline::parse("time,A,B\n1,1,\n2,0,5\n2,1,\n4,,6\n", "x").unwrap();
        assert_eq!(tl.end(), secs(4.0));
        assert_eq!(tl.rows(), 4);
        assert_eq!(tl.column_index("B"), Some(1));
        assert_eq!(tl.value_at(0, secs(0.5)), None);
        assert_eq!(tl.value_at(0, secs(1.0)), Some(1));
        assert_eq!(tl.value_at(0, secs(1.999)), Some(1));
        // Two rows at one time: the later one is what holds.
        assert_eq!(tl.value_at(0, secs(2.0)), Some(1));
        assert_eq!(tl.value_at(1, secs(3.0)), Some(5));
        assert_eq!(tl.value_at(1, secs(100.0)), Some(6));
        assert_eq!(tl.value_at(7, secs(1.0)), None);
        assert_eq!(tl.to_string(), "time,A,B\n1,1,\n2,1,5\n4,,6\n");
    }

    #[test]
    fn cursor_agrees_with_value_at() {
        let tl = Timeline::parse("time,A,B\n0,1,\n0.3,0,5\n0.3,1,\n0.7,,6\n", "x").unwrap();
        let mut c = tl.cursor();
        assert_eq!(c.values(), &[None, None]);
        let times: Vec<Duration> = (0..12).map(|k| Duration::from_millis(100) * k).collect();
        for &t in &times {
            let expect: Vec<Option<i64>> = (0..2).map(|col| tl.value_at(col, t)).collect();
            assert_eq!(c.seek(t), expect.as_slice(), "at {t:?}");
        }
        // Going back restarts rather than giving stale values.
        assert_eq!(c.seek(secs(0.1)), &[Some(1), None]);
    }
}
