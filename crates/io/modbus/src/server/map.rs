//! The server's address map: the table rows of the module's section checked against the
//! points (built once at init, then read-only), and the register image the network serves
//! (the values of the mapped addresses, refreshed each scan and by client writes).

use petriplc_config::{Origin, PointKind, PointValue, Row};
use petriplc_runtime::image::{Handle, ModuleMap};

use crate::value::{self, RegisterType, WordOrder};

/// The four Modbus data tables, ordered as the client visits them in a cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Table {
    Coil,
    DiscreteInput,
    Holding,
    Input,
}

/// Every spelling of each table a row may start with.
pub const TABLE_NAMES: &[(&str, Table)] = &[
    ("coil", Table::Coil),
    ("coils", Table::Coil),
    ("0x", Table::Coil),
    ("discrete_input", Table::DiscreteInput),
    ("discrete_inputs", Table::DiscreteInput),
    ("discrete", Table::DiscreteInput),
    ("input_status", Table::DiscreteInput),
    ("1x", Table::DiscreteInput),
    ("holding", Table::Holding),
    ("holding_register", Table::Holding),
    ("holding_registers", Table::Holding),
    ("register", Table::Holding),
    ("4x", Table::Holding),
    ("input", Table::Input),
    ("input_register", Table::Input),
    ("input_registers", Table::Input),
    ("3x", Table::Input),
];

impl Table {
    pub const ALL: [Table; 4] = [
        Table::Coil,
        Table::DiscreteInput,
        Table::Holding,
        Table::Input,
    ];

    pub fn parse(name: &str) -> Option<Table> {
        let lower = name.to_ascii_lowercase();
        TABLE_NAMES
            .iter()
            .find(|(n, _)| *n == lower)
            .map(|&(_, t)| t)
    }

    pub fn name(self) -> &'static str {
        match self {
            Table::Coil => "coil",
            Table::DiscreteInput => "discrete_input",
            Table::Holding => "holding",
            Table::Input => "input",
        }
    }

    /// Coils and discrete inputs hold bits; the others 16-bit registers.
    pub fn is_bits(self) -> bool {
        matches!(self, Table::Coil | Table::DiscreteInput)
    }

    /// Whether clients may write the table at all (coils and holding registers).
    pub fn is_writable(self) -> bool {
        matches!(self, Table::Coil | Table::Holding)
    }

    fn index(self) -> usize {
        self as usize
    }
}

/// One table row: a point at an address.
#[derive(Clone, Debug)]
pub struct Entry {
    pub table: Table,
    pub address: u16,
    /// Addresses taken: 1 for a bit or a 16-bit type, 2 for a 32-bit type.
    pub width: u16,
    /// Index into [`AddressMap::points`].
    pub point: u32,
    /// `U16` in the bit tables, where it means nothing.
    pub ty: RegisterType,
    pub order: WordOrder,
    /// Clients may write it: a coil or holding row of a point the server owns.
    pub writable: bool,
    pub origin: Origin,
}

/// A point the map exposes, with every row that shows it.
#[derive(Clone, Debug)]
pub struct MappedPoint {
    pub name: String,
    pub handle: Handle,
    pub kind: PointKind,
    pub bits: u8,
    pub entries: Vec<u32>,
}

const NONE: u32 = u32::MAX;

/// One table's addresses, dense over the span from its lowest to its highest mapped address.
#[derive(Clone, Debug, Default)]
pub struct TableIndex {
    base: u32,
    /// Per address from `base`: the entry there, or `NONE`.
    slot: Vec<u32>,
    /// Per address: the end (exclusive, absolute) of the run of mapped addresses holding it,
    /// so that "is this range fully mapped" is one look-up.
    run_end: Vec<u32>,
    /// The same for runs of writable addresses.
    write_end: Vec<u32>,
}

impl TableIndex {
    /// The span's length: the image keeps one value per address of it.
    pub fn span(&self) -> usize {
        self.slot.len()
    }

    fn rel(&self, address: u32) -> Option<usize> {
        let r = address.checked_sub(self.base)? as usize;
        (r < self.slot.len()).then_some(r)
    }

    /// Where in the image `[address, address + count)` is, if every address is mapped.
    pub fn readable(&self, address: u16, count: u16) -> Option<usize> {
        let end = u32::from(address) + u32::from(count);
        let r = self.rel(u32::from(address))?;
        (self.run_end[r] >= end).then_some(r)
    }

    /// Where in the image `[address, address + count)` is, if every address is writable.
    pub fn writable(&self, address: u16, count: u16) -> Option<usize> {
        let end = u32::from(address) + u32::from(count);
        let r = self.rel(u32::from(address))?;
        (self.write_end[r] >= end).then_some(r)
    }

    /// The entry at image position `rel`.
    pub fn entry_at(&self, rel: usize) -> Option<u32> {
        self.slot.get(rel).copied().filter(|&e| e != NONE)
    }

    /// The image position of `address` (which must be in the span).
    pub fn position(&self, address: u16) -> Option<usize> {
        self.rel(u32::from(address))
    }
}

/// Every row of the section, checked, and the look-ups the protocol needs.
#[derive(Clone, Debug, Default)]
pub struct AddressMap {
    pub entries: Vec<Entry>,
    pub points: Vec<MappedPoint>,
    tables: [TableIndex; 4],
}

impl AddressMap {
    /// Reads the table rows (every spelling in [`TABLE_NAMES`]): `TABLE ADDRESS POINT [TYPE]
    /// [ORDER]`. Every problem is reported, one per line, each with the row's file:line.
    pub fn build(
        rows: &[&Row],
        map: &ModuleMap,
        default_order: WordOrder,
    ) -> Result<AddressMap, Vec<String>> {
        let mut problems = Vec::new();
        let mut out = AddressMap::default();
        for row in rows {
            match out.entry(row, map, default_order) {
                Ok(e) => {
                    let idx = out.entries.len() as u32;
                    out.points[e.point as usize].entries.push(idx);
                    out.entries.push(e);
                }
                Err(why) => problems.push(format!("{}: {why}", row.origin)),
            }
        }
        for table in Table::ALL {
            if let Err(mut p) = out.index(table) {
                problems.append(&mut p);
            }
        }
        if problems.is_empty() {
            Ok(out)
        } else {
            Err(problems)
        }
    }

    pub fn table(&self, t: Table) -> &TableIndex {
        &self.tables[t.index()]
    }

    fn entry(
        &mut self,
        row: &Row,
        map: &ModuleMap,
        default_order: WordOrder,
    ) -> Result<Entry, String> {
        let Some(table) = Table::parse(&row.table) else {
            return Err(format!(
                "unknown table `{}`; a modbus_server reads coil, discrete_input, holding and \
                 input rows (see docs/modbus.md for their other names)",
                row.table
            ));
        };
        let t = table.name();
        let usage = if table.is_bits() {
            format!("`{t} ADDRESS POINT`")
        } else {
            format!("`{t} ADDRESS POINT [u16|i16|u32|i32|f32] [high_first|low_first]`")
        };
        let (address, point, rest) = match row.cells.as_slice() {
            [a, p, rest @ ..] if rest.len() <= if table.is_bits() { 0 } else { 2 } => (a, p, rest),
            _ => return Err(format!("a {t} row is {usage}")),
        };
        let address = parse_address(address).ok_or_else(|| {
            format!(
                "address `{address}` is not valid; write a number from 0 to 65535 (decimal or \
                 0x hex), the 0-based address on the wire"
            )
        })?;
        let handle = map.handle(point).map_err(|e| {
            format!("{e}; declare `point {point} ...` in [PLC] or fix the name in the row")
        })?;
        let (kind, bits) = (handle.kind(), handle.bits());
        let owned = map.owns(&handle);
        let (mut ty, mut order) = (value::default_type(kind, bits), default_order);
        let mut saw_type = false;
        let mut saw_order = false;
        for cell in rest {
            if let Some(t) = RegisterType::parse(cell) {
                if saw_type || saw_order {
                    return Err(format!(
                        "`{cell}`: write the type once, before the word order: {usage}"
                    ));
                }
                ty = t;
                saw_type = true;
            } else if let Some(o) = WordOrder::parse(cell) {
                if saw_order {
                    return Err(format!("the word order is written twice: {usage}"));
                }
                order = o;
                saw_order = true;
            } else {
                return Err(format!(
                    "`{cell}` is neither a register type (u16, i16, u32, i32, f32) nor a word \
                     order (high_first, low_first): {usage}"
                ));
            }
        }
        let what = describe(kind, bits);
        if table.is_bits() {
            if kind == PointKind::Float {
                return Err(format!(
                    "point `{point}` is {what}: a {t} is one bit; expose it in a holding or \
                     input row (f32), or declare a bool point"
                ));
            }
            if kind == PointKind::Signed && bits == 1 {
                return Err(format!(
                    "point `{point}` is {what}, which cannot hold 1 (on): declare it `u1` (a bool)"
                ));
            }
        } else {
            if !ty.holds(kind, bits) {
                let fix = value::default_type(kind, bits);
                return Err(format!(
                    "type {ty} cannot hold point `{point}` ({what}); use {fix}, or leave the \
                     type out for {fix}"
                ));
            }
            if saw_order && ty.registers() == 1 {
                return Err(format!(
                    "a word order means nothing for {ty}, a one-register type; remove \
                     `{}` or use a 32-bit type",
                    order
                ));
            }
        }
        let width = if table.is_bits() {
            1
        } else {
            ty.registers() as u16
        };
        if u32::from(address) + u32::from(width) > 65536 {
            return Err(format!(
                "{ty} at address {address} takes {width} registers and ends past 65535; use an \
                 address up to {}",
                65536 - u32::from(width)
            ));
        }
        let point_idx = match self.points.iter().position(|p| p.name == *point) {
            Some(i) => i,
            None => {
                self.points.push(MappedPoint {
                    name: point.clone(),
                    handle,
                    kind,
                    bits,
                    entries: Vec::new(),
                });
                self.points.len() - 1
            }
        };
        Ok(Entry {
            table,
            address,
            width,
            point: point_idx as u32,
            ty: if table.is_bits() {
                RegisterType::U16
            } else {
                ty
            },
            order,
            writable: table.is_writable() && owned,
            origin: row.origin.clone(),
        })
    }

    fn index(&mut self, table: Table) -> Result<(), Vec<String>> {
        let mut rows: Vec<u32> = (0..self.entries.len() as u32)
            .filter(|&i| self.entries[i as usize].table == table)
            .collect();
        if rows.is_empty() {
            return Ok(());
        }
        rows.sort_by_key(|&i| self.entries[i as usize].address);
        let lo = u32::from(self.entries[rows[0] as usize].address);
        let hi = rows
            .iter()
            .map(|&i| {
                let e = &self.entries[i as usize];
                u32::from(e.address) + u32::from(e.width)
            })
            .max()
            .unwrap_or(lo);
        let span = (hi - lo) as usize;
        let mut slot = vec![NONE; span];
        let mut problems = Vec::new();
        for &i in &rows {
            let e = &self.entries[i as usize];
            for a in u32::from(e.address)..u32::from(e.address) + u32::from(e.width) {
                let s = &mut slot[(a - lo) as usize];
                if *s != NONE {
                    let other = &self.entries[*s as usize];
                    problems.push(format!(
                        "{}: {} address {a} of point `{}` is already taken by point `{}` ({}); \
                         move one of the rows",
                        e.origin,
                        table.name(),
                        self.points[e.point as usize].name,
                        self.points[other.point as usize].name,
                        other.origin
                    ));
                    break;
                }
                *s = i;
            }
        }
        // 0 where the address does not qualify, so that no range starting there does.
        let ends = |ok: &dyn Fn(u32) -> bool| {
            let mut end = vec![0u32; span];
            for r in (0..span).rev() {
                if ok(slot[r]) {
                    end[r] = match end.get(r + 1) {
                        Some(&e) if e != 0 => e,
                        _ => lo + r as u32 + 1,
                    };
                }
            }
            end
        };
        let run_end = ends(&|s| s != NONE);
        let write_end = ends(&|s| s != NONE && self.entries[s as usize].writable);
        self.tables[table.index()] = TableIndex {
            base: lo,
            slot,
            run_end,
            write_end,
        };
        if problems.is_empty() {
            Ok(())
        } else {
            Err(problems)
        }
    }
}

/// `12` or `0x0C`.
fn parse_address(text: &str) -> Option<u16> {
    let t = text.trim();
    match t.strip_prefix("0x").or_else(|| t.strip_prefix("0X")) {
        Some(hex) => u16::from_str_radix(hex, 16).ok(),
        None => t.parse().ok(),
    }
}

fn describe(kind: PointKind, bits: u8) -> String {
    match (kind, bits) {
        (PointKind::Unsigned, 1) => "a bool".to_string(),
        (PointKind::Unsigned, b) => format!("u{b}"),
        (PointKind::Signed, b) => format!("i{b}"),
        (PointKind::Float, _) => "a float".to_string(),
    }
}

/// The values the network serves, one per mapped address of each table's span (bits as 0 or
/// 1), the client writes not yet applied to the points, and which points had a value refused
/// since their last accepted write.
#[derive(Debug, Default)]
pub struct Image {
    pub values: [Vec<u16>; 4],
    /// Point index and value, in arrival order; drained by each scan.
    pub pending: Vec<(u32, PointValue)>,
    /// Per point: a refused value was logged, and no write to it has been accepted since
    /// (further refusals are only counted).
    refusing: Vec<bool>,
}

impl Image {
    pub fn new(map: &AddressMap) -> Image {
        Image {
            values: Table::ALL.map(|t| vec![0u16; map.table(t).span()]),
            pending: Vec::new(),
            refusing: vec![false; map.points.len()],
        }
    }

    /// A value written to point `p` was refused: whether this is the first since the point
    /// last accepted one (the refusal to log).
    pub fn refuse(&mut self, p: u32) -> bool {
        match self.refusing.get_mut(p as usize) {
            Some(r) => !std::mem::replace(r, true),
            None => false,
        }
    }

    pub fn table(&self, t: Table) -> &[u16] {
        &self.values[t.index()]
    }

    /// Shows `v` at every row of point `p`.
    pub fn show(&mut self, map: &AddressMap, p: u32, v: PointValue) {
        for &e in &map.points[p as usize].entries {
            let e = &map.entries[e as usize];
            let Some(pos) = map.table(e.table).position(e.address) else {
                continue;
            };
            let values = &mut self.values[e.table.index()];
            if e.table.is_bits() {
                values[pos] = u16::from(value::to_bit(v));
            } else {
                let words = value::encode(v, e.ty, e.order);
                let n = usize::from(e.width);
                values[pos..pos + n].copy_from_slice(&words[..n]);
            }
        }
    }

    /// A client's write: shown at once, applied to the point at the next scan.
    pub fn write(&mut self, map: &AddressMap, p: u32, v: PointValue) {
        self.show(map, p, v);
        if let Some(r) = self.refusing.get_mut(p as usize) {
            *r = false;
        }
        // While the module does not scan (held by the synchronisation net, say) writes pile
        // up; only the last per point can matter, since a scan applies them all before any
        // other module sees one.
        if self.pending.len() >= PENDING_LIMIT.max(2 * map.points.len()) {
            coalesce(&mut self.pending, map.points.len());
        }
        self.pending.push((p, v));
    }

    /// Every mapped point's current value from the module's map: one consistent snapshot.
    pub fn refresh(&mut self, map: &AddressMap, points: &ModuleMap) {
        for (i, p) in map.points.iter().enumerate() {
            self.show(map, i as u32, points.get(&p.handle));
        }
    }
}

/// Queued writes beyond which they are coalesced.
const PENDING_LIMIT: usize = 1024;

/// Keeps the last write of each point, in the order of those last writes.
fn coalesce(pending: &mut Vec<(u32, PointValue)>, points: usize) {
    let mut seen = vec![false; points];
    let mut kept: Vec<(u32, PointValue)> = pending
        .iter()
        .rev()
        .filter(|(p, _)| match seen.get_mut(*p as usize) {
            Some(s) if !*s => {
                *s = true;
                true
            }
            _ => false,
        })
        .copied()
        .collect();
    kept.reverse();
    *pending = kept;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coalescing_keeps_the_last_write_of_each_point() {
        let u = PointValue::Unsigned;
        let mut pending = vec![(0, u(1)), (1, u(2)), (0, u(3)), (2, u(4)), (1, u(5))];
        coalesce(&mut pending, 3);
        assert_eq!(pending, [(0, u(3)), (2, u(4)), (1, u(5))]);
    }

    #[test]
    fn table_names() {
        assert_eq!(Table::parse("coil"), Some(Table::Coil));
        assert_eq!(Table::parse("HOLDING"), Some(Table::Holding));
        assert_eq!(Table::parse("3x"), Some(Table::Input));
        assert_eq!(Table::parse("input_status"), Some(Table::DiscreteInput));
        assert_eq!(Table::parse("registers"), None);
        for (name, t) in TABLE_NAMES {
            assert_eq!(Table::parse(name), Some(*t));
        }
    }

    #[test]
    fn addresses() {
        assert_eq!(parse_address("0"), Some(0));
        assert_eq!(parse_address("65535"), Some(65535));
        assert_eq!(parse_address("0x10"), Some(16));
        assert_eq!(parse_address("65536"), None);
        assert_eq!(parse_address("-1"), None);
        assert_eq!(parse_address("4x1"), None);
    }
}
