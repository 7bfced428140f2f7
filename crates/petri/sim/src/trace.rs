//! The record of a simulation run: one row per scan in which something changed, and its CSV
//! form, which is byte-for-byte deterministic so runs can be diffed and golden-tested.

use std::borrow::Cow;
use std::fmt::Write as _;
use std::io::{self, Write};
use std::time::Duration;

use petriplc_net::time::format_seconds;
use petriplc_net::{Net, SignalType};

/// The state after one scan.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct TraceRow {
    pub time: Duration,
    /// Controller input values, in the order of [`Trace::inputs`].
    pub inputs: Vec<i64>,
    /// Controller output values, in the order of [`Trace::outputs`].
    pub outputs: Vec<i64>,
    /// Tokens per place, in the order of [`Trace::places`].
    pub marking: Vec<u32>,
    /// Labels of the transitions fired by the scan, in firing order.
    pub fired: Vec<String>,
    /// The plant's observed outputs, in the order of [`Trace::plant`].
    pub plant: Vec<i64>,
}

/// A run's recorded rows and the names that give their columns meaning.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Trace {
    /// The controller net's name, else its id (for the plot's title).
    pub net: String,
    /// The scan period of the run (for the plot's title; zero when unknown).
    pub period: Duration,
    /// Input signal names: those a timeline drives in its column order, then those a plant
    /// drives, then the rest in declaration order (see [`Trace::order_inputs`]).
    pub inputs: Vec<String>,
    pub input_types: Vec<SignalType>,
    /// Output signal names, in declaration order.
    pub outputs: Vec<String>,
    pub output_types: Vec<SignalType>,
    /// Place labels ([`Net::place_label`]).
    pub places: Vec<String>,
    /// Per output, in the order of [`Trace::outputs`]: the places that drive it (indices into
    /// [`Trace::places`]). The plot leaves out a place's lane when the place alone drives an
    /// output and its marking equals that output throughout.
    pub output_places: Vec<Vec<usize>>,
    /// Plant outputs that drive no controller input, observed only (the turntable's angle,
    /// its error outputs): plotted, not written to the CSV, which is the controller's trace.
    pub plant: Vec<String>,
    /// The first scan's row, then one for every scan whose inputs, outputs or marking changed
    /// or in which something fired.
    pub rows: Vec<TraceRow>,
    /// The time of the last scan made (rows stop at the last change, the run may go on).
    pub end: Duration,
    /// How many scans were made.
    pub scans: u64,
}

impl Trace {
    /// An empty trace with the columns of `net`.
    pub fn new(net: &Net) -> Self {
        let (inputs, input_types) = net
            .inputs()
            .map(|s| (net.signal(s).name.clone(), net.signal(s).ty))
            .unzip();
        let (outputs, output_types) = net
            .outputs()
            .map(|s| (net.signal(s).name.clone(), net.signal(s).ty))
            .unzip();
        let output_places = net
            .outputs()
            .map(|o| {
                net.place_ids()
                    .enumerate()
                    .filter(|&(_, p)| net.place(p).output == Some(o))
                    .map(|(i, _)| i)
                    .collect()
            })
            .collect();
        Trace {
            net: if net.name.is_empty() {
                net.id.clone()
            } else {
                net.name.clone()
            },
            output_places,
            inputs,
            input_types,
            outputs,
            output_types,
            places: net
                .place_ids()
                .map(|p| net.place_label(p).to_string())
                .collect(),
            ..Trace::default()
        }
    }

    /// Puts the inputs named in `first` first, in that order; the others keep their order.
    /// Returns the permutation applied (new position → old position), for the rows' values.
    /// Only for a trace with no rows yet.
    pub fn order_inputs(&mut self, first: &[&str]) -> Vec<usize> {
        debug_assert!(self.rows.is_empty(), "reorder the columns before recording");
        let mut order: Vec<usize> = Vec::with_capacity(self.inputs.len());
        for name in first {
            if let Some(i) = self.inputs.iter().position(|n| n == name) {
                if !order.contains(&i) {
                    order.push(i);
                }
            }
        }
        for i in 0..self.inputs.len() {
            if !order.contains(&i) {
                order.push(i);
            }
        }
        self.inputs = order.iter().map(|&i| self.inputs[i].clone()).collect();
        self.input_types = order.iter().map(|&i| self.input_types[i]).collect();
        order
    }

    /// Notes one scan; keeps a copy of `row` when it is the first or differs from the last
    /// kept one (or fired something). Returns whether it was kept.
    pub fn record(&mut self, row: &TraceRow) -> bool {
        self.scans += 1;
        self.end = self.end.max(row.time);
        let keep = self.rows.last().is_none_or(|last| {
            !row.fired.is_empty()
                || last.inputs != row.inputs
                || last.outputs != row.outputs
                || last.marking != row.marking
                || last.plant != row.plant
        });
        if keep {
            self.rows.push(row.clone());
        }
        keep
    }

    /// The rows the CSV shows: the first, then those where an input, output or marking
    /// changed or something fired (rows kept only for a plant change are left out: the CSV,
    /// the controller's trace, has no columns for them).
    pub fn csv_row_iter(&self) -> impl Iterator<Item = &TraceRow> + '_ {
        self.rows.iter().enumerate().filter_map(move |(i, row)| {
            let shown = match i.checked_sub(1).map(|j| &self.rows[j]) {
                None => true,
                Some(prev) => {
                    !row.fired.is_empty()
                        || prev.inputs != row.inputs
                        || prev.outputs != row.outputs
                        || prev.marking != row.marking
                }
            };
            shown.then_some(row)
        })
    }

    /// Notes a scan at `time` whose row would equal the last one kept (nothing changed and
    /// nothing fired): what [`Trace::record`] does with such a row, without the row.
    pub fn count(&mut self, time: Duration) {
        debug_assert!(!self.rows.is_empty(), "the first scan is always recorded");
        self.scans += 1;
        self.end = self.end.max(time);
    }

    /// How many data lines [`Trace::write_csv`] writes.
    pub fn csv_rows(&self) -> usize {
        self.csv_row_iter().count()
    }

    /// Writes `time,in:<input>…,<output>…,m:<place>…,fired`, one line per
    /// [`Trace::csv_row_iter`] row (the first scan, then every scan in which an input, output
    /// or marking changed or something fired), with `\n` line ends and fields quoted only where CSV needs it. Boolean signals are
    /// written 0 or 1.
    pub fn write_csv(&self, mut w: impl Write) -> io::Result<()> {
        let mut line = String::from("time");
        for name in &self.inputs {
            push_field(&mut line, &format!("in:{name}"));
        }
        for name in &self.outputs {
            push_field(&mut line, name);
        }
        for place in &self.places {
            push_field(&mut line, &format!("m:{place}"));
        }
        push_field(&mut line, "fired");
        line.push('\n');
        w.write_all(line.as_bytes())?;
        for row in self.csv_row_iter() {
            line.clear();
            line.push_str(&format_seconds(row.time));
            let signals = row
                .inputs
                .iter()
                .zip(&self.input_types)
                .chain(row.outputs.iter().zip(&self.output_types));
            for (v, ty) in signals {
                let v = match ty {
                    SignalType::Bool => i64::from(*v != 0),
                    SignalType::Int => *v,
                };
                // Into the line's buffer: no string per field.
                let _ = write!(line, ",{v}");
            }
            for m in &row.marking {
                let _ = write!(line, ",{m}");
            }
            push_field(&mut line, &row.fired.join(" "));
            line.push('\n');
            w.write_all(line.as_bytes())?;
        }
        w.flush()
    }

    /// The controller's inputs as a timeline in `petriplc sim --inputs`'s format: `time` and
    /// one column per input, a row for the first scan and for every scan whose inputs
    /// changed. Replaying it drives the controller alone through the same scans — the
    /// closed loop opened, e.g. for the generated C.
    pub fn write_inputs_csv(&self, mut w: impl Write) -> io::Result<()> {
        let mut line = String::from("time");
        for name in &self.inputs {
            push_field(&mut line, name);
        }
        line.push('\n');
        w.write_all(line.as_bytes())?;
        let mut last: Option<&Vec<i64>> = None;
        for row in &self.rows {
            if last == Some(&row.inputs) {
                continue;
            }
            last = Some(&row.inputs);
            line.clear();
            line.push_str(&format_seconds(row.time));
            for v in &row.inputs {
                line.push(',');
                line.push_str(&v.to_string());
            }
            line.push('\n');
            w.write_all(line.as_bytes())?;
        }
        w.flush()
    }

    /// The CSV as a string (see [`Trace::write_csv`]).
    pub fn to_csv(&self) -> String {
        let mut out = Vec::new();
        // Writing to a Vec cannot fail.
        let _ = self.write_csv(&mut out);
        String::from_utf8_lossy(&out).into_owned()
    }
}

/// Appends `,field`, quoted as RFC 4180 asks only when it holds a comma, quote or line break.
fn push_field(line: &mut String, field: &str) {
    line.push(',');
    line.push_str(&quote(field));
}

fn quote(field: &str) -> Cow<'_, str> {
    if field.contains([',', '"', '\n', '\r']) {
        Cow::Owned(format!("\"{}\"", field.replace('"', "\"\"")))
    } else {
        Cow::Borrowed(field)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use petriplc_testnet::net;

    fn row(ms: u64, inputs: &[i64], outputs: &[i64], marking: &[u32], fired: &[&str]) -> TraceRow {
        TraceRow {
            time: Duration::from_millis(ms),
            inputs: inputs.to_vec(),
            outputs: outputs.to_vec(),
            marking: marking.to_vec(),
            fired: fired.iter().map(|s| s.to_string()).collect(),
            plant: vec![],
        }
    }

    /// Records `rows` as consecutive scans; compares which were kept (by time in ms) and the
    /// exact CSV.
    fn check(trace: &mut Trace, rows: &[TraceRow], expect_kept: &[u64], expect_csv: &str) {
        for r in rows {
            trace.record(r);
        }
        let kept: Vec<u64> = trace
            .rows
            .iter()
            .map(|r| r.time.as_millis() as u64)
            .collect();
        assert_eq!(kept, expect_kept);
        assert_eq!(trace.to_csv(), expect_csv);
        assert_eq!(trace.scans, rows.len() as u64);
    }

    fn lamp_trace() -> Trace {
        let n = net("
            s level out int
            p off 1 >lamp
            p on 0
            p count 0 >level
            t t_on off -> on count if button
            t t_off on -> off if NOT button
        ");
        Trace::new(&n)
    }

    #[test]
    fn keeps_changes_and_writes_exact_csv() {
        let mut trace = lamp_trace();
        assert_eq!(trace.inputs, ["button"]);
        assert_eq!(trace.outputs, ["level", "lamp"]);
        assert_eq!(trace.places, ["off", "on", "count"]);
        check(
            &mut trace,
            &[
                row(0, &[0], &[0, 1], &[1, 0, 0], &[]),
                row(10, &[0], &[0, 1], &[1, 0, 0], &[]),
                // An input change alone is a row: it may tell why nothing fired.
                row(20, &[1], &[0, 1], &[1, 0, 0], &[]),
                row(30, &[1], &[1, 0], &[0, 1, 1], &["t_on"]),
                row(40, &[1], &[1, 0], &[0, 1, 1], &[]),
                // Firing with no net change of marking still shows.
                row(50, &[1], &[1, 0], &[0, 1, 1], &["t_off", "t_on"]),
                row(60, &[0], &[1, 0], &[1, 0, 1], &["t_off"]),
                row(70, &[0], &[1, 0], &[1, 0, 1], &[]),
            ],
            &[0, 20, 30, 50, 60],
            "time,in:button,level,lamp,m:off,m:on,m:count,fired\n\
             0,0,0,1,1,0,0,\n\
             0.02,1,0,1,1,0,0,\n\
             0.03,1,1,0,0,1,1,t_on\n\
             0.05,1,1,0,0,1,1,t_off t_on\n\
             0.06,0,1,0,1,0,1,t_off\n",
        );
        assert_eq!(trace.end, Duration::from_millis(70));
        assert_eq!(trace.csv_rows(), 5);
    }

    #[test]
    fn inputs_are_written_as_a_timeline() {
        let mut trace = lamp_trace();
        for r in [
            row(0, &[0], &[0, 1], &[1, 0, 0], &[]),
            row(10, &[1], &[0, 1], &[1, 0, 0], &[]),
            row(20, &[1], &[1, 0], &[0, 1, 1], &["t_on"]),
            row(30, &[0], &[1, 0], &[0, 1, 1], &[]),
        ] {
            trace.record(&r);
        }
        let mut out = Vec::new();
        trace.write_inputs_csv(&mut out).unwrap();
        assert_eq!(
            String::from_utf8(out).unwrap(),
            "time,button\n0,0\n0.01,1\n0.03,0\n"
        );
    }

    /// A plant value that changes keeps the row for the plot, not for the CSV.
    #[test]
    fn plant_changes_are_kept_but_not_written() {
        let mut trace = lamp_trace();
        trace.plant = vec!["level".into()];
        let with = |ms: u64, level: i64| TraceRow {
            plant: vec![level],
            ..row(ms, &[0], &[0, 1], &[1, 0, 0], &[])
        };
        check(
            &mut trace,
            &[with(0, 0), with(10, 5), with(20, 5), with(30, 7)],
            &[0, 10, 30],
            "time,in:button,level,lamp,m:off,m:on,m:count,fired\n0,0,0,1,1,0,0,\n",
        );
    }

    #[test]
    fn the_first_row_is_always_written() {
        let mut trace = lamp_trace();
        check(
            &mut trace,
            &[row(0, &[1], &[0, 1], &[1, 0, 0], &[])],
            &[0],
            "time,in:button,level,lamp,m:off,m:on,m:count,fired\n0,1,0,1,1,0,0,\n",
        );
        check(&mut Trace::default(), &[], &[], "time,fired\n");
    }

    #[test]
    fn quotes_only_when_needed() {
        let mut trace = Trace {
            inputs: vec!["x,y".into()],
            input_types: vec![SignalType::Int],
            outputs: vec!["Y".into()],
            output_types: vec![SignalType::Bool],
            places: vec!["a,b".into(), "say \"hi\"".into()],
            ..Trace::default()
        };
        check(
            &mut trace,
            &[row(1500, &[-3], &[5], &[0, 2], &["t,1", "t2"])],
            &[1500],
            "time,\"in:x,y\",Y,\"m:a,b\",\"m:say \"\"hi\"\"\",fired\n1.5,-3,1,0,2,\"t,1 t2\"\n",
        );
    }
}

#[cfg(test)]
mod order_tests {
    use super::*;
    use petriplc_testnet::net;

    #[test]
    fn inputs_go_in_the_order_asked_then_the_rest() {
        let n = net("s a in bool\ns b in int\ns c in bool\np x 0");
        let mut trace = Trace::new(&n);
        assert_eq!(trace.inputs, ["a", "b", "c"]);
        assert_eq!(trace.order_inputs(&["c", "nope", "a", "c"]), [2, 0, 1]);
        assert_eq!(trace.inputs, ["c", "a", "b"]);
        assert_eq!(
            trace.input_types,
            [SignalType::Bool, SignalType::Bool, SignalType::Int]
        );
        assert_eq!(trace.net, "test");
    }
}
