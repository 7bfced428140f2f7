//! The recording of matiec's results (testdata/matiec/oscat_basic.txt): numbers only, one
//! block per POU, so CI compares petriplc with matiec without matiec.
//!
//! ```text
//! # header lines (matiec commit, generator, seed, scans, cycle)
//! @ oscat_basic/ACOSH.st ACOSH        a POU: its file and name
//! = WR;WO_Y                           the wrapper's columns
//! 0.5;1                               one row per scan, cells as `super::cell` prints them
//! ! stopped after scan 12: signal 8   C stopped there (the rows before it compare)
//! @ oscat_basic/AIN.st AIN
//! - matiec refuses: …                 not run by matiec, and why
//! ```

use std::fmt::Write as _;

/// What matiec made of one POU.
#[derive(Clone, Debug, PartialEq)]
pub enum Outcome {
    Rows {
        columns: Vec<String>,
        rows: Vec<Vec<String>>,
        /// Why C stopped before the last scan.
        stopped: Option<String>,
    },
    /// Not comparable: the reason.
    NotRun(String),
}

#[derive(Clone, Debug, PartialEq)]
pub struct Recorded {
    pub file: String,
    pub pou: String,
    pub outcome: Outcome,
}

pub fn write(header: &[String], pous: &[Recorded]) -> String {
    let mut out = String::new();
    for h in header {
        let _ = writeln!(out, "# {h}");
    }
    for p in pous {
        let _ = writeln!(out, "@ {} {}", p.file, p.pou);
        match &p.outcome {
            Outcome::NotRun(why) => {
                let _ = writeln!(out, "- {}", one_line(why));
            }
            Outcome::Rows {
                columns,
                rows,
                stopped,
            } => {
                let _ = writeln!(out, "= {}", columns.join(";"));
                for r in rows {
                    let _ = writeln!(out, "{}", r.join(";"));
                }
                if let Some(s) = stopped {
                    let _ = writeln!(out, "! {}", one_line(s));
                }
            }
        }
    }
    out
}

fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// The header lines and the POUs of a recording.
pub fn read(text: &str) -> Result<(Vec<String>, Vec<Recorded>), String> {
    let mut header = Vec::new();
    let mut pous: Vec<Recorded> = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let bad = || format!("line {}: `{line}`", n + 1);
        if let Some(h) = line.strip_prefix("# ") {
            header.push(h.to_string());
        } else if let Some(rest) = line.strip_prefix("@ ") {
            let (file, pou) = rest.split_once(' ').ok_or_else(bad)?;
            pous.push(Recorded {
                file: file.into(),
                pou: pou.into(),
                outcome: Outcome::NotRun(String::new()),
            });
        } else {
            let p = pous.last_mut().ok_or_else(bad)?;
            if let Some(why) = line.strip_prefix("- ") {
                p.outcome = Outcome::NotRun(why.into());
            } else if let Some(cols) = line.strip_prefix("= ") {
                p.outcome = Outcome::Rows {
                    columns: cols.split(';').map(String::from).collect(),
                    rows: Vec::new(),
                    stopped: None,
                };
            } else if let Outcome::Rows { rows, stopped, .. } = &mut p.outcome {
                match line.strip_prefix("! ") {
                    Some(s) => *stopped = Some(s.into()),
                    None => rows.push(line.split(';').map(String::from).collect()),
                }
            } else {
                return Err(bad());
            }
        }
    }
    Ok((header, pous))
}
