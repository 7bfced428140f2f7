//! Keys bound to points (MatPLC's keyboard module): what a key is, and what pressing it
//! does to its point: a point the vitrine owns is written, any other point is forced (and
//! released by the Delete key, or by the end of a pulse).

use std::fmt;
use std::time::Duration;

use petriplc_config::{Origin, PointValue};
use petriplc_runtime::image::{Handle, ModuleMap};
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyEventKind, KeyModifiers};

/// A key as `key` rows name it. Letters are kept in lower case: a binding matches either
/// case, so Caps Lock or Shift does not silently disable it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KeySpec {
    Char(char),
    Named(Named),
}

/// The keys with names (`key F1 ...`, `key up ...`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Named {
    Enter,
    Tab,
    Backspace,
    Esc,
    Up,
    Down,
    Left,
    Right,
    Home,
    End,
    PageUp,
    PageDown,
    Insert,
    F(u8),
}

const NAMES: &[(&str, Named)] = &[
    ("enter", Named::Enter),
    ("tab", Named::Tab),
    ("backspace", Named::Backspace),
    ("esc", Named::Esc),
    ("up", Named::Up),
    ("down", Named::Down),
    ("left", Named::Left),
    ("right", Named::Right),
    ("home", Named::Home),
    ("end", Named::End),
    ("pageup", Named::PageUp),
    ("pagedown", Named::PageDown),
    ("insert", Named::Insert),
];

impl fmt::Display for KeySpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            KeySpec::Char(' ') => f.write_str("space"),
            KeySpec::Char(c) => write!(f, "{c}"),
            KeySpec::Named(Named::F(n)) => write!(f, "F{n}"),
            KeySpec::Named(n) => {
                let name = NAMES.iter().find(|(_, k)| k == n).map_or("?", |(s, _)| s);
                f.write_str(name)
            }
        }
    }
}

/// Reads the KEY cell of a `key` row: one character (quote `" "` or write `space`), or a
/// key name. Delete and Ctrl-C are the vitrine's own.
pub fn parse_key(text: &str) -> Result<KeySpec, String> {
    let mut chars = text.chars();
    if let (Some(c), None) = (chars.next(), chars.next()) {
        return Ok(KeySpec::Char(lower(c)));
    }
    let name = text.to_ascii_lowercase();
    if name == "space" {
        return Ok(KeySpec::Char(' '));
    }
    if matches!(name.as_str(), "delete" | "del") {
        return Err(
            "Delete is the vitrine's key for releasing its forces; bind another key".into(),
        );
    }
    if let Some((_, k)) = NAMES.iter().find(|(n, _)| *n == name) {
        return Ok(KeySpec::Named(*k));
    }
    if let Some(n) = name.strip_prefix('f').and_then(|n| n.parse::<u8>().ok()) {
        if (1..=12).contains(&n) {
            return Ok(KeySpec::Named(Named::F(n)));
        }
    }
    Err(format!(
        "`{text}` is not a key: write one character (`b`, `1`, `\" \"`), space, F1 to F12, or \
         one of {}",
        NAMES.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
    ))
}

fn lower(c: char) -> char {
    let mut l = c.to_lowercase();
    match (l.next(), l.next()) {
        (Some(x), None) => x,
        _ => c,
    }
}

/// The crossterm key code of a named key.
pub fn code(n: Named) -> KeyCode {
    match n {
        Named::Enter => KeyCode::Enter,
        Named::Tab => KeyCode::Tab,
        Named::Backspace => KeyCode::Backspace,
        Named::Esc => KeyCode::Esc,
        Named::Up => KeyCode::Up,
        Named::Down => KeyCode::Down,
        Named::Left => KeyCode::Left,
        Named::Right => KeyCode::Right,
        Named::Home => KeyCode::Home,
        Named::End => KeyCode::End,
        Named::PageUp => KeyCode::PageUp,
        Named::PageDown => KeyCode::PageDown,
        Named::Insert => KeyCode::Insert,
        Named::F(n) => KeyCode::F(n),
    }
}

/// What a key press means to the vitrine.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Input {
    /// A key bound by a `key` row (its binding's index).
    Bound(usize),
    /// Ctrl-C, or `q` while no row binds it: stop the PLC.
    Stop,
    /// Delete: release every force the vitrine made.
    Release,
    ScrollUp,
    ScrollDown,
    Other,
}

/// Reads a key event against the bindings: bound keys first, then the vitrine's own.
pub fn classify(ev: &KeyEvent, bindings: &[Binding]) -> Input {
    if ev.kind == KeyEventKind::Release {
        return Input::Other;
    }
    let ctrl = ev.modifiers.contains(KeyModifiers::CONTROL);
    if ctrl && matches!(ev.code, KeyCode::Char('c' | 'C')) {
        return Input::Stop;
    }
    if ctrl || ev.modifiers.contains(KeyModifiers::ALT) {
        return Input::Other;
    }
    let spec = match ev.code {
        KeyCode::Char(c) => Some(KeySpec::Char(lower(c))),
        KeyCode::Enter => Some(KeySpec::Named(Named::Enter)),
        KeyCode::Tab => Some(KeySpec::Named(Named::Tab)),
        KeyCode::Backspace => Some(KeySpec::Named(Named::Backspace)),
        KeyCode::Esc => Some(KeySpec::Named(Named::Esc)),
        KeyCode::Up => Some(KeySpec::Named(Named::Up)),
        KeyCode::Down => Some(KeySpec::Named(Named::Down)),
        KeyCode::Left => Some(KeySpec::Named(Named::Left)),
        KeyCode::Right => Some(KeySpec::Named(Named::Right)),
        KeyCode::Home => Some(KeySpec::Named(Named::Home)),
        KeyCode::End => Some(KeySpec::Named(Named::End)),
        KeyCode::PageUp => Some(KeySpec::Named(Named::PageUp)),
        KeyCode::PageDown => Some(KeySpec::Named(Named::PageDown)),
        KeyCode::Insert => Some(KeySpec::Named(Named::Insert)),
        KeyCode::F(n) => Some(KeySpec::Named(Named::F(n))),
        _ => None,
    };
    if let Some(i) = spec.and_then(|s| bindings.iter().position(|b| b.key == s)) {
        return Input::Bound(i);
    }
    match ev.code {
        KeyCode::Char('q' | 'Q') => Input::Stop,
        KeyCode::Delete => Input::Release,
        KeyCode::PageUp => Input::ScrollUp,
        KeyCode::PageDown => Input::ScrollDown,
        _ => Input::Other,
    }
}

/// What a bound key does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Action {
    /// True for the `pulse` time, then back (false, or the force released).
    Pulse,
    /// The opposite of what the point reads now.
    Toggle,
    Set(PointValue),
}

/// One `key` row, resolved.
#[derive(Clone, Debug)]
pub struct Binding {
    /// The KEY cell as written.
    pub written: String,
    pub key: KeySpec,
    pub point: String,
    pub handle: Handle,
    /// Whether the vitrine owns the point (writes it) or not (forces it).
    pub owned: bool,
    pub action: Action,
    pub origin: Origin,
}

impl Binding {
    /// `b B1 pulse`, for the footer.
    pub fn help(&self) -> String {
        let action = match self.action {
            Action::Pulse => "pulse".to_string(),
            Action::Toggle => "toggle".to_string(),
            Action::Set(v) => format!("={}", show(v)),
        };
        format!("{} {} {action}", self.key, self.point)
    }
}

fn show(v: PointValue) -> String {
    match v {
        PointValue::Unsigned(n) => n.to_string(),
        PointValue::Signed(n) => n.to_string(),
        PointValue::Float(x) => x.to_string(),
    }
}

/// The keys' state between scans: pulses running and points the vitrine forced.
#[derive(Debug)]
pub struct Keys {
    pub bindings: Vec<Binding>,
    pulse: Duration,
    /// Per binding: when its running pulse ends.
    pulses: Vec<Option<Duration>>,
    /// Points the vitrine forced and has not released, in the order it forced them.
    forced: Vec<(String, Handle)>,
}

impl Keys {
    pub fn new(bindings: Vec<Binding>, pulse: Duration) -> Keys {
        Keys {
            pulses: vec![None; bindings.len()],
            bindings,
            pulse,
            forced: Vec::new(),
        }
    }

    /// How many points the vitrine holds forced.
    pub fn forces(&self) -> usize {
        self.forced.len()
    }

    /// Presses binding `i` at `now`; says what it did.
    pub fn press(
        &mut self,
        i: usize,
        now: Duration,
        map: &mut ModuleMap,
    ) -> Result<String, String> {
        let b = &self.bindings[i];
        let value = match b.action {
            Action::Pulse => {
                self.pulses[i] = Some(now + self.pulse);
                PointValue::Unsigned(1)
            }
            Action::Toggle => PointValue::Unsigned(u32::from(!map.get_bool(&b.handle))),
            Action::Set(v) => v,
        };
        let b = &self.bindings[i];
        let (point, handle, owned) = (b.point.clone(), b.handle, b.owned);
        let shown = match (b.action, value) {
            (Action::Pulse, _) => format!("ON for {} ms", self.pulse.as_millis()),
            (_, PointValue::Unsigned(n)) if b.handle.bits() == 1 => {
                if n == 1 { "ON" } else { "off" }.to_string()
            }
            (_, v) => show(v),
        };
        self.write(&point, &handle, owned, value, map)?;
        Ok(if owned {
            format!("{point} := {shown}")
        } else {
            format!("{point} forced {shown}")
        })
    }

    /// Ends the pulses due by `now`.
    pub fn tick(&mut self, now: Duration, map: &mut ModuleMap) -> Result<(), String> {
        for i in 0..self.bindings.len() {
            if self.pulses[i].is_some_and(|end| end <= now) {
                self.pulses[i] = None;
                let b = &self.bindings[i];
                let (point, handle) = (b.point.clone(), b.handle);
                // Another key may still hold the same point: release it with the last.
                let held = self
                    .bindings
                    .iter()
                    .zip(&self.pulses)
                    .any(|(o, p)| p.is_some() && o.handle == handle);
                if held {
                    continue;
                }
                if b.owned {
                    map.set_bool(&handle, false).map_err(|e| e.to_string())?;
                } else {
                    self.unforce(&point, &handle, map)?;
                }
            }
        }
        Ok(())
    }

    /// Releases every force the vitrine made, and any force on a point its keys force
    /// (one left by a vitrine that failed and restarted, say), ending the pulses of forced
    /// points with them; says how many.
    pub fn release_all(&mut self, map: &mut ModuleMap) -> Result<usize, String> {
        let mut released = std::mem::take(&mut self.forced);
        for b in &self.bindings {
            if !b.owned && map.is_forced(&b.handle) && !released.iter().any(|(p, _)| *p == b.point)
            {
                released.push((b.point.clone(), b.handle));
            }
        }
        for (_, h) in &released {
            map.unforce(h).map_err(|e| e.to_string())?;
        }
        for (b, p) in self.bindings.iter().zip(&mut self.pulses) {
            if !b.owned {
                *p = None;
            }
        }
        Ok(released.len())
    }

    fn write(
        &mut self,
        point: &str,
        h: &Handle,
        owned: bool,
        v: PointValue,
        map: &mut ModuleMap,
    ) -> Result<(), String> {
        if owned {
            return map.set(h, v).map_err(|e| e.to_string());
        }
        map.force(h, v).map_err(|e| e.to_string())?;
        if !self.forced.iter().any(|(p, _)| p == point) {
            self.forced.push((point.to_string(), *h));
        }
        Ok(())
    }

    fn unforce(&mut self, point: &str, h: &Handle, map: &mut ModuleMap) -> Result<(), String> {
        self.forced.retain(|(p, _)| p != point);
        map.unforce(h).map_err(|e| e.to_string())
    }
}
