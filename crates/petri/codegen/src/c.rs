//! C99: the lowered program as one self-contained file in seed 004's style (a comment per
//! transition, checks grouped as test, inhibitor, preset and postset arcs), with
//! `int step(const inputs_t *in, outputs_t *out, uint64_t now_ms)` and, when compiled with
//! `-DPETRIPLC_MAIN`, a `main` that reads a timeline CSV and prints the trace exactly as
//! `petriplc sim` does (software-in-the-loop).

use std::fmt::Write as _;

use petriplc_net::guard::{CmpOp, Expr, Operand};
use petriplc_net::{Evolution, SignalType, StepRule};

use crate::enabling::Cond;
use crate::lower::{PlaceVar, Program, TransitionCode};
use crate::spell::{render, Syntax};
use crate::text::comment;
use crate::CodegenError;

/// The whole C file.
pub fn file(p: &Program) -> Result<String, CodegenError> {
    for tm in &p.timers {
        if tm.delay.subsec_nanos() % 1_000_000 != 0 {
            return Err(CodegenError::DelayNotMilliseconds {
                arc: tm.arc.clone(),
                delay: crate::iec_time(tm.delay),
            });
        }
    }
    let mut w = String::new();
    let header = crate::st::header(p, "/*", " */", " *");
    w.push_str(&header);
    w.push_str(PRELUDE);

    // Names of places and transitions as C constants, for the arrays and the trace.
    let _ = writeln!(w, "\n/* Places (index into M) */\nenum {{");
    for (i, pl) in p.places.iter().enumerate() {
        let _ = writeln!(w, "    P_{} = {i}, /* {} */", pl.ident, comment(&pl.label));
    }
    let _ = writeln!(w, "    N_PLACES = {}\n}};", p.places.len());
    let _ = writeln!(w, "\n/* Transitions, in priority order */\nenum {{");
    for (i, t) in p.transitions.iter().enumerate() {
        let _ = writeln!(w, "    T_{} = {i}, /* {} */", t.ident, comment(&t.label));
    }
    let _ = writeln!(w, "    N_TRANSITIONS = {}\n}};", p.transitions.len());

    let _ = writeln!(w, "\n/* Input signals */\ntypedef struct {{");
    for s in &p.inputs {
        let _ = writeln!(w, "    {} {};", c_type(s.ty), s.ident);
    }
    if p.inputs.is_empty() {
        let _ = writeln!(w, "    char unused;");
    }
    let _ = writeln!(w, "}} inputs_t;\n\n/* Output signals */\ntypedef struct {{");
    for s in &p.outputs {
        let _ = writeln!(w, "    {} {};", c_type(s.ty), s.ident);
    }
    if p.outputs.is_empty() {
        let _ = writeln!(w, "    char unused;");
    }
    let _ = writeln!(w, "}} outputs_t;");

    let _ = writeln!(
        w,
        "\n/* The marking: tokens per place{} */",
        if p.boolean {
            " (a safe net: 0 or 1)"
        } else {
            ""
        }
    );
    let _ = writeln!(w, "static uint32_t M[N_PLACES + 1];");
    if !p.transitions.is_empty() {
        let _ = writeln!(
            w,
            "/* Fire flags of the current pass */\nstatic bool F[N_TRANSITIONS + 1];"
        );
    }
    let _ = writeln!(
        w,
        "/* Timers of delayed arcs (TON): running since when */\nstatic pn_timer_t TM[{}];",
        p.timers.len().max(1)
    );
    let _ = writeln!(w, "static bool initialized;");
    for (i, tm) in p.timers.iter().enumerate() {
        let _ = writeln!(
            w,
            "#define DELAY_{i} {}u /* ms, arc {} */",
            tm.delay.as_millis(),
            comment(&tm.arc)
        );
    }

    let _ = writeln!(
        w,
        "\n/* Back to the initial marking. */\nvoid reset(void)\n{{"
    );
    let _ = writeln!(
        w,
        "    memset(M, 0, sizeof M);\n    memset(TM, 0, sizeof TM);"
    );
    for pl in p.places.iter().filter(|pl| pl.initial > 0) {
        let _ = writeln!(w, "    M[P_{}] = {}u;", pl.ident, pl.initial);
    }
    let _ = writeln!(w, "    initialized = true;\n}}");

    write_pass(p, &mut w);
    write_step(p, &mut w);
    write_main(p, &mut w);
    Ok(w)
}

fn c_type(ty: SignalType) -> &'static str {
    match ty {
        SignalType::Bool => "bool",
        SignalType::Int => "int64_t",
    }
}

const PRELUDE: &str = r#"
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* step() results */
#define PN_OK 0
#define PN_UNSTABLE 1 /* still firing after the last allowed pass of a scan */
#define PN_OVERFLOW 2 /* a place without capacity would exceed 4294967295 tokens */

typedef struct {
    bool running;
    uint64_t since; /* ms */
} pn_timer_t;

/* Called with each transition that fires; the trace printer of main() defines it. */
#ifdef PETRIPLC_MAIN
static void pn_fired(int t);
#define PN_FIRED(t) pn_fired(t)
#else
#define PN_FIRED(t) ((void)0)
#endif
"#;

/// `pass()`: one pass of the step rule; returns whether anything fired, or -1 on overflow.
fn write_pass(p: &Program, w: &mut String) {
    let bool_maximal = p.step == StepRule::MaximalStep && p.boolean;
    let int_maximal = p.step == StepRule::MaximalStep && !p.boolean;
    let _ = writeln!(
        w,
        "\n/* One pass ({}): returns 1 if a transition fired, 0 if none, -1 on overflow. */",
        match (p.step, p.boolean) {
            (StepRule::Sequential, _) => "sequential: each transition fires at once",
            (_, true) => "maximal step: enabling on the start marking, then the token flow",
            (_, false) => "maximal step: judged on the tokens not yet taken",
        }
    );
    let _ = writeln!(w, "static int pass(const inputs_t *in, uint64_t now)\n{{");
    let _ = writeln!(w, "    int fired = 0;");
    if int_maximal {
        let _ = writeln!(
            w,
            "    uint32_t A[N_PLACES + 1]; /* tokens not yet taken */\n    uint64_t N[N_PLACES + 1]; /* tokens produced */"
        );
        let _ = writeln!(
            w,
            "    memcpy(A, M, sizeof A);\n    memset(N, 0, sizeof N);"
        );
    }
    let _ = writeln!(w, "    (void)in;\n    (void)now;");
    if !p.timers.is_empty() {
        let _ = writeln!(
            w,
            "\n    /* Delayed arcs: sampled at the start of the pass */"
        );
        for (i, tm) in p.timers.iter().enumerate() {
            let _ = writeln!(
                w,
                "    if ({}) {{\n        if (!TM[{i}].running) {{ TM[{i}].running = true; TM[{i}].since = now; }}\n    }} else {{\n        TM[{i}].running = false;\n    }}",
                cond(p, &tm.input)
            );
        }
    }
    for (i, t) in p.transitions.iter().enumerate() {
        let _ = writeln!(
            w,
            "\n    // Code for TRANSITION {}: {}{}",
            comment(&t.label),
            comment(&t.summary),
            t.shown_guard()
                .map(|g| format!(", if {}", comment(g)))
                .unwrap_or_default()
        );
        let _ = writeln!(w, "    F[T_{}] = {};", t.ident, enabling(p, t));
        if bool_maximal {
            let _ = writeln!(
                w,
                "    if (F[T_{}]) {{ fired = 1; PN_FIRED({i}); }}",
                t.ident
            );
            continue;
        }
        let _ = writeln!(w, "    if (F[T_{}]) {{", t.ident);
        if !t.consume.is_empty() {
            let _ = writeln!(w, "        // Changes by preset edges");
        }
        for &(pl, wt) in &t.consume {
            let place = &p.places[pl];
            if int_maximal {
                let _ = writeln!(w, "        A[P_{}] -= {wt}u;", place.ident);
            } else if place.boolean {
                let _ = writeln!(w, "        M[P_{}] = 0;", place.ident);
            } else {
                let _ = writeln!(w, "        M[P_{}] -= {wt}u;", place.ident);
            }
        }
        if !t.produce.is_empty() {
            let _ = writeln!(w, "        // Changes by postset edges");
        }
        for &(pl, wt) in &t.produce {
            let place = &p.places[pl];
            if int_maximal {
                let _ = writeln!(w, "        N[P_{}] += {wt}u;", place.ident);
            } else if place.boolean {
                let _ = writeln!(w, "        M[P_{}] = 1;", place.ident);
            } else if place.capacity.is_some() {
                let _ = writeln!(w, "        M[P_{}] += {wt}u;", place.ident);
            } else {
                let _ = writeln!(
                    w,
                    "        if (M[P_{0}] > UINT32_MAX - {wt}u) return -1;\n        M[P_{0}] += {wt}u;",
                    place.ident
                );
            }
        }
        let _ = writeln!(w, "        fired = 1;\n        PN_FIRED({i});\n    }}");
    }
    if bool_maximal && p.transitions.iter().any(|t| !t.consume.is_empty()) {
        let _ = writeln!(
            w,
            "\n    /* Token flow: tokens taken first, then tokens given */"
        );
        for t in &p.transitions {
            for &(pl, _) in &t.consume {
                let _ = writeln!(
                    w,
                    "    if (F[T_{}]) M[P_{}] = 0;",
                    t.ident, p.places[pl].ident
                );
            }
        }
    }
    if bool_maximal {
        for t in &p.transitions {
            for &(pl, _) in &t.produce {
                let _ = writeln!(
                    w,
                    "    if (F[T_{}]) M[P_{}] = 1;",
                    t.ident, p.places[pl].ident
                );
            }
        }
    }
    if int_maximal {
        let _ = writeln!(
            w,
            "\n    /* End of the step: the tokens left plus the tokens produced */\n    for (int p = 0; p < N_PLACES; p++)\n        if ((uint64_t)A[p] + N[p] > UINT32_MAX) return -1;\n    for (int p = 0; p < N_PLACES; p++)\n        M[p] = (uint32_t)(A[p] + N[p]);"
        );
    }
    let _ = writeln!(w, "    return fired;\n}}");
}

fn write_step(p: &Program, w: &mut String) {
    let _ = writeln!(
        w,
        "\n/* One PLC scan at time now_ms: inputs, evolution, outputs. Returns PN_OK, or\n   PN_UNSTABLE / PN_OVERFLOW (outputs are then not written). */"
    );
    let _ = writeln!(
        w,
        "int step(const inputs_t *in, outputs_t *out, uint64_t now_ms)\n{{"
    );
    let _ = writeln!(w, "    if (!initialized) reset();");
    if p.outputs.is_empty() {
        let _ = writeln!(w, "    (void)out;");
    }
    for pl in &p.places {
        let Some((s, clamp)) = pl.input else { continue };
        let sig = &p.inputs[s];
        let value = match sig.ty {
            SignalType::Bool => format!("in->{} ? 1u : 0u", sig.ident),
            SignalType::Int => format!(
                "in->{0} < 0 ? 0u : in->{0} > {clamp} ? {clamp}u : (uint32_t)in->{0}",
                sig.ident
            ),
        };
        let _ = writeln!(w, "    M[P_{}] = {value}; /* input place */", pl.ident);
    }
    match p.evolve {
        Evolution::OnePass => {
            let _ = writeln!(w, "    if (pass(in, now_ms) < 0) return PN_OVERFLOW;");
        }
        Evolution::UntilStable => {
            let _ = writeln!(
                w,
                "    for (uint32_t passes = 1;; passes++) {{\n        int r = pass(in, now_ms);\n        if (r < 0) return PN_OVERFLOW;\n        if (r == 0) break;\n        if (passes == {}u) return PN_UNSTABLE;\n    }}",
                p.max_passes
            );
        }
    }
    for o in &p.outputs {
        let value = match o.ty {
            SignalType::Bool if o.places.is_empty() => "false".to_string(),
            SignalType::Bool => o
                .places
                .iter()
                .map(|&i| format!("M[P_{}] != 0", p.places[i].ident))
                .collect::<Vec<_>>()
                .join(" || "),
            SignalType::Int => o
                .places
                .first()
                .map_or("0".to_string(), |&i| format!("M[P_{}]", p.places[i].ident)),
        };
        let _ = writeln!(w, "    out->{} = {value};", o.ident);
    }
    let _ = writeln!(w, "    return PN_OK;\n}}");
}

/// The enabling as a C expression, one group per line with seed 004's comments.
fn enabling(p: &Program, t: &TransitionCode) -> String {
    let groups = t.enabling.groups();
    if groups.is_empty() {
        return "true".into();
    }
    let parts: Vec<String> = groups
        .iter()
        .map(|(name, conds)| {
            let text = conds
                .iter()
                .map(|c| cond(p, c))
                .collect::<Vec<_>>()
                .join(" && ");
            format!("( // Check {name}\n        {text})")
        })
        .collect();
    parts.join(" &&\n        ")
}

fn cond(p: &Program, c: &Cond) -> String {
    render(&C(p), c)
}

/// C's spelling of conditions: markings in `M` (`A` and `N` in an int maximal-step pass),
/// fire flags in `F`, timers in `TM`.
struct C<'p>(&'p Program);

fn not(s: String, negated: bool) -> String {
    if negated {
        format!("!{s}")
    } else {
        s
    }
}

impl Syntax for C<'_> {
    type Out = String;

    fn program(&self) -> &Program {
        self.0
    }

    fn constant(&self, value: bool) -> String {
        value.to_string()
    }

    fn any(&self, items: Vec<String>) -> String {
        format!("({})", items.join(" || "))
    }

    // guard() is always a primary: parenthesised, a constant or a negation.
    fn guard(&self, t: usize, negated: bool) -> String {
        not(guard(self.0, &self.0.transitions[t].guard), negated)
    }

    fn timer(&self, i: usize, negated: bool) -> String {
        not(
            format!("(TM[{i}].running && now - TM[{i}].since >= DELAY_{i})"),
            negated,
        )
    }

    fn marked(&self, place: &PlaceVar, negated: bool) -> String {
        not(format!("M[P_{}]", place.ident), negated)
    }

    fn fired(&self, t: &TransitionCode, negated: bool) -> String {
        not(format!("F[T_{}]", t.ident), negated)
    }

    fn at_least(
        &self,
        place: &PlaceVar,
        avail: Option<&str>,
        tokens: u32,
        negated: bool,
    ) -> String {
        let arr = if avail.is_some() { "A" } else { "M" };
        format!(
            "{arr}[P_{}] {} {tokens}u",
            place.ident,
            if negated { "<" } else { ">=" }
        )
    }

    fn at_most(
        &self,
        place: &PlaceVar,
        produced: Option<&str>,
        limit: u64,
        negated: bool,
    ) -> String {
        let lhs = if produced.is_some() {
            format!("(uint64_t)M[P_{0}] + N[P_{0}]", place.ident)
        } else {
            format!("(uint64_t)M[P_{}]", place.ident)
        };
        format!("{lhs} {} {limit}u", if negated { ">" } else { "<=" })
    }
}

/// A guard as a fully parenthesised C expression over `in->…`.
fn guard(p: &Program, g: &Expr<usize>) -> String {
    let operand = |o: &Operand<usize>| match o {
        Operand::Signal(s) => format!("(int64_t)in->{}", p.inputs[*s].ident),
        Operand::Literal(v) if *v == i64::MIN => "INT64_MIN".to_string(),
        Operand::Literal(v) => format!("INT64_C({v})"),
    };
    match g {
        Expr::Const(b) => b.to_string(),
        Expr::Signal(s) => format!("(in->{} != 0)", p.inputs[*s].ident),
        Expr::Not(e) => format!("!{}", guard(p, e)),
        Expr::And(a, b) => format!("({} && {})", guard(p, a), guard(p, b)),
        Expr::Or(a, b) => format!("({} || {})", guard(p, a), guard(p, b)),
        Expr::Xor(a, b) => format!("({} != {})", guard(p, a), guard(p, b)),
        Expr::Cmp(a, op, b) => {
            let sym = match op {
                CmpOp::Eq => "==",
                CmpOp::Ne => "!=",
                CmpOp::Lt => "<",
                CmpOp::Le => "<=",
                CmpOp::Gt => ">",
                CmpOp::Ge => ">=",
            };
            format!("({} {sym} {})", operand(a), operand(b))
        }
    }
}

/// The software-in-the-loop `main`, compiled in with `-DPETRIPLC_MAIN`.
fn write_main(p: &Program, w: &mut String) {
    let _ = writeln!(w, "\n#ifdef PETRIPLC_MAIN");
    let _ = writeln!(
        w,
        "/* Software in the loop: {} [TIMELINE.csv] [--period T] [--until T]\n   Prints the trace as `petriplc sim --out` writes it. */",
        p.pou
    );
    let quoted = |names: Vec<String>| {
        names
            .iter()
            .map(|n| format!("\"{}\"", c_string(n)))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let _ = writeln!(
        w,
        "static const char *const place_names[N_PLACES + 1] = {{{}}};",
        quoted(
            p.places
                .iter()
                .map(|pl| pl.label.clone())
                .chain(["".to_string()])
                .collect()
        )
    );
    let _ = writeln!(
        w,
        "static const char *const transition_names[N_TRANSITIONS + 1] = {{{}}};",
        quoted(
            p.transitions
                .iter()
                .map(|t| t.label.clone())
                .chain(["".to_string()])
                .collect()
        )
    );
    let _ = writeln!(w, "#define N_INPUTS {}", p.inputs.len());
    let _ = writeln!(w, "#define N_OUTPUTS {}", p.outputs.len());
    let _ = writeln!(
        w,
        "static const char *const input_names[N_INPUTS + 1] = {{{}}};",
        quoted(
            p.inputs
                .iter()
                .map(|s| s.name.clone())
                .chain(["".to_string()])
                .collect()
        )
    );
    let _ = writeln!(
        w,
        "static const bool input_is_bool[N_INPUTS + 1] = {{{}}};",
        p.inputs
            .iter()
            .map(|s| (s.ty == SignalType::Bool).to_string())
            .chain(["false".to_string()])
            .collect::<Vec<_>>()
            .join(", ")
    );
    let _ = writeln!(
        w,
        "static const char *const output_names[N_OUTPUTS + 1] = {{{}}};",
        quoted(
            p.outputs
                .iter()
                .map(|s| s.name.clone())
                .chain(["".to_string()])
                .collect()
        )
    );
    let _ = writeln!(w, "#define DEFAULT_PERIOD_NS {}ull", p.period.as_nanos());
    let _ = writeln!(
        w,
        "static void set_input(inputs_t *in, int i, int64_t v)\n{{\n    switch (i) {{"
    );
    for (i, s) in p.inputs.iter().enumerate() {
        let v = match s.ty {
            SignalType::Bool => "v != 0",
            SignalType::Int => "v",
        };
        let _ = writeln!(w, "    case {i}: in->{} = {v}; break;", s.ident);
    }
    let _ = writeln!(w, "    default: (void)in; (void)v; break;\n    }}\n}}");
    let _ = writeln!(
        w,
        "static int64_t get_output(const outputs_t *out, int i)\n{{\n    switch (i) {{"
    );
    for (i, s) in p.outputs.iter().enumerate() {
        let _ = writeln!(w, "    case {i}: return (int64_t)out->{};", s.ident);
    }
    let _ = writeln!(w, "    default: (void)out; return 0;\n    }}\n}}");
    w.push_str(MAIN);
    let _ = writeln!(w, "#endif /* PETRIPLC_MAIN */");
}

/// `s` as the contents of a C string literal.
fn c_string(s: &str) -> String {
    let mut out = String::new();
    for b in s.bytes() {
        match b {
            b'"' => out.push_str("\\\""),
            b'\\' => out.push_str("\\\\"),
            0x20..=0x7e => out.push(b as char),
            _ => {
                let _ = write!(out, "\\{b:03o}");
            }
        }
    }
    out
}

/// The net-independent part of the software-in-the-loop main: timeline parsing (the format
/// of `petriplc sim --inputs`), the scan loop and the trace printer.
const MAIN: &str = include_str!("c_main.c");
