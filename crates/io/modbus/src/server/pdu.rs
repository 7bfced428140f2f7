//! The Modbus application protocol on the server side: one request PDU in, one response PDU
//! (or exception) out, against the address map and the register image. Shared by TCP and RTU.
//!
//! Checks follow the order of the specification's state diagrams (Modbus Application
//! Protocol V1.1b3, section 6): function code (01), then quantity, byte count and length
//! (03), then addresses (02), then values (03); nothing is written unless the whole request
//! is valid. A value its point cannot hold (NaN or ±Inf into a float point, 300 into a `u8`)
//! gets exception 03 like the others, but is returned as a [`BadValue`], which the server
//! logs once per point (docs/modbus.md, Bad values).

use crate::value::{self, Unfit};

use super::map::{AddressMap, Image, Table};

pub const ILLEGAL_FUNCTION: u8 = 0x01;
pub const ILLEGAL_DATA_ADDRESS: u8 = 0x02;
pub const ILLEGAL_DATA_VALUE: u8 = 0x03;

/// The specification's limits on quantities.
pub const MAX_READ_BITS: u16 = 2000;
pub const MAX_WRITE_BITS: u16 = 1968;
pub const MAX_READ_REGISTERS: u16 = 125;
pub const MAX_WRITE_REGISTERS: u16 = 123;
pub const MAX_RW_WRITE_REGISTERS: u16 = 121;

/// A write refused (exception 03) because a value does not fit its point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BadValue {
    /// The row ([`AddressMap::entries`]) the value was written to.
    pub entry: u32,
    /// Its registers as the client wrote them (the second unused for one-register types).
    pub words: [u16; 2],
    pub why: Unfit,
}

/// What [`respond`] answered.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Outcome {
    Served,
    /// An exception response with this code.
    Exception(u8),
    /// Exception 03 for a value its point cannot hold.
    BadValue(BadValue),
}

/// Why a request is refused, inside this module.
enum Fail {
    Code(u8),
    Value(BadValue),
}

impl From<u8> for Fail {
    fn from(code: u8) -> Fail {
        Fail::Code(code)
    }
}

/// Appends the response to `pdu` (function code first) to `out`. An empty PDU gets exception
/// 01 for function code 0.
pub fn respond(map: &AddressMap, image: &mut Image, pdu: &[u8], out: &mut Vec<u8>) -> Outcome {
    let (fc, body) = match pdu.split_first() {
        Some((&fc, body)) => (fc, body),
        None => (0, pdu),
    };
    let start = out.len();
    let (code, outcome) = match handle(map, image, fc, body, out) {
        Ok(()) => return Outcome::Served,
        Err(Fail::Code(code)) => (code, Outcome::Exception(code)),
        Err(Fail::Value(bad)) => (ILLEGAL_DATA_VALUE, Outcome::BadValue(bad)),
    };
    out.truncate(start);
    out.push(fc | 0x80);
    out.push(code);
    outcome
}

fn be(b: &[u8], i: usize) -> u16 {
    u16::from_be_bytes([b[i], b[i + 1]])
}

/// The two 16-bit fields of the fixed-size requests (01-06).
fn two_fields(body: &[u8]) -> Result<(u16, u16), u8> {
    if body.len() != 4 {
        return Err(ILLEGAL_DATA_VALUE);
    }
    Ok((be(body, 0), be(body, 2)))
}

fn quantity(q: u16, max: u16) -> Result<u16, u8> {
    if q == 0 || q > max {
        Err(ILLEGAL_DATA_VALUE)
    } else {
        Ok(q)
    }
}

fn handle(
    map: &AddressMap,
    image: &mut Image,
    fc: u8,
    body: &[u8],
    out: &mut Vec<u8>,
) -> Result<(), Fail> {
    match fc {
        0x01 | 0x02 => {
            let table = if fc == 0x01 {
                Table::Coil
            } else {
                Table::DiscreteInput
            };
            let (address, q) = two_fields(body)?;
            let q = quantity(q, MAX_READ_BITS)?;
            let pos = map
                .table(table)
                .readable(address, q)
                .ok_or(ILLEGAL_DATA_ADDRESS)?;
            let bits = &image.table(table)[pos..pos + usize::from(q)];
            out.push(fc);
            out.push(bits.len().div_ceil(8) as u8);
            for chunk in bits.chunks(8) {
                let byte = chunk
                    .iter()
                    .enumerate()
                    .fold(0u8, |b, (i, &v)| b | (u8::from(v != 0) << i));
                out.push(byte);
            }
            Ok(())
        }
        0x03 | 0x04 => {
            let table = if fc == 0x03 {
                Table::Holding
            } else {
                Table::Input
            };
            let (address, q) = two_fields(body)?;
            let q = quantity(q, MAX_READ_REGISTERS)?;
            let pos = map
                .table(table)
                .readable(address, q)
                .ok_or(ILLEGAL_DATA_ADDRESS)?;
            out.push(fc);
            read_registers(image.table(table), pos, q, out);
            Ok(())
        }
        0x05 => {
            let (address, v) = two_fields(body)?;
            let on = match v {
                0xFF00 => true,
                0x0000 => false,
                _ => return Err(ILLEGAL_DATA_VALUE.into()),
            };
            let t = map.table(Table::Coil);
            let pos = t.writable(address, 1).ok_or(ILLEGAL_DATA_ADDRESS)?;
            write_bit(map, image, pos, on)?;
            out.push(fc);
            out.extend_from_slice(body);
            Ok(())
        }
        0x06 => {
            let (address, _) = two_fields(body)?;
            write_registers(map, image, address, 1, &body[2..4])?;
            out.push(fc);
            out.extend_from_slice(body);
            Ok(())
        }
        0x0F => {
            if body.len() < 5 {
                return Err(ILLEGAL_DATA_VALUE.into());
            }
            let (address, q, count) = (be(body, 0), be(body, 2), body[4]);
            let q = quantity(q, MAX_WRITE_BITS)?;
            let data = &body[5..];
            if usize::from(count) != usize::from(q).div_ceil(8) || data.len() != usize::from(count)
            {
                return Err(ILLEGAL_DATA_VALUE.into());
            }
            let t = map.table(Table::Coil);
            let pos = t.writable(address, q).ok_or(ILLEGAL_DATA_ADDRESS)?;
            for i in 0..usize::from(q) {
                let on = data[i / 8] & (1 << (i % 8)) != 0;
                write_bit(map, image, pos + i, on)?;
            }
            out.push(fc);
            out.extend_from_slice(&body[..4]);
            Ok(())
        }
        0x10 => {
            if body.len() < 5 {
                return Err(ILLEGAL_DATA_VALUE.into());
            }
            let (address, q, count) = (be(body, 0), be(body, 2), body[4]);
            let q = quantity(q, MAX_WRITE_REGISTERS)?;
            let data = &body[5..];
            if usize::from(count) != 2 * usize::from(q) || data.len() != usize::from(count) {
                return Err(ILLEGAL_DATA_VALUE.into());
            }
            write_registers(map, image, address, q, data)?;
            out.push(fc);
            out.extend_from_slice(&body[..4]);
            Ok(())
        }
        0x17 => {
            if body.len() < 9 {
                return Err(ILLEGAL_DATA_VALUE.into());
            }
            let (read_address, rq) = (be(body, 0), be(body, 2));
            let (write_address, wq, count) = (be(body, 4), be(body, 6), body[8]);
            let rq = quantity(rq, MAX_READ_REGISTERS)?;
            let wq = quantity(wq, MAX_RW_WRITE_REGISTERS)?;
            let data = &body[9..];
            if usize::from(count) != 2 * usize::from(wq) || data.len() != usize::from(count) {
                return Err(ILLEGAL_DATA_VALUE.into());
            }
            let holding = map.table(Table::Holding);
            let pos = holding
                .readable(read_address, rq)
                .ok_or(ILLEGAL_DATA_ADDRESS)?;
            // The write comes first, as the specification says: the read sees it.
            write_registers(map, image, write_address, wq, data)?;
            out.push(fc);
            read_registers(image.table(Table::Holding), pos, rq, out);
            Ok(())
        }
        _ => Err(ILLEGAL_FUNCTION.into()),
    }
}

/// Why a request got exception `code`, in words for the log: which address of which table,
/// and what to do about it. Only called for refused requests, off the served path.
pub fn explain(map: &AddressMap, pdu: &[u8], code: u8) -> String {
    let (fc, body) = match pdu.split_first() {
        Some((&fc, body)) => (fc, body),
        None => return "an empty request".to_string(),
    };
    if code == ILLEGAL_FUNCTION {
        return format!("function code {fc} is not served (1-6, 15, 16 and 23 are): exception 01");
    }
    let field = |i: usize| (body.len() >= i + 2).then(|| be(body, i));
    // (what the request does, table, first address, quantity)
    let (what, table, address, q) = match fc {
        0x01..=0x04 => {
            let table = match fc {
                0x01 => Table::Coil,
                0x02 => Table::DiscreteInput,
                0x03 => Table::Holding,
                _ => Table::Input,
            };
            ("read", table, field(0), field(2))
        }
        0x05 => ("write", Table::Coil, field(0), Some(1)),
        0x06 => ("write", Table::Holding, field(0), Some(1)),
        0x0F => ("write", Table::Coil, field(0), field(2)),
        0x10 => ("write", Table::Holding, field(0), field(2)),
        _ => ("write", Table::Holding, field(4), field(6)),
    };
    let (Some(address), Some(q)) = (address, q) else {
        return format!(
            "a malformed request (function {fc}, {} bytes): exception 03",
            pdu.len()
        );
    };
    let table_name = table.name();
    let range = if q == 1 {
        format!("{table_name} {address}")
    } else {
        format!(
            "{table_name} {address}-{}",
            u32::from(address) + u32::from(q) - 1
        )
    };
    if code == ILLEGAL_DATA_VALUE {
        return format!(
            "{what} {range}: exception 03, a quantity out of the protocol's limits or a byte \
             count that does not match"
        );
    }
    let t = map.table(table);
    for a in u32::from(address)..u32::from(address) + u32::from(q) {
        let entry = u16::try_from(a)
            .ok()
            .and_then(|a| t.position(a))
            .and_then(|pos| t.entry_at(pos))
            .map(|e| &map.entries[e as usize]);
        match entry {
            None => {
                return format!(
                    "{what} {range}: exception 02, no point is mapped at {table_name} {a}; \
                     the server's section maps the addresses it serves"
                )
            }
            Some(e) if what == "write" && !e.writable => {
                let point = &map.points[e.point as usize].name;
                return format!(
                    "{what} {range}: exception 02, {table_name} {a} shows point `{point}`, \
                     which another module owns: clients may read it, only points the server \
                     owns can be written"
                );
            }
            Some(_) => {}
        }
    }
    format!("{what} {range}: exception 02, the range cuts a 32-bit value in two")
}

/// A refused value in words for the log: what was written where, to which point, and why.
pub fn explain_value(map: &AddressMap, bad: &BadValue) -> String {
    let e = &map.entries[bad.entry as usize];
    let point = &map.points[e.point as usize];
    let n = usize::from(e.width);
    let registers: Vec<String> = bad.words[..n]
        .iter()
        .map(|w| format!("0x{w:04X}"))
        .collect();
    let at = if n == 1 {
        format!("holding {}", e.address)
    } else {
        format!("holding {}-{}", e.address, u32::from(e.address) + 1)
    };
    let ty = if n == 1 {
        e.ty.to_string()
    } else {
        format!("{} {}", e.ty, e.order)
    };
    format!(
        "a write of {} to {at} ({ty}), point `{}` ({}): {}; exception 03, the point keeps its \
         value",
        registers.join(" "),
        point.name,
        e.origin,
        bad.why
    )
}

fn read_registers(values: &[u16], pos: usize, q: u16, out: &mut Vec<u8>) {
    let words = &values[pos..pos + usize::from(q)];
    out.push((2 * words.len()) as u8);
    out.reserve(2 * words.len());
    for w in words {
        out.extend_from_slice(&w.to_be_bytes());
    }
}

fn write_bit(map: &AddressMap, image: &mut Image, pos: usize, on: bool) -> Result<(), u8> {
    let e = map
        .table(Table::Coil)
        .entry_at(pos)
        .ok_or(ILLEGAL_DATA_ADDRESS)?;
    let p = map.entries[e as usize].point;
    let kind = map.points[p as usize].kind;
    image.write(map, p, value::from_bit(on, kind));
    Ok(())
}

/// Writes `q` holding registers from `address` (`data`: 2 × q bytes): every address must be
/// writable and every 32-bit value written whole (02: half of a pair would combine with the
/// other half's current value into a value nobody wrote, NaN perhaps), every value must fit
/// its point (03).
fn write_registers(
    map: &AddressMap,
    image: &mut Image,
    address: u16,
    q: u16,
    data: &[u8],
) -> Result<(), Fail> {
    let t = map.table(Table::Holding);
    let pos = t.writable(address, q).ok_or(ILLEGAL_DATA_ADDRESS)?;
    let end = u32::from(address) + u32::from(q);
    // The range is mapped without holes, so only its two ends can cut a 32-bit value.
    let first = t.entry_at(pos).ok_or(ILLEGAL_DATA_ADDRESS)?;
    let last = t
        .entry_at(pos + usize::from(q) - 1)
        .ok_or(ILLEGAL_DATA_ADDRESS)?;
    let (first, last) = (&map.entries[first as usize], &map.entries[last as usize]);
    if first.address != address || u32::from(last.address) + u32::from(last.width) != end {
        return Err(ILLEGAL_DATA_ADDRESS.into());
    }
    for apply in [false, true] {
        let mut i = 0usize;
        while i < usize::from(q) {
            let entry_index = t.entry_at(pos + i).ok_or(ILLEGAL_DATA_ADDRESS)?;
            let e = &map.entries[entry_index as usize];
            let n = usize::from(e.width);
            let mut words = [0u16; 2];
            for (k, w) in words.iter_mut().enumerate().take(n) {
                *w = be(data, 2 * (i + k));
            }
            let p = &map.points[e.point as usize];
            let v = value::convert(value::decode(&words[..n], e.ty, e.order), p.kind, p.bits)
                .map_err(|why| {
                    Fail::Value(BadValue {
                        entry: entry_index,
                        words,
                        why,
                    })
                })?;
            if apply {
                image.write(map, e.point, v);
            }
            i += n;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_functions_get_01_with_the_code_echoed() {
        let map = AddressMap::default();
        let mut image = Image::new(&map);
        for fc in [0x00u8, 0x07, 0x08, 0x2B, 0x7F, 0x81, 0xFF] {
            let mut out = Vec::new();
            assert_ne!(
                respond(&map, &mut image, &[fc, 1, 2], &mut out),
                Outcome::Served
            );
            assert_eq!(out, [fc | 0x80, ILLEGAL_FUNCTION]);
        }
        let mut out = Vec::new();
        assert_ne!(respond(&map, &mut image, &[], &mut out), Outcome::Served);
        assert_eq!(out, [0x80, ILLEGAL_FUNCTION]);
    }

    #[test]
    fn short_or_long_pdus_get_03() {
        let map = AddressMap::default();
        let mut image = Image::new(&map);
        for pdu in [
            &[0x03u8, 0, 0, 0][..],
            &[0x03, 0, 0, 0, 1, 9],
            &[0x05, 0, 0],
            &[0x10, 0, 0, 0, 1],
            &[0x10, 0, 0, 0, 1, 2, 0],
            &[0x0F, 0, 0, 0, 9, 1, 0],
            &[0x17, 0, 0, 0, 1, 0, 0, 0, 1],
        ] {
            let mut out = Vec::new();
            assert_ne!(respond(&map, &mut image, pdu, &mut out), Outcome::Served);
            assert_eq!(out, [pdu[0] | 0x80, ILLEGAL_DATA_VALUE], "{pdu:?}");
        }
    }

    #[test]
    fn quantities_are_checked_before_addresses() {
        let map = AddressMap::default();
        let mut image = Image::new(&map);
        for (pdu, code) in [
            (&[0x01u8, 0, 0, 0x07, 0xD1][..], ILLEGAL_DATA_VALUE),
            (&[0x01, 0, 0, 0x07, 0xD0], ILLEGAL_DATA_ADDRESS),
            (&[0x03, 0, 0, 0, 0], ILLEGAL_DATA_VALUE),
            (&[0x04, 0, 0, 0, 126], ILLEGAL_DATA_VALUE),
            (&[0x04, 0, 0, 0, 125], ILLEGAL_DATA_ADDRESS),
            (&[0x05, 0, 0, 0x12, 0x34], ILLEGAL_DATA_VALUE),
            (&[0x05, 0, 0, 0xFF, 0], ILLEGAL_DATA_ADDRESS),
        ] {
            let mut out = Vec::new();
            assert_ne!(respond(&map, &mut image, pdu, &mut out), Outcome::Served);
            assert_eq!(out, [pdu[0] | 0x80, code], "{pdu:?}");
        }
    }

    /// `explain` of the exception `pdu` gets from a server mapping coil 0 to its own point
    /// `stop`, coil 1 to `lamp` (owned by another module) and holding 0 to `level`.
    fn check_explain(pdu: &[u8], expect: &str) {
        let text = "[PLC]\nmodule mb modbus_server\nmodule other timeline\n\
                    point stop \"\" mb\npoint lamp \"\" other\npoint level \"\" mb u8\n\
                    [mb]\ncoil 0 stop\ncoil 1 lamp\nholding 0 level\n";
        let config = petriplc_config::parse_str(text, "t.conf", std::path::Path::new(".")).unwrap();
        let layout = petriplc_runtime::image::Layout::new(&config).unwrap();
        let points = petriplc_runtime::image::ModuleMap::new(
            &layout,
            "mb",
            petriplc_config::Location::Local,
        )
        .unwrap();
        let rows = petriplc_modules::common::module_rows(&config, "mb");
        let map = AddressMap::build(&rows, &points, crate::value::WordOrder::HighFirst).unwrap();
        let mut image = Image::new(&map);
        let mut out = Vec::new();
        assert_ne!(
            respond(&map, &mut image, pdu, &mut out),
            Outcome::Served,
            "{pdu:?} was served"
        );
        assert_eq!(explain(&map, pdu, out[1]), expect, "{pdu:?}");
    }

    #[test]
    fn refusals_are_explained() {
        check_explain(
            &[0x05, 0, 1, 0xFF, 0],
            "write coil 1: exception 02, coil 1 shows point `lamp`, which another module owns: \
             clients may read it, only points the server owns can be written",
        );
        check_explain(
            &[0x0F, 0, 0, 0, 3, 1, 7],
            "write coil 0-2: exception 02, coil 1 shows point `lamp`, which another module \
             owns: clients may read it, only points the server owns can be written",
        );
        check_explain(
            &[0x03, 0, 5, 0, 1],
            "read holding 5: exception 02, no point is mapped at holding 5; the server's \
             section maps the addresses it serves",
        );
        check_explain(
            &[0x10, 0, 0, 0, 1, 3, 0, 0],
            "write holding 0: exception 03, a quantity out of the protocol's limits or a byte \
             count that does not match",
        );
        check_explain(
            &[0x2B, 0x0E],
            "function code 43 is not served (1-6, 15, 16 and 23 are): exception 01",
        );
        check_explain(
            &[0x03, 0],
            "a malformed request (function 3, 2 bytes): exception 03",
        );
    }

    /// A server's map: floats at holding 0-1 (high word first) and 2-3 (low word first), a
    /// `u8` at 4, an `i16` at 5, a `u32` at 6-7, another module's float at 8-9 (read-only)
    /// and at input 0-1, a coil at 0.
    const FLOATS: &str = "[PLC]\nmodule mb modbus_server\nmodule other timeline\n\
        point hi \"\" mb f32\npoint lo \"\" mb f32\npoint small \"\" mb u8\n\
        point s \"\" mb i16\npoint w \"\" mb u32\npoint ro \"\" other f32\npoint c \"\" mb\n\
        [mb]\nholding 0 hi\nholding 2 lo f32 low_first\nholding 4 small\nholding 5 s\n\
        holding 6 w\nholding 8 ro\ninput 0 ro\ncoil 0 c\n";

    fn floats() -> (AddressMap, Image) {
        let config =
            petriplc_config::parse_str(FLOATS, "t.conf", std::path::Path::new(".")).unwrap();
        let layout = petriplc_runtime::image::Layout::new(&config).unwrap();
        let points = petriplc_runtime::image::ModuleMap::new(
            &layout,
            "mb",
            petriplc_config::Location::Local,
        )
        .unwrap();
        let rows = petriplc_modules::common::module_rows(&config, "mb");
        let map = AddressMap::build(&rows, &points, crate::value::WordOrder::HighFirst).unwrap();
        let image = Image::new(&map);
        (map, image)
    }

    /// FC 16 of `words` at `address`.
    fn fc16(address: u16, words: &[u16]) -> Vec<u8> {
        let mut pdu = vec![0x10];
        pdu.extend(address.to_be_bytes());
        pdu.extend((words.len() as u16).to_be_bytes());
        pdu.push(2 * words.len() as u8);
        for w in words {
            pdu.extend(w.to_be_bytes());
        }
        pdu
    }

    /// Every NaN and infinity class as an f32's two registers, high word first.
    const NOT_FINITE: [[u16; 2]; 6] = [
        [0x7FC0, 0x0000], // the quiet NaN every tool writes
        [0xFFC0, 0x0000], // negative quiet NaN
        [0x7F80, 0x0001], // a signalling NaN
        [0x7FFF, 0xFFFF], // NaN with every payload bit
        [0x7F80, 0x0000], // +Inf
        [0xFF80, 0x0000], // -Inf
    ];

    #[test]
    fn non_finite_floats_are_refused_in_every_write_function() {
        for [high, low] in NOT_FINITE {
            // (request, the row that refuses: entry 0 is `hi`, entry 1 `lo`)
            let requests = [
                (fc16(0, &[high, low]), 0),
                (fc16(2, &[low, high]), 1),
                // Good values around the bad one: nothing of the request is written.
                (fc16(0, &[0x3FC0, 0, low, high, 7]), 1),
                (
                    [
                        &[0x17u8, 0, 0, 0, 4, 0, 0, 0, 2, 4][..],
                        &high.to_be_bytes(),
                        &low.to_be_bytes(),
                    ]
                    .concat(),
                    0,
                ),
            ];
            for (pdu, entry) in requests {
                let (map, mut image) = floats();
                let before = image.values.clone();
                let mut out = Vec::new();
                let outcome = respond(&map, &mut image, &pdu, &mut out);
                let Outcome::BadValue(bad) = outcome else {
                    panic!("{pdu:02X?}: {outcome:?}");
                };
                assert_eq!(bad.entry, entry, "{pdu:02X?}");
                assert!(matches!(bad.why, Unfit::NotFinite(_)), "{bad:?}");
                assert_eq!(out, [pdu[0] | 0x80, ILLEGAL_DATA_VALUE]);
                assert_eq!(image.values, before, "{pdu:02X?} changed the image");
                assert!(image.pending.is_empty(), "{pdu:02X?} queued a write");
            }
        }
    }

    #[test]
    fn half_a_float_is_never_written() {
        // FC 6 to either register, FC 16 and FC 23 starting or ending inside a pair: 02,
        // whatever the value (the other half's current value with 0x7FC0 would be a NaN).
        for pdu in [
            vec![0x06, 0, 0, 0x7F, 0xC0],
            vec![0x06, 0, 1, 0x7F, 0xC0],
            vec![0x06, 0, 3, 0x7F, 0xC0],
            fc16(1, &[0x7FC0]),
            fc16(1, &[0, 0x7FC0]),
            fc16(3, &[0x7FC0, 0]),
            vec![0x17, 0, 0, 0, 1, 0, 1, 0, 1, 2, 0x7F, 0xC0],
        ] {
            let (map, mut image) = floats();
            let mut out = Vec::new();
            let outcome = respond(&map, &mut image, &pdu, &mut out);
            assert_eq!(
                outcome,
                Outcome::Exception(ILLEGAL_DATA_ADDRESS),
                "{pdu:02X?}"
            );
            assert!(image.pending.is_empty());
            assert_eq!(
                explain(&map, &pdu, ILLEGAL_DATA_ADDRESS),
                format!(
                    "write holding {}: exception 02, the range cuts a 32-bit value in two",
                    match pdu[0] {
                        0x06 => format!("{}", pdu[2]),
                        0x10 if pdu[4] == 1 => format!("{}", pdu[2]),
                        0x10 => format!("{}-{}", pdu[2], pdu[2] + 1),
                        _ => "1".to_string(),
                    }
                ),
                "{pdu:02X?}"
            );
        }
    }

    #[test]
    fn values_a_point_cannot_hold_are_explained() {
        let (map, mut image) = floats();
        let mut out = Vec::new();
        let Outcome::BadValue(nan) = respond(&map, &mut image, &fc16(2, &[0, 0x7FC0]), &mut out)
        else {
            panic!("{out:?}");
        };
        assert_eq!(
            explain_value(&map, &nan),
            "a write of 0x0000 0x7FC0 to holding 2-3 (f32 low_first), point `lo` (t.conf:13): \
             NaN is not a finite number; points take only finite values from the network; \
             exception 03, the point keeps its value"
        );
        let Outcome::BadValue(big) = respond(&map, &mut image, &[0x06, 0, 4, 1, 44], &mut out)
        else {
            panic!("{out:?}");
        };
        assert_eq!(
            explain_value(&map, &big),
            "a write of 0x012C to holding 4 (u16), point `small` (t.conf:14): 300 is outside \
             the point's range 0 to 255; exception 03, the point keeps its value"
        );
    }

    #[test]
    fn a_points_refusals_are_logged_again_only_after_a_write_is_accepted() {
        let (map, mut image) = floats();
        assert!(image.refuse(0), "the first refusal is logged");
        assert!(!image.refuse(0), "a repeat is only counted");
        assert!(image.refuse(1), "per point");
        let mut out = Vec::new();
        assert_eq!(
            respond(&map, &mut image, &fc16(0, &[0x3FC0, 0]), &mut out),
            Outcome::Served
        );
        assert!(image.refuse(0), "an accepted write re-arms the log");
        assert!(!image.refuse(1));
    }

    /// A request with a function the server serves (or any byte), near the mapped addresses,
    /// with quantities and byte counts mostly right and sometimes not, registers random or
    /// a NaN/Inf pair, and the PDU sometimes cut or extended.
    fn request() -> impl proptest::strategy::Strategy<Value = Vec<u8>> {
        use proptest::prelude::*;
        let word = prop_oneof![
            4 => any::<u16>(),
            1 => prop::sample::select(vec![0x7FC0u16, 0xFFC0, 0x7F80, 0xFF80, 0x7FFF, 0xFFFF, 0]),
        ];
        (
            prop_oneof![
                8 => prop::sample::select(vec![1u8, 2, 3, 4, 5, 6, 15, 16, 23]),
                1 => any::<u8>(),
            ],
            0u16..12,
            prop_oneof![4 => Just(None), 1 => any::<u16>().prop_map(Some)],
            proptest::collection::vec(word, 1..8),
            prop_oneof![6 => Just(None), 1 => any::<u8>().prop_map(Some)],
            prop_oneof![8 => Just(0usize), 1 => 1usize..300],
            prop::bool::weighted(0.1),
        )
            .prop_map(|(fc, address, q, words, count, cut, extend)| {
                // Reads ask for as many as there are words, writes carry them.
                let q = q.unwrap_or(words.len() as u16);
                let mut pdu = vec![fc];
                let data: Vec<u8> = words.iter().flat_map(|w| w.to_be_bytes()).collect();
                let count = count.unwrap_or(data.len() as u8);
                match fc {
                    15 => {
                        let bytes = usize::from(q.div_ceil(8)).min(data.len());
                        pdu.extend(address.to_be_bytes());
                        pdu.extend(q.to_be_bytes());
                        pdu.push(if count == data.len() as u8 {
                            bytes as u8
                        } else {
                            count
                        });
                        pdu.extend(&data[..bytes]);
                    }
                    16 => {
                        pdu.extend(address.to_be_bytes());
                        pdu.extend(q.to_be_bytes());
                        pdu.push(count);
                        pdu.extend(&data);
                    }
                    5 => {
                        let w = words[0];
                        pdu.extend(address.to_be_bytes());
                        pdu.extend([0xFF00, 0, w][usize::from(w % 3)].to_be_bytes());
                    }
                    23 => {
                        pdu.extend(address.to_be_bytes());
                        pdu.extend(q.to_be_bytes());
                        pdu.extend(address.wrapping_add(q % 3).to_be_bytes());
                        pdu.extend((words.len() as u16).to_be_bytes());
                        pdu.push(count);
                        pdu.extend(&data);
                    }
                    6 => {
                        pdu.extend(address.to_be_bytes());
                        pdu.extend(words[0].to_be_bytes());
                    }
                    _ => {
                        pdu.extend(address.to_be_bytes());
                        pdu.extend(q.to_be_bytes());
                    }
                }
                pdu.truncate(pdu.len().saturating_sub(cut).max(1));
                if extend {
                    pdu.extend(data.iter().take(3));
                }
                pdu.truncate(253);
                pdu
            })
    }

    proptest::proptest! {
        /// Any request: one well-formed response or exception, nothing queued that its point
        /// cannot hold (no NaN or Inf into a float point), and a bad value always named.
        #[test]
        fn every_request_gets_a_well_formed_answer_and_no_bad_value_gets_in(
            pdus in proptest::collection::vec(request(), 1..20),
        ) {
            let (map, mut image) = floats();
            for pdu in &pdus {
                let mut out = Vec::new();
                let outcome = respond(&map, &mut image, pdu, &mut out);
                let fc = pdu[0];
                match outcome {
                    Outcome::Served => {
                        proptest::prop_assert_eq!(out[0], fc);
                        match fc {
                            1..=4 | 23 => proptest::prop_assert_eq!(usize::from(out[1]), out.len() - 2),
                            5 | 6 => proptest::prop_assert_eq!(&out[..], &pdu[..]),
                            _ => proptest::prop_assert_eq!(&out[..], &pdu[..5]),
                        }
                    }
                    Outcome::Exception(code) => {
                        proptest::prop_assert_eq!(&out, &vec![fc | 0x80, code]);
                        proptest::prop_assert!((1..=3).contains(&code));
                    }
                    Outcome::BadValue(bad) => {
                        proptest::prop_assert_eq!(&out, &vec![fc | 0x80, ILLEGAL_DATA_VALUE]);
                        let e = &map.entries[bad.entry as usize];
                        proptest::prop_assert!(e.writable && e.table == Table::Holding);
                    }
                }
                for &(p, v) in &image.pending {
                    let point = &map.points[p as usize];
                    proptest::prop_assert!(value::fits(&v, point.kind, point.bits), "{v:?}");
                }
            }
        }
    }
}
