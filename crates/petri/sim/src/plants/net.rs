//! A second net as the process model (seed 004): the plant is itself a Petri net with inputs
//! and outputs, run by its own scanner at the controller's scan times.

use std::time::Duration;

use petriplc_net::{Net, ScanOptions, Scanner, SignalId};

use crate::plant::{Plant, PlantError};

/// A plant whose inputs are the model net's input signals and whose outputs are its output
/// signals, in declaration order.
#[derive(Clone, Debug)]
pub struct NetPlant<'n> {
    name: String,
    scanner: Scanner<'n>,
    signals: Vec<i64>,
    inputs: Vec<SignalId>,
    outputs: Vec<SignalId>,
}

impl<'n> NetPlant<'n> {
    /// The model at its initial marking; `options` are its own, not the controller's.
    pub fn new(net: &'n Net, options: ScanOptions) -> Self {
        let name = [net.name.as_str(), net.id.as_str()]
            .into_iter()
            .find(|n| !n.trim().is_empty())
            .unwrap_or("process model")
            .to_string();
        NetPlant {
            name,
            scanner: Scanner::incremental(net, options),
            signals: vec![0; net.signals().len()],
            inputs: net.inputs().collect(),
            outputs: net.outputs().collect(),
        }
    }
    pub fn scanner(&self) -> &Scanner<'n> {
        &self.scanner
    }
    /// The model's signal values, indexed by its own [`SignalId`]s.
    pub fn signals(&self) -> &[i64] {
        &self.signals
    }
}

impl Plant for NetPlant<'_> {
    fn name(&self) -> &str {
        &self.name
    }
    fn inputs(&self) -> Vec<String> {
        let net = self.scanner.net();
        self.inputs
            .iter()
            .map(|&s| net.signal(s).name.clone())
            .collect()
    }
    fn outputs(&self) -> Vec<String> {
        let net = self.scanner.net();
        self.outputs
            .iter()
            .map(|&s| net.signal(s).name.clone())
            .collect()
    }

    fn step(
        &mut self,
        now: Duration,
        inputs: &[i64],
        outputs: &mut [i64],
    ) -> Result<(), PlantError> {
        for (&s, &v) in self.inputs.iter().zip(inputs) {
            self.signals[s.index()] = v;
        }
        self.scanner
            .scan(now, &mut self.signals)
            .map_err(|source| PlantError::Scan {
                plant: self.name.clone(),
                source,
            })?;
        for (&s, out) in self.outputs.iter().zip(outputs.iter_mut()) {
            *out = self.signals[s.index()];
        }
        Ok(())
    }

    fn summary(&self) -> String {
        let net = self.scanner.net();
        let m = self.scanner.marking();
        let marked: Vec<String> = net
            .place_ids()
            .filter(|&p| m[p] > 0)
            .map(|p| match m[p] {
                1 => net.place_label(p).to_string(),
                n => format!("{}({n})", net.place_label(p)),
            })
            .collect();
        if marked.is_empty() {
            format!("{}, no place marked", self.name)
        } else {
            format!("{}, marking {}", self.name, marked.join(" "))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use petriplc_testnet::net;

    /// Steps the model once per input vector (one per second) and renders each step's outputs
    /// and the final summary.
    fn check(model: &Net, steps: &[&[i64]], expect: &str) {
        let mut plant = NetPlant::new(model, ScanOptions::of(model));
        let mut out = vec![0; plant.outputs().len()];
        let mut got = Vec::new();
        for (k, inputs) in steps.iter().enumerate() {
            plant
                .step(Duration::from_secs(k as u64), inputs, &mut out)
                .unwrap();
            got.push(format!("{out:?}"));
        }
        got.push(plant.summary());
        assert_eq!(got.join(" "), expect);
    }

    #[test]
    fn runs_the_model_with_its_own_signals() {
        // A cylinder: extends while `push` is on, reports `extended` one scan later, retracts
        // when it goes off.
        let model = net("
            p retracted 1 >home
            p extended 0 >extended
            t out retracted -> extended if push
            t back extended -> retracted if NOT push
        ");
        let plant = NetPlant::new(&model, ScanOptions::of(&model));
        assert_eq!(plant.name(), "test");
        assert_eq!(plant.inputs(), ["push"]);
        assert_eq!(plant.outputs(), ["home", "extended"]);
        check(
            &model,
            &[&[0], &[1], &[1], &[0]],
            "[1, 0] [0, 1] [0, 1] [1, 0] test, marking retracted",
        );
        check(&model, &[&[1]], "[0, 1] test, marking extended");
    }

    #[test]
    fn uses_its_own_timers_and_reports_tokens() {
        // A pair of parts arrives after 2 s of model time.
        let model = net("
            p src 1
            p parts 0 >part
            t arrive src@2 -> parts*2
        ");
        check(
            &model,
            &[&[], &[], &[], &[]],
            "[0] [0] [1] [1] test, marking parts(2)",
        );
    }

    #[test]
    fn scan_errors_name_the_plant() {
        let model = net("
            evolve until-stable
            p a 1
            t loop a -> a
        ");
        let mut plant = NetPlant::new(&model, ScanOptions::of(&model));
        let e = plant.step(Duration::ZERO, &[], &mut []).unwrap_err();
        let text = petriplc_testnet::error_chain(&e);
        assert!(
            text.starts_with("plant `test`: the net is unstable at t=0s"),
            "{text}"
        );
    }
}
