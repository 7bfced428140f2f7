//! The `modbus_client` section read into devices and point rows: `device`, `read`, `write`
//! and `stale` rows checked against each other and against the points, every problem
//! reported at once with the row's file:line and how to fix it.

use std::collections::BTreeMap;
use std::time::Duration;

use petriplc_config::{Origin, PointKind, Row};
use petriplc_modules::common::{self, error};
use petriplc_net::time::parse_duration;
use petriplc_runtime::image::{Handle, ModuleMap};
use petriplc_runtime::module::{InitContext, ModuleError};

use crate::serial::SerialSettings;
use crate::value::{default_type, RegisterType, WordOrder};

use super::KIND;

/// A device's timeout when its row gives none.
pub const DEFAULT_TIMEOUT: Duration = Duration::from_secs(1);

/// The four Modbus tables (the server's type: the same spellings; a cycle visits them in
/// their declaration order).
pub use crate::server::Table;

/// Where a device is reached.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Endpoint {
    /// `tcp:HOST:PORT`; the host is resolved at each connection.
    Tcp { host: String, port: u16 },
    /// `rtu:PATH[:BAUD[:FRAME]]`.
    Rtu(SerialSettings),
}

impl Endpoint {
    pub fn parse(text: &str) -> Result<Endpoint, String> {
        const FORMS: &str = "`tcp:HOST:PORT` (e.g. tcp:192.168.1.20:502) or \
                             `rtu:PATH:BAUD:FRAME` (e.g. rtu:/dev/ttyUSB0:19200:8E1)";
        if let Some(rest) = text.strip_prefix("tcp:") {
            let Some((host, port)) = rest.rsplit_once(':') else {
                return Err(format!(
                    "endpoint `{text}` has no port; write `tcp:HOST:PORT`, e.g. tcp:{rest}:502"
                ));
            };
            let host = host
                .strip_prefix('[')
                .and_then(|h| h.strip_suffix(']'))
                .unwrap_or(host);
            if host.is_empty() {
                return Err(format!(
                    "endpoint `{text}` has no host; write `tcp:HOST:PORT`, e.g. \
                     tcp:127.0.0.1:{port}"
                ));
            }
            match port.parse::<u16>() {
                Ok(p) if p > 0 => Ok(Endpoint::Tcp {
                    host: host.to_string(),
                    port: p,
                }),
                _ => Err(format!(
                    "endpoint `{text}`: port `{port}` is not valid; write a port from 1 to \
                     65535 (Modbus TCP's is 502)"
                )),
            }
        } else if let Some(rest) = text.strip_prefix("rtu:") {
            SerialSettings::parse(rest)
                .map(Endpoint::Rtu)
                .map_err(|e| format!("endpoint `{text}`: {e}"))
        } else {
            Err(format!("endpoint `{text}` is not valid; write {FORMS}"))
        }
    }
}

impl std::fmt::Display for Endpoint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Endpoint::Tcp { host, port } if host.contains(':') => write!(f, "tcp:[{host}]:{port}"),
            Endpoint::Tcp { host, port } => write!(f, "tcp:{host}:{port}"),
            Endpoint::Rtu(s) => write!(f, "rtu:{s}"),
        }
    }
}

/// `device NAME ENDPOINT UNIT PERIOD [TIMEOUT]`
#[derive(Clone, Debug)]
pub struct DeviceSpec {
    pub name: String,
    pub endpoint: Endpoint,
    pub unit: u8,
    pub period: Duration,
    pub timeout: Duration,
}

/// `read|write DEVICE TABLE ADDRESS POINT [TYPE] [ORDER]`
#[derive(Clone, Debug)]
pub struct PointRow {
    /// Index into [`Spec::devices`].
    pub device: usize,
    pub table: Table,
    pub address: u16,
    pub point: String,
    pub handle: Handle,
    /// The register type (`U16` for the bit tables, where it is not used).
    pub ty: RegisterType,
    pub order: WordOrder,
    pub origin: Origin,
}

impl PointRow {
    /// How many addresses of its table the row takes.
    pub fn width(&self) -> u16 {
        if self.table.is_bits() {
            1
        } else {
            self.ty.registers() as u16
        }
    }
}

/// A section read and checked.
#[derive(Debug)]
pub struct Spec {
    pub devices: Vec<DeviceSpec>,
    pub reads: Vec<PointRow>,
    pub writes: Vec<PointRow>,
    /// Per device, its `stale` point.
    pub stale: Vec<Option<(String, Handle)>>,
}

const DEVICE_SYNTAX: &str = "`device NAME ENDPOINT UNIT PERIOD [TIMEOUT]`";

fn rw_syntax(table: &str) -> String {
    format!("`{table} DEVICE TABLE ADDRESS POINT [TYPE] [WORD_ORDER]`")
}

/// Reads the rows of the module's section.
pub fn read(ctx: &InitContext<'_>) -> Result<Spec, ModuleError> {
    let module = ctx.decl.name.as_str();
    let rows = common::rows(ctx, KIND, &["device", "read", "write", "stale"])?;
    let mut p = Problems::default();
    let mut devices: Vec<DeviceSpec> = Vec::new();
    let mut by_name: BTreeMap<String, (usize, Origin)> = BTreeMap::new();
    // Devices first, so that rows may name a device declared further down.
    for row in rows.iter().filter(|r| r.table == "device") {
        if let Some(d) = device(row, &mut p) {
            if let Some((_, first)) = by_name.get(&d.name) {
                p.at(
                    row,
                    format!(
                        "device `{}` is declared twice (first at {first}); give each device its \
                         own name",
                        d.name
                    ),
                );
                continue;
            }
            by_name.insert(d.name.clone(), (devices.len(), row.origin.clone()));
            devices.push(d);
        }
    }
    if devices.is_empty() && p.list.is_empty() {
        p.list.push(format!(
            "no devices: add rows {DEVICE_SYNTAX} to section [{module}], e.g. `device drive \
             tcp:192.168.1.20:502 1 100ms`"
        ));
    }
    check_serial_lines(&devices, &rows, &mut p);

    let mut reads = Vec::new();
    let mut writes = Vec::new();
    let mut stale: Vec<Option<(String, Handle)>> = vec![None; devices.len()];
    // Which row first used each point, to refuse a second source of the same point.
    let mut sourced: BTreeMap<String, Origin> = BTreeMap::new();
    for row in &rows {
        let find = |name: &str, p: &mut Problems| -> Option<usize> {
            let found = by_name.get(name).map(|(i, _)| *i);
            if found.is_none() {
                let known: Vec<&str> = devices.iter().map(|d| d.name.as_str()).collect();
                p.at(
                    row,
                    format!(
                        "unknown device `{name}`; declare it with {DEVICE_SYNTAX} (devices: {})",
                        if known.is_empty() {
                            "none".to_string()
                        } else {
                            known.join(", ")
                        }
                    ),
                );
            }
            found
        };
        match row.table.as_str() {
            "read" | "write" => {
                let write = row.table == "write";
                let Some(r) = point_row(row, write, ctx.map, &mut p, |n, p| find(n, p)) else {
                    continue;
                };
                if !write {
                    if !claim(&mut sourced, &r.point, row, &mut p) {
                        continue;
                    }
                    if !ctx.map.owns(&r.handle) {
                        p.at(
                            row,
                            not_owned(ctx.map, module, &r.point, &r.handle, "read into"),
                        );
                        continue;
                    }
                }
                if write {
                    writes.push(r);
                } else {
                    reads.push(r);
                }
            }
            "stale" => {
                let [dev, point] = row.cells.as_slice() else {
                    p.at(
                        row,
                        "a stale row is `stale DEVICE POINT` (a bool point of this module, true \
                         while the device does not answer)",
                    );
                    continue;
                };
                let Some(d) = find(dev, &mut p) else {
                    continue;
                };
                let Some(h) = handle(ctx.map, point, row, module, &mut p) else {
                    continue;
                };
                if !ctx.map.owns(&h) {
                    p.at(row, not_owned(ctx.map, module, point, &h, "set"));
                    continue;
                }
                if h.kind() == PointKind::Float {
                    p.at(
                        row,
                        format!(
                            "stale point `{point}` is a float point; declare it as a bool: \
                             `point {point} \"...\" {module}`"
                        ),
                    );
                    continue;
                }
                if let Some((first, _)) = &stale[d] {
                    p.at(
                        row,
                        format!(
                            "device `{dev}` already has stale point `{first}`; keep one stale \
                             row per device"
                        ),
                    );
                    continue;
                }
                if !claim(&mut sourced, point, row, &mut p) {
                    continue;
                }
                stale[d] = Some((point.clone(), h));
            }
            _ => {}
        }
    }
    check_overlapping_writes(&writes, &devices, &mut p);
    for d in &devices {
        let used = rows
            .iter()
            .any(|r| (r.table == "read" || r.table == "write") && r.cells.first() == Some(&d.name));
        if !used {
            p.list.push(format!(
                "device `{}` has no read or write rows; add some (e.g. `read {} holding 0 \
                 POINT`) or remove the device",
                d.name, d.name
            ));
        }
    }
    if !p.list.is_empty() {
        return Err(error(module, p.list.join(&format!("\nmodule {module}: "))));
    }
    Ok(Spec {
        devices,
        reads,
        writes,
        stale,
    })
}

#[derive(Default)]
struct Problems {
    list: Vec<String>,
}

impl Problems {
    fn at(&mut self, row: &Row, message: impl std::fmt::Display) {
        self.list.push(format!("{}: {message}", row.origin));
    }
}

fn device(row: &Row, p: &mut Problems) -> Option<DeviceSpec> {
    let (name, endpoint, unit, period, timeout) = match row.cells.as_slice() {
        [n, e, u, per] => (n, e, u, per, None),
        [n, e, u, per, t] => (n, e, u, per, Some(t)),
        _ => {
            p.at(
                row,
                format!(
                    "a device row is {DEVICE_SYNTAX}, e.g. `device drive tcp:192.168.1.20:502 1 \
                     100ms 500ms`"
                ),
            );
            return None;
        }
    };
    let before = p.list.len();
    let endpoint = Endpoint::parse(endpoint)
        .map_err(|e| p.at(row, format!("device `{name}`: {e}")))
        .ok();
    let unit = match (unit.parse::<u16>(), &endpoint) {
        (Ok(u @ 1..=247), _) => Some(u as u8),
        (Ok(u @ (0 | 255)), Some(Endpoint::Tcp { .. })) => Some(u as u8),
        (Ok(0), Some(Endpoint::Rtu(_))) => {
            p.at(
                row,
                format!(
                    "device `{name}`: unit 0 is the RTU broadcast address, which no device \
                     answers; this client waits for every answer, so give each device's own \
                     unit (1 to 247)"
                ),
            );
            None
        }
        _ => {
            p.at(
                row,
                format!(
                    "device `{name}`: unit `{unit}` is not valid; write the device's unit \
                     (slave) id, 1 to 247 (on TCP also 0 or 255, which a TCP device itself \
                     answers)"
                ),
            );
            None
        }
    };
    let mut duration = |what: &str, text: &str| match parse_duration(text) {
        Ok(d) if !d.is_zero() => Some(d),
        Ok(_) => {
            p.at(
                row,
                format!("device `{name}`: the {what} must be more than 0, e.g. 100ms"),
            );
            None
        }
        Err(e) => {
            p.at(row, format!("device `{name}`: {what}: {e}"));
            None
        }
    };
    let period = duration("period", period);
    let timeout = match timeout {
        Some(t) => duration("timeout", t),
        None => Some(DEFAULT_TIMEOUT),
    };
    if p.list.len() > before {
        return None;
    }
    Some(DeviceSpec {
        name: name.clone(),
        endpoint: endpoint?,
        unit: unit?,
        period: period?,
        timeout: timeout?,
    })
}

/// Devices on one serial port share it (a multi-drop line): they must agree on its settings
/// and have distinct units.
fn check_serial_lines(devices: &[DeviceSpec], rows: &[&Row], p: &mut Problems) {
    let origin = |name: &str| {
        rows.iter()
            .find(|r| r.table == "device" && r.cells.first().map(String::as_str) == Some(name))
            .map(|r| r.origin.to_string())
            .unwrap_or_default()
    };
    for (i, a) in devices.iter().enumerate() {
        let Endpoint::Rtu(sa) = &a.endpoint else {
            continue;
        };
        if let Some(b) = devices[..i].iter().find(|b| match &b.endpoint {
            Endpoint::Rtu(sb) => sb.path == sa.path,
            _ => false,
        }) {
            let Endpoint::Rtu(sb) = &b.endpoint else {
                continue;
            };
            if sb != sa {
                p.list.push(format!(
                    "{}: device `{}` uses serial port {} as `{sa}` but device `{}` as `{sb}`; \
                     devices on one line share its settings: write the same speed and frame",
                    origin(&a.name),
                    a.name,
                    sa.path.display(),
                    b.name
                ));
            } else if a.unit == b.unit {
                p.list.push(format!(
                    "{}: devices `{}` and `{}` are both unit {} on serial port {}; give each \
                     device on a line its own unit",
                    origin(&a.name),
                    b.name,
                    a.name,
                    a.unit,
                    sa.path.display()
                ));
            }
        }
    }
}

fn point_row(
    row: &Row,
    write: bool,
    map: &ModuleMap,
    p: &mut Problems,
    find: impl Fn(&str, &mut Problems) -> Option<usize>,
) -> Option<PointRow> {
    let what = row.table.as_str();
    let [dev, table, address, point, rest @ ..] = row.cells.as_slice() else {
        p.at(row, format!("a {what} row is {}", rw_syntax(what)));
        return None;
    };
    let device = find(dev, p);
    let table_ok = match Table::parse(table) {
        Some(t) if write && !t.is_writable() => {
            p.at(
                row,
                format!("table `{table}` is read-only in Modbus; write to `coil` or `holding`"),
            );
            None
        }
        Some(t) => Some(t),
        None => {
            let tables = if write {
                "coil or holding"
            } else {
                "coil, discrete_input, holding or input"
            };
            p.at(row, format!("unknown table `{table}`; write {tables}"));
            None
        }
    };
    let address = parse_address(address)
        .map_err(|()| {
            p.at(
                row,
                format!(
                    "address `{address}` is not valid; write the protocol address 0 to 65535 \
                     (register 40001 is holding address 0)"
                ),
            )
        })
        .ok();
    let h = handle(map, point, row, map.module(), p);
    let (device, table, address, h) = (device?, table_ok?, address?, h?);

    let mut ty = None;
    let mut order = None;
    for cell in rest {
        if let Some(t) = RegisterType::parse(cell) {
            if ty.replace(t).is_some() {
                p.at(row, format!("a second register type `{cell}`; keep one"));
                return None;
            }
        } else if let Some(o) = WordOrder::parse(cell) {
            if order.replace(o).is_some() {
                p.at(row, format!("a second word order `{cell}`; keep one"));
                return None;
            }
        } else {
            p.at(
                row,
                format!(
                    "`{cell}` is neither a register type (u16, i16, u32, i32, f32) nor a word \
                     order (high_first, low_first): {}",
                    rw_syntax(what)
                ),
            );
            return None;
        }
    }
    if table.is_bits() {
        if ty.is_some() || order.is_some() {
            p.at(
                row,
                format!(
                    "a {} carries one bit: remove the register type and word order",
                    table.name()
                ),
            );
            return None;
        }
        if h.kind() == PointKind::Float {
            p.at(
                row,
                format!(
                    "point `{point}` is a float point; a {} carries one bit: use a bool (or \
                     integer) point",
                    table.name()
                ),
            );
            return None;
        }
    }
    let ty = ty.unwrap_or_else(|| default_type(h.kind(), h.bits()));
    if order.is_some() && ty.registers() == 1 {
        p.at(
            row,
            format!(
                "a word order only applies to two-register types (u32, i32, f32), not to {ty}: \
                 remove it"
            ),
        );
        return None;
    }
    if !table.is_bits() {
        let lossy = if write {
            // Writes out: the type must carry every value the point holds.
            !ty.holds(h.kind(), h.bits())
        } else {
            // Reads in: integers into integer points (out-of-range values are reported when
            // they come), floats into float points.
            (ty == RegisterType::F32) != (h.kind() == PointKind::Float)
        };
        if lossy {
            let natural = default_type(h.kind(), h.bits());
            p.at(
                row,
                format!(
                    "point `{point}` ({}{}) cannot be {} as {ty}; use {natural} (the default \
                     for this point: leave the type out) or declare the point to match",
                    kind_letter(h.kind()),
                    h.bits(),
                    if write { "written" } else { "read" },
                ),
            );
            return None;
        }
    }
    if u32::from(address)
        + u32::from(if table.is_bits() {
            1
        } else {
            ty.registers() as u16
        })
        > 65536
    {
        p.at(
            row,
            format!(
                "{ty} at address {address} runs past the last address 65535; read it from a \
                 lower address"
            ),
        );
        return None;
    }
    Some(PointRow {
        device,
        table,
        address,
        point: point.clone(),
        handle: h,
        ty,
        order: order.unwrap_or_default(),
        origin: row.origin.clone(),
    })
}

fn kind_letter(kind: PointKind) -> char {
    match kind {
        PointKind::Unsigned => 'u',
        PointKind::Signed => 'i',
        PointKind::Float => 'f',
    }
}

/// Decimal, or hexadecimal with `0x`.
fn parse_address(text: &str) -> Result<u16, ()> {
    match text.strip_prefix("0x").or_else(|| text.strip_prefix("0X")) {
        Some(hex) => u16::from_str_radix(hex, 16).map_err(|_| ()),
        None => text.parse::<u16>().map_err(|_| ()),
    }
}

fn handle(
    map: &ModuleMap,
    point: &str,
    row: &Row,
    module: &str,
    p: &mut Problems,
) -> Option<Handle> {
    match map.handle(point) {
        Ok(h) => Some(h),
        Err(e) => {
            p.at(
                row,
                format!("{e}; declare it with `point {point} \"...\" {module}` in [PLC]"),
            );
            None
        }
    }
}

fn not_owned(map: &ModuleMap, module: &str, point: &str, h: &Handle, verb: &str) -> String {
    let owner = &map.layout().slot(h.id()).owner;
    format!(
        "point `{point}` is owned by module `{owner}`, and only its owner may write a point: \
         to {verb} it here, declare `point {point} \"...\" {module}`"
    )
}

/// Records that `row` writes `point` into the image; false (with a problem) if another row
/// already does.
fn claim(sourced: &mut BTreeMap<String, Origin>, point: &str, row: &Row, p: &mut Problems) -> bool {
    if let Some(first) = sourced.get(point) {
        p.at(
            row,
            format!(
                "point `{point}` is already set by the row at {first}; a point has one source: \
                 use another point"
            ),
        );
        return false;
    }
    sourced.insert(point.to_string(), row.origin.clone());
    true
}

/// Two write rows that cover the same register or coil of a device would fight over it.
fn check_overlapping_writes(writes: &[PointRow], devices: &[DeviceSpec], p: &mut Problems) {
    let mut sorted: Vec<&PointRow> = writes.iter().collect();
    sorted.sort_by_key(|r| (r.device, r.table, r.address));
    for pair in sorted.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        if a.device == b.device
            && a.table == b.table
            && u32::from(b.address) < u32::from(a.address) + u32::from(a.width())
        {
            p.list.push(format!(
                "{}: `{}` writes {} {} of device `{}`, which the row at {} (`{}`) already \
                 writes; give each written point its own addresses",
                b.origin,
                b.point,
                b.table.name(),
                b.address,
                devices[b.device].name,
                a.origin,
                a.point
            ));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn endpoints() {
        assert_eq!(
            Endpoint::parse("tcp:127.0.0.1:5020"),
            Ok(Endpoint::Tcp {
                host: "127.0.0.1".into(),
                port: 5020
            })
        );
        assert_eq!(
            Endpoint::parse("tcp:[::1]:502").map(|e| e.to_string()),
            Ok("tcp:[::1]:502".to_string())
        );
        assert_eq!(
            Endpoint::parse("rtu:/dev/ttyUSB0:9600:8N1").map(|e| e.to_string()),
            Ok("rtu:/dev/ttyUSB0:9600:8N1".to_string())
        );
        for (text, says) in [
            ("tcp:host", "no port"),
            ("tcp::502", "no host"),
            ("tcp:host:0", "port `0`"),
            ("tcp:host:http", "port `http`"),
            ("rtu:/dev/x:9600:9Z9", "frame `9Z9`"),
            ("udp:host:502", "tcp:HOST:PORT"),
        ] {
            let e = Endpoint::parse(text).unwrap_err();
            assert!(e.contains(says), "{text}: {e}");
        }
    }

    #[test]
    fn tables_and_addresses() {
        assert_eq!(Table::parse("Holding"), Some(Table::Holding));
        assert_eq!(Table::parse("discrete_input"), Some(Table::DiscreteInput));
        assert_eq!(Table::parse("4x"), Some(Table::Holding));
        assert_eq!(Table::parse("regs"), None);
        assert!(Table::Coil.is_writable() && !Table::Input.is_writable());
        assert_eq!(parse_address("0x10"), Ok(16));
        assert_eq!(parse_address("65535"), Ok(65535));
        assert!(parse_address("65536").is_err());
        assert!(parse_address("-1").is_err());
    }
}
