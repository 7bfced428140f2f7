//! The runner's side of retentive values: where the retain file is, what a start restores
//! into the process image (before any module scans), and the persistence thread's source —
//! the retentive points copied out of the image under its lock, with the modules' committed
//! retained data as of the same instant.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

use petriplc_config::{PlcConfig, PointKind};
use petriplc_retain::restore::{self, Wanted};
use petriplc_retain::{data, Ack, Entry, Identity, Persister, Registry, RetainError, Value};
use petriplc_runtime::image::{GlobalMap, Layout, PointId};
use petriplc_runtime::retained;
use petriplc_runtime::status::RetainStatus;

/// The retain file of a PLC that keeps retentive values, and how they are kept.
pub(crate) struct Retain {
    pub path: PathBuf,
    pub registry: Arc<Registry>,
    /// The retentive points, in declaration order.
    points: Vec<PointId>,
    persister: Mutex<Option<Persister>>,
    /// Open but not yet handed to the persister (between restore and the first scan).
    pending: Mutex<Option<Pending>>,
    identity: Identity,
}

struct Pending {
    file: petriplc_retain::RetainFile,
    restored: Option<Ack>,
}

/// The retain file of PLC `plc_id`: `[PLC] retain_file` (relative to the configuration's
/// folder), else `ID.retain` in systemd's state directory (`$STATE_DIRECTORY`, set by
/// `StateDirectory=`), else beside the configuration, named after it (`plc.conf` →
/// `plc.retain`).
pub(crate) fn path(
    config: &PlcConfig,
    base_dir: &Path,
    config_path: &Path,
    plc_id: &str,
) -> PathBuf {
    if let Some(s) = &config.retain.file {
        return base_dir.join(&s.value);
    }
    match std::env::var_os("STATE_DIRECTORY") {
        // systemd lists one folder per StateDirectory= entry, separated by colons.
        Some(dirs) if !dirs.is_empty() => {
            let dirs = dirs.to_string_lossy().into_owned();
            PathBuf::from(dirs.split(':').next().unwrap_or_default())
                .join(format!("{plc_id}.retain"))
        }
        _ => {
            let stem = config_path
                .file_stem()
                .map_or_else(|| "plc".into(), |s| s.to_string_lossy().into_owned());
            base_dir.join(format!("{stem}.retain"))
        }
    }
}

impl Retain {
    /// Opens (and locks) the retain file when the PLC keeps anything there — retentive
    /// points, module data (`data`: a module said it registers some), or a `retain_file`
    /// setting — and checks what it holds against the configuration. Returns the values to
    /// restore, by point. A PLC that keeps nothing opens no file.
    pub(crate) fn open(
        config: &PlcConfig,
        layout: &Layout,
        base_dir: &Path,
        config_path: &Path,
        plc_id: &str,
        data: bool,
    ) -> Result<(Retain, Vec<(PointId, u32)>), RetainError> {
        let path = path(config, base_dir, config_path, plc_id);
        let points = retained::points(layout);
        let identity = Identity {
            plc_id: plc_id.to_string(),
            config: config_path.display().to_string(),
        };
        if points.is_empty() && config.retain.file.is_none() && !data {
            return Ok((
                Retain {
                    registry: Arc::new(Registry::without_file(path.clone())),
                    path,
                    points,
                    persister: Mutex::new(None),
                    pending: Mutex::new(None),
                    identity,
                },
                Vec::new(),
            ));
        }
        let (file, loaded) = petriplc_retain::RetainFile::open(&path)?;
        for w in &loaded.warnings {
            log::warn!("{w}");
        }
        let wanted: Vec<Wanted> = points
            .iter()
            .map(|&id| {
                let s = layout.slot(id);
                Wanted {
                    name: &s.name,
                    kind: s.kind,
                    bits: s.bits,
                }
            })
            .collect();
        let mut values = Vec::new();
        let mut data_entries: &[Entry] = &[];
        if let Some(snap) = &loaded.snapshot {
            let r = restore::points(&path, snap, &identity, &wanted)?;
            for n in &r.notes {
                log::warn!("{n}");
            }
            values = points
                .iter()
                .zip(&r.points)
                .filter_map(|(&id, v)| v.map(|raw| (id, raw)))
                .collect();
            log::info!(
                "retain file {}: restored {} of {} retentive point{} from snapshot {} of {}",
                path.display(),
                values.len(),
                points.len(),
                if points.len() == 1 { "" } else { "s" },
                snap.seq,
                petriplc_retain::file::show_time(snap.written)
            );
            data_entries = &snap.entries;
        } else if loaded.created {
            log::info!(
                "retain file {}: created; the retentive values start from their init values",
                path.display()
            );
        } else if loaded.warnings.is_empty() {
            log::info!(
                "retain file {}: nothing stored yet (the PLC stopped before its first write); \
                 the retentive values start from their init values",
                path.display()
            );
        }
        let registry = Arc::new(Registry::new(path.clone(), data_entries));
        let restored = loaded.snapshot.as_ref().map(|s| Ack {
            seq: s.seq,
            written: s.written,
            entries: s.entries.clone(),
        });
        Ok((
            Retain {
                path,
                registry,
                points,
                persister: Mutex::new(None),
                pending: Mutex::new(Some(Pending { file, restored })),
                identity,
            },
            values,
        ))
    }

    /// Makes the registry the one modules of PLC `plc_id` register their data with.
    pub(crate) fn install(&self) {
        data::install(&self.identity.plc_id, &self.registry);
    }

    /// Starts the persistence thread (once every module is initialised, before the first
    /// scan): from now on the retain file follows the image.
    pub(crate) fn start(
        &self,
        global: &GlobalMap,
        layout: &Layout,
        policy: petriplc_config::RetainWrite,
    ) -> Result<(), RetainError> {
        for name in self.registry.unclaimed() {
            log::warn!(
                "retain file {}: `{name}` is stored but no module registered it: dropped at \
                 the next write",
                self.path.display()
            );
        }
        let Some(pending) = take(&self.pending) else {
            return Ok(());
        };
        let source = source(
            global.clone(),
            layout.clone(),
            self.points.clone(),
            Arc::clone(&self.registry),
        );
        let persister = Persister::start(
            pending.file,
            self.identity.clone(),
            policy,
            pending.restored,
            source,
        )
        .map_err(|source| RetainError::Io {
            path: self.path.clone(),
            what: "cannot start the thread that writes it",
            source,
        })?;
        *lock(&self.persister) = Some(persister);
        Ok(())
    }

    /// Writes a last snapshot and stops the persistence thread (the PLC stops).
    pub(crate) fn stop(&self) {
        if let Some(p) = take(&self.persister) {
            if let Some((_, Some(ack))) = p.stop() {
                log::info!(
                    "retain file {}: holds snapshot {}, the values as the PLC stopped",
                    self.path.display(),
                    ack.seq
                );
            }
        }
        take(&self.pending);
        data::uninstall(&self.identity.plc_id);
    }

    /// What the file holds, for the status; `None` when the PLC keeps nothing.
    pub(crate) fn status(&self) -> Option<RetainStatus> {
        let persister = lock(&self.persister);
        let ack = persister.as_ref()?.acknowledged();
        let file = self.path.display().to_string();
        Some(match ack {
            None => RetainStatus {
                file,
                ..RetainStatus::default()
            },
            Some(a) => RetainStatus {
                file,
                sequence: a.seq,
                written: petriplc_runtime::owner::rfc3339(a.written),
                values: a
                    .entries
                    .iter()
                    .map(|e| (e.name.clone(), show(&e.value)))
                    .collect(),
            },
        })
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

fn take<T>(m: &Mutex<Option<T>>) -> Option<T> {
    lock(m).take()
}

/// A value as the status shows it.
fn show(v: &Value) -> String {
    match *v {
        Value::Point { kind, bits, raw } => match kind {
            PointKind::Unsigned => raw.to_string(),
            PointKind::Signed => {
                let shift = 32 - u32::from(bits.clamp(1, 32));
                (((raw << shift) as i32) >> shift).to_string()
            }
            PointKind::Float => f32::from_bits(raw).to_string(),
        },
        Value::Data { ref bytes, .. } => format!("{} bytes", bytes.len()),
    }
}

/// The persistence thread's snapshot: the retentive points as their owners last committed
/// them and the modules' committed data, read while the image's lock is held, so that both
/// are of the same scans. A module half-way through committing its data is waited for.
fn source(
    global: GlobalMap,
    layout: Layout,
    points: Vec<PointId>,
    registry: Arc<Registry>,
) -> petriplc_retain::persist::Source {
    let meta: Vec<(String, PointKind, u8)> = points
        .iter()
        .map(|&id| {
            let s = layout.slot(id);
            (s.name.clone(), s.kind, s.bits)
        })
        .collect();
    let mut raw = Vec::with_capacity(points.len());
    Box::new(move |out: &mut Vec<Entry>| {
        let mut data = Vec::new();
        loop {
            raw.clear();
            data.clear();
            if retained::read(&global, &layout, &points, &mut raw, || {
                registry.snapshot(&mut data)
            }) {
                break;
            }
            std::thread::sleep(Duration::from_micros(50));
        }
        out.extend(
            meta.iter()
                .zip(&raw)
                .map(|((name, kind, bits), &raw)| Entry {
                    name: name.clone(),
                    value: Value::Point {
                        kind: *kind,
                        bits: *bits,
                        raw,
                    },
                }),
        );
        out.append(&mut data);
    })
}
