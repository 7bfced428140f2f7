//! Which refused messages the module logs: the first refusal on a topic, the next one only
//! after a good message on that topic has come in between, and never more than one line per
//! topic every [`LOG_INTERVAL`]; the others are only counted (`rejected` in the status). A
//! peer publishing garbage at 1 kHz logs one line, one alternating garbage and good values
//! one line every 10 s.

use std::collections::HashMap;
use std::time::{Duration, Instant};

/// The least time between two lines about one topic.
pub const LOG_INTERVAL: Duration = Duration::from_secs(10);

/// The refusals of each topic the module has refused something on (subscribed topics only,
/// so a bounded set).
#[derive(Debug, Default)]
pub struct Refusals {
    topics: HashMap<String, Topic>,
}

#[derive(Debug, Default)]
struct Topic {
    /// Logged since the last good message: further refusals are only counted.
    quiet: bool,
    last_line: Option<Instant>,
    /// Refusals since the last line.
    unlogged: u64,
}

impl Refusals {
    /// A message on `topic` refused at `now`: `Some(n)` if this one is to be logged, `n`
    /// being the refusals on the topic left unlogged since its last line.
    pub fn refused(&mut self, topic: &str, now: Instant) -> Option<u64> {
        let t = match self.topics.get_mut(topic) {
            Some(t) => t,
            None => self.topics.entry(topic.to_string()).or_default(),
        };
        let due = !t.quiet
            && t.last_line
                .is_none_or(|last| now.saturating_duration_since(last) >= LOG_INTERVAL);
        if due {
            t.quiet = true;
            t.last_line = Some(now);
            Some(std::mem::take(&mut t.unlogged))
        } else {
            t.unlogged += 1;
            None
        }
    }

    /// A good message on `topic`: its next refusal is logged again (LOG_INTERVAL allowing).
    pub fn accepted(&mut self, topic: &str) {
        if let Some(t) = self.topics.get_mut(topic) {
            t.quiet = false;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_line_per_burst_and_per_interval() {
        let t0 = Instant::now();
        let s = Duration::from_secs;
        let mut r = Refusals::default();
        // A burst: the first logged, the rest counted.
        assert_eq!(r.refused("a", t0), Some(0));
        for _ in 0..1000 {
            assert_eq!(r.refused("a", t0 + s(1)), None);
        }
        // Another topic has its own line.
        assert_eq!(r.refused("b", t0 + s(1)), Some(0));
        // Long after, still quiet: no good message came in between.
        assert_eq!(r.refused("a", t0 + s(60)), None);
        // A good message re-arms the line; the next refusal says how many went unlogged.
        r.accepted("a");
        assert_eq!(r.refused("a", t0 + s(61)), Some(1001));
        // Garbage and good values alternating: one line per LOG_INTERVAL.
        let mut lines = Vec::new();
        for i in 0..100u64 {
            r.accepted("a");
            let at = s(62) + Duration::from_millis(i * 100);
            if let Some(unlogged) = r.refused("a", t0 + at) {
                lines.push((at, unlogged));
            }
        }
        // 10 s after the line at 61 s, with the 90 refusals between.
        assert_eq!(lines, [(s(71), 90)], "10 s of alternating values");
        // A good message on another topic re-arms nothing here.
        r.accepted("b");
        assert_eq!(r.refused("a", t0 + s(200)), Some(9));
        assert_eq!(r.refused("a", t0 + s(300)), None);
    }
}
