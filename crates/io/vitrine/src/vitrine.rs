//! The `vitrine` module: each scan it samples the points, reads the keys, applies them to
//! their points, refreshes the PLC status now and then, builds the [`View`] and draws it.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

use petriplc_config::ModuleDecl;
use petriplc_modules::common::error;
use petriplc_runtime::image::{Handle, ModuleMap};
use petriplc_runtime::module::{Control, InitContext, Module, ModuleError, ScanContext};
use petriplc_runtime::status::PlcStatus;
use ratatui::buffer::Buffer;
use ratatui::crossterm::event::{self, Event, KeyEvent, KeyEventKind};
use ratatui::layout::Rect;

use crate::format;
use crate::keys::{classify, parse_key, Input, KeySpec, Keys};
use crate::logring;
use crate::setup::{self, GraphSpec, Settings, ShowField};
use crate::term::{Screen, TakeError};
use crate::view::{self, GraphLine, NetLine, PointLine, ShowScreen, ShowText, View};

/// The vitrine's scan period when its section sets none: a display needs no more.
pub const DEFAULT_PERIOD: Duration = Duration::from_millis(50);

/// How often the status file is read.
const STATUS_EVERY: Duration = Duration::from_millis(200);

/// Frames closer than this are skipped (a vitrine in a fast synchronisation loop).
const MIN_FRAME: Duration = Duration::from_millis(30);

/// Samples kept per graph: wider than any terminal's graph.
const SAMPLES: usize = 512;

/// Log lines kept for the footer.
const LOG_LINES: usize = 4;

pub(crate) fn factory(decl: &ModuleDecl) -> Result<Box<dyn Module>, ModuleError> {
    Ok(Box::new(Vitrine::new(decl)?))
}

/// The `vitrine` module.
pub struct Vitrine {
    name: String,
    settings: Settings,
    probe: Option<Probe>,
    run: Option<Run>,
}

/// Where frames go and keys come from.
enum Output {
    /// Standard output is not a terminal (or another vitrine has it): nothing is drawn.
    Off(&'static str),
    Terminal(Box<Screen>),
    Probe(Probe),
    /// After `close`.
    Closed,
}

struct Run {
    plc_id: String,
    output: Output,
    points: Vec<Shown>,
    show: Vec<ShowField>,
    background: Vec<String>,
    graphs: Vec<(GraphSpec, VecDeque<f64>)>,
    keys: Keys,
    /// The `petrinet` modules, in declaration order.
    nets: Vec<String>,
    status: Option<PlcStatus>,
    status_read: Option<Duration>,
    last_frame: Option<Duration>,
    message: String,
    scroll: usize,
    /// Whether `q` stops the PLC (no `key q` row).
    q_stops: bool,
    /// Whether the scanning thread was claimed as the display's.
    claimed: bool,
}

struct Shown {
    name: String,
    description: String,
    owner: String,
    handle: Handle,
}

impl Vitrine {
    /// Checks the settings; rows, points and the terminal are taken by `init`.
    pub fn new(decl: &ModuleDecl) -> Result<Vitrine, ModuleError> {
        Ok(Vitrine {
            name: decl.name.clone(),
            settings: Settings::parse(decl)?,
            probe: None,
            run: None,
        })
    }

    /// A vitrine that never touches the terminal: it draws into `probe`'s buffer and reads
    /// the keys pushed into `probe` (for tests and tools that step a PLC).
    pub fn with_probe(decl: &ModuleDecl, probe: Probe) -> Result<Vitrine, ModuleError> {
        let mut v = Vitrine::new(decl)?;
        v.probe = Some(probe);
        Ok(v)
    }

    fn fail(&self, message: impl std::fmt::Display) -> ModuleError {
        error(&self.name, message)
    }
}

impl Module for Vitrine {
    fn init(&mut self, ctx: &mut InitContext<'_>) -> Result<(), ModuleError> {
        let rows = setup::rows(ctx)?;
        let layout = ctx.map.layout().clone();
        let names: Vec<String> = match &self.settings.points {
            Some(list) => list.clone(),
            None => layout.points().map(|(_, s)| s.name.clone()).collect(),
        };
        let mut points = Vec::new();
        let mut problems = Vec::new();
        for n in names {
            match ctx.map.handle(&n) {
                Ok(h) => {
                    let slot = layout.slot(h.id());
                    let description = ctx
                        .config
                        .points
                        .iter()
                        .find(|p| p.name == n)
                        .map_or_else(String::new, |p| p.description.clone());
                    points.push(Shown {
                        owner: slot.owner.clone(),
                        name: n,
                        description,
                        handle: h,
                    });
                }
                Err(e) => problems.push(format!(
                    "`points`: {e}; fix the name in `points = ...` of [{}]",
                    self.name
                )),
            }
        }
        if !problems.is_empty() {
            return Err(self.fail(problems.join(&format!("\nmodule {}: ", self.name))));
        }
        let background = match &self.settings.background {
            None => Vec::new(),
            Some(file) => {
                let path = ctx.path(file);
                let text =
                    petriplc_files::read_to_string(&path, petriplc_files::SMALL).map_err(|e| {
                        self.fail(format!(
                            "background: {e}; fix `background` in [{}] (a text file, relative \
                             to the configuration file)",
                            self.name
                        ))
                    })?;
                text.lines().map(expand_tabs).collect()
            }
        };
        let q_stops = !rows.keys.iter().any(|b| b.key == KeySpec::Char('q'));
        let nets = petriplc_modules::petrinet_modules(ctx.config)
            .map(|m| m.name.clone())
            .collect();
        let output = match self.probe.clone() {
            Some(p) => Output::Probe(p),
            None => match Screen::take() {
                Ok(s) => Output::Terminal(Box::new(s)),
                Err(TakeError::NotTerminal) => {
                    log::warn!(
                        "{}: standard output is not a terminal; the display is off",
                        self.name
                    );
                    Output::Off("standard output is not a terminal")
                }
                Err(TakeError::Held) => {
                    log::warn!(
                        "{}: another vitrine has the terminal; the display is off",
                        self.name
                    );
                    Output::Off("another vitrine has the terminal")
                }
                Err(TakeError::Io(e)) => {
                    return Err(self.fail(format!("cannot take the terminal: {e}")))
                }
            },
        };
        self.run = Some(Run {
            plc_id: ctx.plc_id.to_string(),
            output,
            points,
            show: rows.show,
            background,
            graphs: rows
                .graphs
                .into_iter()
                .map(|g| (g, VecDeque::with_capacity(SAMPLES)))
                .collect(),
            keys: Keys::new(rows.keys, self.settings.pulse),
            nets,
            status: None,
            status_read: None,
            last_frame: None,
            message: String::new(),
            scroll: 0,
            q_stops,
            claimed: false,
        });
        Ok(())
    }

    fn scan(&mut self, ctx: &mut ScanContext<'_>) -> Result<Control, ModuleError> {
        let Some(run) = &mut self.run else {
            return Err(error(&self.name, "scanned before init"));
        };
        if let Output::Off(_) | Output::Closed = run.output {
            return Ok(Control::Continue);
        }
        if let (Output::Terminal(s), false) = (&run.output, run.claimed) {
            s.claim_thread();
            run.claimed = true;
        }
        let now = ctx.now;
        let map = &mut *ctx.map;
        for (g, samples) in &mut run.graphs {
            if samples.len() == SAMPLES {
                samples.pop_front();
            }
            samples.push_back(format::number(map.get(&g.handle)));
        }
        if let Err(e) = run.keys.tick(now, map) {
            run.warn(&self.name, &e);
        }
        let mut pressed = false;
        for key in run.read_keys(&self.name) {
            pressed = true;
            match run.key(&key, now, map, &self.name) {
                Control::Continue => {}
                Control::StopPlc => {
                    log::info!("{}: stop key pressed", self.name);
                    return Ok(Control::StopPlc);
                }
            }
        }
        if run
            .status_read
            .is_none_or(|t| now.saturating_sub(t) >= STATUS_EVERY)
        {
            run.status_read = Some(now);
            run.status = PlcStatus::read(&run.plc_id);
        }
        if pressed
            || run
                .last_frame
                .is_none_or(|t| now.saturating_sub(t) >= MIN_FRAME)
        {
            run.last_frame = Some(now);
            let view = run.view(map);
            run.draw(&view, &self.name);
        }
        Ok(Control::Continue)
    }

    fn close(&mut self) {
        // Dropping the screen gives the terminal back.
        if let Some(run) = &mut self.run {
            run.output = Output::Closed;
        }
    }

    fn status(&self) -> String {
        let Some(run) = &self.run else {
            return String::new();
        };
        let forces = match run.keys.forces() {
            0 => String::new(),
            1 => "; 1 point forced".into(),
            n => format!("; {n} points forced"),
        };
        match &run.output {
            Output::Off(why) => format!("display off: {why}"),
            Output::Closed => "display closed".into(),
            Output::Terminal(_) | Output::Probe(_) => format!("display on{forces}"),
        }
    }

    fn default_scan_period(&self) -> Option<Duration> {
        Some(DEFAULT_PERIOD)
    }
}

impl Run {
    fn warn(&mut self, module: &str, e: &str) {
        log::warn!("{module}: {e}");
        self.message = e.to_string();
    }

    fn read_keys(&mut self, module: &str) -> Vec<KeyEvent> {
        match &self.output {
            Output::Probe(p) => p.take_keys(),
            Output::Terminal(_) => {
                let mut keys = Vec::new();
                loop {
                    match event::poll(Duration::ZERO) {
                        Ok(false) => break,
                        Ok(true) => match event::read() {
                            Ok(Event::Key(k)) if k.kind != KeyEventKind::Release => keys.push(k),
                            Ok(_) => {}
                            Err(e) => {
                                self.lost(module, &e);
                                break;
                            }
                        },
                        Err(e) => {
                            self.lost(module, &e);
                            break;
                        }
                    }
                }
                keys
            }
            Output::Off(_) | Output::Closed => Vec::new(),
        }
    }

    /// The terminal failed (hung up, closed): the display goes off, the PLC goes on.
    fn lost(&mut self, module: &str, e: &std::io::Error) {
        self.output = Output::Off("the terminal failed");
        log::warn!("{module}: the terminal failed ({e}); the display is off");
    }

    fn key(&mut self, key: &KeyEvent, now: Duration, map: &mut ModuleMap, module: &str) -> Control {
        match classify(key, &self.keys.bindings) {
            Input::Stop => return Control::StopPlc,
            Input::Bound(i) => match self.keys.press(i, now, map) {
                Ok(what) => {
                    // An operator's writes and forces belong in the PLC's log.
                    log::info!("{module}: key {}: {what}", self.keys.bindings[i].key);
                    self.message = what;
                }
                Err(e) => self.warn(module, &e),
            },
            Input::Release => match self.keys.release_all(map) {
                Ok(0) => self.message = "no forces to release".into(),
                Ok(n) => {
                    self.message = format!("released {n} force{}", if n == 1 { "" } else { "s" });
                    log::info!("{module}: {}", self.message);
                }
                Err(e) => self.warn(module, &e),
            },
            Input::ScrollUp => self.scroll = self.scroll.saturating_sub(10),
            Input::ScrollDown => {
                self.scroll = (self.scroll + 10).min(self.points.len().saturating_sub(1));
            }
            Input::Other => {}
        }
        Control::Continue
    }

    fn view(&self, map: &ModuleMap) -> View {
        let points = self
            .points
            .iter()
            .map(|p| {
                let (value, on) = format::point(p.handle.bits(), map.get(&p.handle));
                PointLine {
                    name: p.name.clone(),
                    description: p.description.clone(),
                    value,
                    on,
                    owner: p.owner.clone(),
                    forced: map.is_forced(&p.handle),
                }
            })
            .collect();
        let show = (!self.show.is_empty() || !self.background.is_empty()).then(|| ShowScreen {
            background: self.background.clone(),
            fields: self
                .show
                .iter()
                .map(|f| {
                    let (text, on) = format::show(f.ty, map.get(&f.handle), &f.on, &f.off);
                    ShowText {
                        row: f.row,
                        col: f.col,
                        text,
                        on,
                    }
                })
                .collect(),
        });
        let graphs = self
            .graphs
            .iter()
            .map(|(g, samples)| {
                let (lo, hi) = g.range.unwrap_or_else(|| {
                    let bool_point = g.handle.bits() == 1;
                    let lo = samples.iter().copied().fold(f64::INFINITY, f64::min);
                    let hi = samples.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                    match (bool_point, lo.is_finite() && hi.is_finite()) {
                        (true, _) | (false, false) => (0.0, 1.0),
                        (false, true) if lo == hi => (lo - 1.0, hi + 1.0),
                        (false, true) => (lo, hi),
                    }
                });
                GraphLine {
                    name: g.point.clone(),
                    value: format::point(g.handle.bits(), map.get(&g.handle)).0,
                    lo,
                    hi,
                    samples: samples.iter().copied().collect(),
                }
            })
            .collect();
        let modules = self.status.as_ref().map(|s| s.modules.clone());
        let nets = self
            .nets
            .iter()
            .map(|name| {
                let status = self
                    .status
                    .as_ref()
                    .and_then(|s| s.modules.iter().find(|m| &m.name == name));
                NetLine {
                    module: name.clone(),
                    places: status.map(|m| m.marking.clone()).unwrap_or_default(),
                    note: match status {
                        None => "waiting for the PLC's status".into(),
                        Some(m) if m.detail.is_empty() => "no marking yet".into(),
                        Some(m) => m.detail.clone(),
                    },
                }
            })
            .collect();
        let mut keys: Vec<(String, String)> = self
            .keys
            .bindings
            .iter()
            .map(|b| {
                let help = b.help();
                let (k, rest) = help.split_once(' ').unwrap_or((&help, ""));
                (k.to_string(), rest.to_string())
            })
            .collect();
        let forces = self.keys.forces();
        if forces > 0 {
            keys.push(("Del".into(), format!("release {forces} forced")));
        } else if self.keys.bindings.iter().any(|b| !b.owned) {
            keys.push(("Del".into(), "release forces".into()));
        }
        keys.push((
            if self.q_stops { "q/Ctrl-C" } else { "Ctrl-C" }.into(),
            "stop the PLC".into(),
        ));
        let title = match &self.status {
            Some(s) => format!("PLC {} │ up {:.1} s", self.plc_id, s.uptime.as_secs_f64()),
            None => format!("PLC {}", self.plc_id),
        };
        View {
            title,
            message: self.message.clone(),
            points,
            scroll: self.scroll,
            show,
            graphs,
            modules,
            nets,
            keys,
            log: logring::last(LOG_LINES),
        }
    }

    fn draw(&mut self, view: &View, module: &str) {
        match &mut self.output {
            Output::Off(_) | Output::Closed => {}
            Output::Probe(p) => {
                let mut buf = Buffer::empty(Rect::new(0, 0, p.width, p.height));
                view::render(view, buf.area, &mut buf);
                *p.screen.lock().unwrap_or_else(PoisonError::into_inner) = Some(buf);
            }
            Output::Terminal(s) => {
                if let Err(e) = s.terminal.draw(|f| {
                    let area = f.area();
                    view::render(view, area, f.buffer_mut());
                }) {
                    self.lost(module, &e);
                }
            }
        }
    }
}

/// A background line with its tabs expanded to the next multiple of 8 columns, as a
/// terminal shows them.
fn expand_tabs(line: &str) -> String {
    let mut out = String::with_capacity(line.len());
    let mut col = 0;
    for c in line.chars() {
        if c == '\t' {
            let to = (col / 8 + 1) * 8;
            out.extend(std::iter::repeat_n(' ', to - col));
            col = to;
        } else {
            out.push(c);
            col += 1;
        }
    }
    out
}

/// A stand-in terminal for a vitrine made by [`Vitrine::with_probe`]: keys pushed here are
/// read at its next scan, and each frame it draws is kept here. Clones share both.
#[derive(Clone, Debug)]
pub struct Probe {
    width: u16,
    height: u16,
    keys: Arc<Mutex<VecDeque<KeyEvent>>>,
    screen: Arc<Mutex<Option<Buffer>>>,
}

impl Probe {
    /// A screen of `width` × `height` cells.
    pub fn new(width: u16, height: u16) -> Probe {
        Probe {
            width,
            height,
            keys: Arc::default(),
            screen: Arc::default(),
        }
    }

    /// Queues a key press for the next scan.
    pub fn press_key(&self, key: KeyEvent) {
        self.keys
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .push_back(key);
    }

    /// Queues a key given by name as `key` rows write it (`b`, `F1`, `space`), or `delete`,
    /// `pageup`, `pagedown`, `ctrl-c`; an unknown name is an error.
    pub fn press(&self, name: &str) -> Result<(), String> {
        use ratatui::crossterm::event::{KeyCode, KeyModifiers};
        let key = match name.to_ascii_lowercase().as_str() {
            "ctrl-c" => KeyEvent::new(KeyCode::Char('c'), KeyModifiers::CONTROL),
            "delete" => KeyEvent::new(KeyCode::Delete, KeyModifiers::NONE),
            _ => {
                let code = match parse_key(name)? {
                    KeySpec::Char(c) => KeyCode::Char(c),
                    KeySpec::Named(n) => crate::keys::code(n),
                };
                KeyEvent::new(code, KeyModifiers::NONE)
            }
        };
        self.press_key(key);
        Ok(())
    }

    fn take_keys(&self) -> Vec<KeyEvent> {
        self.keys
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .drain(..)
            .collect()
    }

    /// The last frame drawn, if any.
    pub fn screen(&self) -> Option<Buffer> {
        self.screen
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone()
    }

    /// The last frame's text, one line per row, trailing spaces removed (empty before the
    /// first frame).
    pub fn text(&self) -> String {
        self.screen().map(|b| view::text(&b)).unwrap_or_default()
    }
}
