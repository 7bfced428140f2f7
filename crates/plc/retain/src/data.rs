//! Module-private retained data: values a module keeps for itself across restarts (an IEC
//! program's `VAR RETAIN` variables, a totaliser's sum) rather than in plc points.
//!
//! A module registers each value once in its `init`, by name and with a signature (its type
//! as the module describes it, e.g. `INT` or `ARRAY[1..4] OF REAL`): it gets a [`Retained`]
//! handle holding the stored bytes, if any. In each scan it [`Retained::set`]s the new bytes;
//! the runner commits them with the scan's outputs (see [`ModuleData::commit`]), so that a
//! snapshot holds, for every module, its data and its points from the same scan. A stored
//! value whose signature differs from the registered one is refused, never reinterpreted.
//!
//! The runner of a PLC [`install`]s its registry under the PLC id; a module reaches it from
//! its init context. Without one (a module stepped by a test harness) a handle keeps its
//! value in memory only.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError, Weak};

use crate::{Entry, RetainError, Value};

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Every module's retained data of one PLC.
#[derive(Debug)]
pub struct Registry {
    path: PathBuf,
    /// Whether a retain file keeps the values (else registering is refused).
    persistent: bool,
    /// Read from the file at start, by `MODULE/NAME`: signature and bytes.
    stored: Mutex<BTreeMap<String, (String, Vec<u8>)>>,
    modules: Mutex<BTreeMap<String, Arc<ModuleData>>>,
}

/// One module's retained data and the counter that tells a snapshot whether a commit is
/// half done.
#[derive(Debug, Default)]
pub struct ModuleData {
    /// Odd while a commit is under way.
    seq: AtomicU64,
    /// The module's current instance (a restart makes a new one); handles of older
    /// instances are ignored.
    instance: AtomicU64,
    entries: Mutex<Vec<Arc<DataEntry>>>,
}

#[derive(Debug)]
struct DataEntry {
    name: String,
    signature: String,
    /// The value as of the module's last committed scan (or as stored, until then).
    committed: Mutex<Option<Vec<u8>>>,
    /// Set during a scan, by the instance that set it.
    staged: Mutex<Option<(u64, Vec<u8>)>>,
    /// The instance that registered it last.
    registered_by: AtomicU64,
}

/// A module's handle to one retained value.
#[derive(Clone, Debug)]
pub struct Retained {
    entry: Arc<DataEntry>,
    module: Arc<ModuleData>,
    instance: u64,
    /// No registry: `set` is committed at once and nothing is persisted.
    volatile: bool,
}

impl Retained {
    /// A handle that keeps its value in memory only (no PLC registry: a test harness).
    pub fn volatile(name: &str, signature: &str) -> Retained {
        Retained {
            entry: Arc::new(DataEntry {
                name: name.into(),
                signature: signature.into(),
                committed: Mutex::new(None),
                staged: Mutex::new(None),
                registered_by: AtomicU64::new(0),
            }),
            module: Arc::new(ModuleData::default()),
            instance: 0,
            volatile: true,
        }
    }

    /// The value as of the module's last committed scan: at start, the stored one (`None`:
    /// nothing stored, start from the module's own initial value).
    pub fn get(&self) -> Option<Vec<u8>> {
        lock(&self.entry.committed).clone()
    }

    /// The value this scan leaves: committed with the scan's outputs (only if the scan
    /// completes), persisted with the next snapshot. Ignored from a module instance that
    /// has been replaced (restarted, or abandoned by the watchdog).
    pub fn set(&self, bytes: impl Into<Vec<u8>>) {
        if self.volatile {
            *lock(&self.entry.committed) = Some(bytes.into());
            return;
        }
        if self.module.instance.load(Ordering::Acquire) == self.instance {
            *lock(&self.entry.staged) = Some((self.instance, bytes.into()));
        }
    }

    pub fn name(&self) -> &str {
        &self.entry.name
    }

    pub fn signature(&self) -> &str {
        &self.entry.signature
    }
}

impl ModuleData {
    /// Whether the module registered no value (its commits are plain updates).
    pub fn is_empty(&self) -> bool {
        lock(&self.entries).is_empty()
    }

    /// Runs `update` (the scan's end-of-scan `update()`, which commits its points) and
    /// commits the values set during the scan with it, so that a snapshot sees both or
    /// neither. Cheap when the module registered nothing.
    pub fn commit<R>(&self, update: impl FnOnce() -> R) -> R {
        if lock(&self.entries).is_empty() {
            return update();
        }
        self.seq.fetch_add(1, Ordering::SeqCst);
        let r = update();
        let instance = self.instance.load(Ordering::Acquire);
        for e in lock(&self.entries).iter() {
            if let Some((by, bytes)) = lock(&e.staged).take() {
                if by == instance {
                    *lock(&e.committed) = Some(bytes);
                }
            }
        }
        self.seq.fetch_add(1, Ordering::SeqCst);
        r
    }

    /// Forgets values set but not committed (a scan that failed).
    pub fn discard(&self) {
        for e in lock(&self.entries).iter() {
            lock(&e.staged).take();
        }
    }
}

impl Registry {
    /// A registry for the PLC whose retain file is `path`, with the module data `entries`
    /// read from it (points among them are ignored).
    pub fn new(path: PathBuf, entries: &[Entry]) -> Registry {
        Registry::with_file(path, entries, true)
    }

    /// A registry with no retain file behind it (a PLC that keeps nothing): registering is
    /// refused, naming the module.
    pub fn without_file(path: PathBuf) -> Registry {
        Registry::with_file(path, &[], false)
    }

    fn with_file(path: PathBuf, entries: &[Entry], persistent: bool) -> Registry {
        let stored = entries
            .iter()
            .filter_map(|e| match &e.value {
                Value::Data { signature, bytes } => {
                    Some((e.name.clone(), (signature.clone(), bytes.clone())))
                }
                Value::Point { .. } => None,
            })
            .collect();
        Registry {
            path,
            persistent,
            stored: Mutex::new(stored),
            modules: Mutex::new(BTreeMap::new()),
        }
    }

    /// The data of `module` (made on first use).
    pub fn module(&self, module: &str) -> Arc<ModuleData> {
        Arc::clone(lock(&self.modules).entry(module.to_string()).or_default())
    }

    /// A new instance of `module` is about to be initialised: handles of the previous one
    /// stop counting, and its values may be registered again.
    pub fn new_instance(&self, module: &str) {
        let m = self.module(module);
        m.instance.fetch_add(1, Ordering::AcqRel);
        m.discard();
    }

    /// Registers value `name` of `module` with `signature`; its stored value, if any, must
    /// have been stored with the same signature.
    pub fn register(
        &self,
        module: &str,
        name: &str,
        signature: &str,
    ) -> Result<Retained, RetainError> {
        if !self.persistent {
            return Err(RetainError::Undeclared {
                module: module.to_string(),
                name: name.to_string(),
            });
        }
        let m = self.module(module);
        let instance = m.instance.load(Ordering::Acquire);
        let key = format!("{module}/{name}");
        let changed = |stored: &str| RetainError::DataTypeChanged {
            path: self.path.clone(),
            module: module.to_string(),
            name: name.to_string(),
            stored: stored.to_string(),
            now: signature.to_string(),
        };
        let mut entries = lock(&m.entries);
        let entry = match entries.iter().find(|e| e.name == key) {
            Some(e) => {
                if e.signature != signature {
                    return Err(changed(&e.signature));
                }
                if e.registered_by.swap(instance, Ordering::AcqRel) == instance {
                    return Err(RetainError::Unreadable {
                        path: self.path.clone(),
                        why: format!(
                            "module {module} registers its retained value `{name}` twice \
                             (a bug in the module)"
                        ),
                    });
                }
                Arc::clone(e)
            }
            None => {
                let committed = match lock(&self.stored).remove(&key) {
                    Some((sig, _)) if sig != signature => return Err(changed(&sig)),
                    Some((_, bytes)) => Some(bytes),
                    None => None,
                };
                let e = Arc::new(DataEntry {
                    name: key,
                    signature: signature.to_string(),
                    committed: Mutex::new(committed),
                    staged: Mutex::new(None),
                    registered_by: AtomicU64::new(instance),
                });
                entries.push(Arc::clone(&e));
                e
            }
        };
        drop(entries);
        Ok(Retained {
            entry,
            module: m,
            instance,
            volatile: false,
        })
    }

    /// How many values modules have registered.
    pub fn registered(&self) -> usize {
        lock(&self.modules)
            .values()
            .map(|m| lock(&m.entries).len())
            .sum()
    }

    /// Stored values no module registered (once every module is initialised): they are
    /// dropped at the next write.
    pub fn unclaimed(&self) -> Vec<String> {
        lock(&self.stored).keys().cloned().collect()
    }

    /// Appends every registered value as committed, unless a commit is half done (then
    /// `false`: try again after letting it finish). Call it while holding the process
    /// image's lock, so that the points copied with it are of the same scans.
    pub fn snapshot(&self, out: &mut Vec<Entry>) -> bool {
        let modules = lock(&self.modules);
        if modules
            .values()
            .any(|m| m.seq.load(Ordering::SeqCst) % 2 == 1)
        {
            return false;
        }
        for m in modules.values() {
            for e in lock(&m.entries).iter() {
                if let Some(bytes) = lock(&e.committed).as_ref() {
                    out.push(Entry {
                        name: e.name.clone(),
                        value: Value::Data {
                            signature: e.signature.clone(),
                            bytes: bytes.clone(),
                        },
                    });
                }
            }
        }
        true
    }
}

type Installed = Mutex<Vec<(String, Weak<Registry>)>>;
static INSTALLED: Installed = Mutex::new(Vec::new());

/// Makes `registry` the one of PLC `plc_id` in this process (the runner, at start).
pub fn install(plc_id: &str, registry: &Arc<Registry>) {
    let mut all = lock(&INSTALLED);
    all.retain(|(id, r)| id != plc_id && r.strong_count() > 0);
    all.push((plc_id.to_string(), Arc::downgrade(registry)));
}

/// The registry of PLC `plc_id` in this process, if its runner installed one.
pub fn installed(plc_id: &str) -> Option<Arc<Registry>> {
    lock(&INSTALLED)
        .iter()
        .find(|(id, _)| id == plc_id)
        .and_then(|(_, r)| r.upgrade())
}

/// Forgets PLC `plc_id`'s registry (the runner, when the PLC stops).
pub fn uninstall(plc_id: &str) {
    lock(&INSTALLED).retain(|(id, _)| id != plc_id);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data(name: &str, sig: &str, bytes: &[u8]) -> Entry {
        Entry {
            name: name.into(),
            value: Value::Data {
                signature: sig.into(),
                bytes: bytes.to_vec(),
            },
        }
    }

    fn snapshot(r: &Registry) -> Vec<(String, Vec<u8>)> {
        let mut out = Vec::new();
        assert!(r.snapshot(&mut out));
        out.into_iter()
            .map(|e| match e.value {
                Value::Data { bytes, .. } => (e.name, bytes),
                Value::Point { .. } => unreachable!(),
            })
            .collect()
    }

    #[test]
    fn values_are_restored_committed_with_the_scan_and_kept_over_a_restart() {
        let r = Registry::new(
            "r.retain".into(),
            &[
                data("iec/total", "LREAL", &[1]),
                data("gone/x", "INT", &[2]),
            ],
        );
        r.new_instance("iec");
        let total = r.register("iec", "total", "LREAL").unwrap();
        let fresh = r.register("iec", "fresh", "INT").unwrap();
        assert_eq!((total.get(), fresh.get()), (Some(vec![1]), None));
        assert_eq!(r.unclaimed(), vec!["gone/x".to_string()]);
        let m = r.module("iec");
        total.set([5]);
        // Set but not committed: a snapshot still holds the old value.
        assert_eq!(snapshot(&r), vec![("iec/total".into(), vec![1])]);
        m.commit(|| {});
        assert_eq!(snapshot(&r), vec![("iec/total".into(), vec![5])]);
        // A failed scan's values are dropped.
        total.set([6]);
        m.discard();
        m.commit(|| {});
        assert_eq!(total.get(), Some(vec![5]));
        // A restart: the new instance gets the committed value; the old handle is ignored.
        r.new_instance("iec");
        let again = r.register("iec", "total", "LREAL").unwrap();
        assert_eq!(again.get(), Some(vec![5]));
        total.set([9]);
        again.set([7]);
        m.commit(|| {});
        assert_eq!(again.get(), Some(vec![7]));
        assert!(r.register("iec", "total", "LREAL").is_err());
    }

    #[test]
    fn a_changed_signature_is_refused_and_a_half_done_commit_is_waited_for() {
        let r = Registry::new("r.retain".into(), &[data("iec/total", "LREAL", &[1])]);
        let e = r.register("iec", "total", "REAL").unwrap_err().to_string();
        assert!(
            e.starts_with(
                "retain file r.retain: `total` of module iec was stored as `LREAL` and the \
                 module now keeps it as `REAL`"
            ),
            "{e}"
        );
        let t = r.register("iec", "t", "INT").unwrap();
        let m = r.module("iec");
        m.commit(|| {
            t.set([1]);
            let mut out = Vec::new();
            assert!(
                !r.snapshot(&mut out),
                "a commit under way must be waited for"
            );
        });
        assert_eq!(snapshot(&r), vec![("iec/t".into(), vec![1])]);
    }

    #[test]
    fn registries_are_found_by_plc_id() {
        let r = Arc::new(Registry::new("r.retain".into(), &[]));
        install("p1", &r);
        assert!(installed("p1").is_some() && installed("p2").is_none());
        uninstall("p1");
        assert!(installed("p1").is_none());
        let v = Retained::volatile("x", "INT");
        v.set([3]);
        assert_eq!(v.get(), Some(vec![3]));
    }
}
