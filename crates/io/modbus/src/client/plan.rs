//! A device's rows merged into as few Modbus requests as the protocol allows: rows at
//! adjacent (or, for reads, overlapping) addresses of one table share a request up to the
//! protocol's size limit; a gap starts a new request, so no address a row does not name is
//! ever read or written.

use super::config::Table;

/// The most bits one read may ask for (FC1, FC2).
pub const MAX_READ_BITS: u16 = 2000;
/// The most registers one read may ask for (FC3, FC4).
pub const MAX_READ_REGISTERS: u16 = 125;
/// The most coils one write may carry (FC15).
pub const MAX_WRITE_BITS: u16 = 1968;
/// The most registers one write may carry (FC16).
pub const MAX_WRITE_REGISTERS: u16 = 123;

/// One row as the planner sees it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Span {
    pub table: Table,
    pub address: u16,
    /// Addresses taken: 1 for a bit, 1 or 2 registers.
    pub width: u16,
}

/// One request: `count` addresses of `table` from `address`, and where each row's data is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Request {
    pub table: Table,
    pub address: u16,
    pub count: u16,
    /// (row index as given to [`plan`], offset of its first address in the request).
    pub rows: Vec<(usize, u16)>,
}

/// Merges `spans` (rows of one device) into requests, in table order then address order.
/// `write` selects the write limits; overlapping writes are refused before planning.
pub fn plan(spans: &[Span], write: bool) -> Vec<Request> {
    let mut order: Vec<usize> = (0..spans.len()).collect();
    // Stable on the row index, so that equal addresses keep the file's order.
    order.sort_by_key(|&i| (spans[i].table, spans[i].address, i));
    let mut out: Vec<Request> = Vec::new();
    for i in order {
        let s = spans[i];
        let limit = u32::from(limit(s.table, write));
        let end = u32::from(s.address) + u32::from(s.width);
        if let Some(r) = out.last_mut() {
            let r_end = u32::from(r.address) + u32::from(r.count);
            let touches = r.table == s.table && u32::from(s.address) <= r_end;
            let new_end = r_end.max(end);
            if touches && new_end - u32::from(r.address) <= limit {
                r.count = (new_end - u32::from(r.address)) as u16;
                r.rows.push((i, s.address - r.address));
                continue;
            }
        }
        out.push(Request {
            table: s.table,
            address: s.address,
            count: s.width,
            rows: vec![(i, 0)],
        });
    }
    out
}

fn limit(table: Table, write: bool) -> u16 {
    match (table.is_bits(), write) {
        (true, false) => MAX_READ_BITS,
        (false, false) => MAX_READ_REGISTERS,
        (true, true) => MAX_WRITE_BITS,
        (false, true) => MAX_WRITE_REGISTERS,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use Table::*;

    fn span(table: Table, address: u16, width: u16) -> Span {
        Span {
            table,
            address,
            width,
        }
    }

    /// Requests as `table@address+count[rows]`.
    fn show(reqs: &[Request]) -> String {
        reqs.iter()
            .map(|r| {
                let rows: Vec<String> = r.rows.iter().map(|(i, o)| format!("{i}:{o}")).collect();
                format!(
                    "{}@{}+{}[{}]",
                    r.table.name(),
                    r.address,
                    r.count,
                    rows.join(" ")
                )
            })
            .collect::<Vec<_>>()
            .join(" ")
    }

    #[test]
    fn adjacent_rows_merge_and_gaps_split() {
        let spans = [
            span(Holding, 2, 2),
            span(Holding, 0, 1),
            span(Holding, 1, 1),
            span(Holding, 5, 1),
            span(Coil, 7, 1),
            span(Coil, 8, 1),
            span(Input, 0, 1),
        ];
        assert_eq!(
            show(&plan(&spans, false)),
            "coil@7+2[4:0 5:1] holding@0+4[1:0 2:1 0:2] holding@5+1[3:0] input@0+1[6:0]"
        );
    }

    #[test]
    fn tables_never_merge() {
        let spans = [span(DiscreteInput, 1, 1), span(Coil, 0, 1)];
        assert_eq!(
            show(&plan(&spans, false)),
            "coil@0+1[1:0] discrete_input@1+1[0:0]"
        );
    }

    #[test]
    fn overlapping_reads_share_a_request() {
        let spans = [span(Holding, 0, 2), span(Holding, 1, 1)];
        assert_eq!(show(&plan(&spans, false)), "holding@0+2[0:0 1:1]");
    }

    #[test]
    fn limits_split_long_runs() {
        let regs: Vec<Span> = (0..130).map(|a| span(Holding, a, 1)).collect();
        let reads = plan(&regs, false);
        assert_eq!(reads.iter().map(|r| r.count).collect::<Vec<_>>(), [125, 5]);
        let writes = plan(&regs, true);
        assert_eq!(
            writes
                .iter()
                .map(|r| (r.address, r.count))
                .collect::<Vec<_>>(),
            [(0, 123), (123, 7)]
        );
        // A two-register value never straddles two requests.
        let wide: Vec<Span> = (0..63).map(|k| span(Input, 2 * k, 2)).collect();
        let reads = plan(&wide, false);
        assert_eq!(
            reads
                .iter()
                .map(|r| (r.address, r.count))
                .collect::<Vec<_>>(),
            [(0, 124), (124, 2)]
        );
        let bits: Vec<Span> = (0..2001).map(|a| span(Coil, a, 1)).collect();
        assert_eq!(
            plan(&bits, false)
                .iter()
                .map(|r| r.count)
                .collect::<Vec<_>>(),
            [2000, 1]
        );
        assert_eq!(
            plan(&bits, true)
                .iter()
                .map(|r| r.count)
                .collect::<Vec<_>>(),
            [1968, 33]
        );
    }

    #[test]
    fn the_last_address_is_reachable() {
        let spans = [span(Holding, 65534, 2)];
        assert_eq!(show(&plan(&spans, false)), "holding@65534+2[0:0]");
    }
}
