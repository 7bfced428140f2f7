//! PLCopen XML (TC6 v2.01) projects: one program POU in some language, its variables, and a
//! configuration, resource and task that run it, so an IDE can open the file and run it.
//! Every file written validates against tc6_xml_v201.xsd (tested with xmllint).

use std::fmt::Write as _;

use petriplc_net::{Evolution, SignalType};

use crate::lower::Program;
use crate::text::xml;

/// A variable's type.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum VarType {
    Bool,
    Dint,
    Udint,
    /// A function block instance, e.g. `TON`.
    Derived(String),
}

impl VarType {
    /// The type as written in ST declarations.
    pub fn iec(&self) -> &str {
        match self {
            VarType::Bool => "BOOL",
            VarType::Dint => "DINT",
            VarType::Udint => "UDINT",
            VarType::Derived(name) => name,
        }
    }
}

/// One variable declaration.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Var {
    pub name: String,
    pub ty: VarType,
    /// What the variable is for, shown by IDEs.
    pub doc: String,
}

/// The program's variables by section.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Interface {
    pub inputs: Vec<Var>,
    pub outputs: Vec<Var>,
    pub locals: Vec<Var>,
}

/// The type of an input or output signal: BOOL, or DINT for an integer input and UDINT for
/// an integer output (the marking of a place).
pub fn signal_type(ty: SignalType, output: bool) -> VarType {
    match (ty, output) {
        (SignalType::Bool, _) => VarType::Bool,
        (SignalType::Int, false) => VarType::Dint,
        (SignalType::Int, true) => VarType::Udint,
    }
}

/// The variables the ST, IL and LD programs use: the signals, then per place its marking
/// (and `Avail`/`New` counters), per transition its fire flag, per delayed arc its TON, and
/// the bookkeeping flags.
pub fn program_interface(p: &Program) -> Interface {
    let var = |name: &str, ty: VarType, doc: String| Var {
        name: name.to_string(),
        ty,
        doc,
    };
    let mut i = Interface::default();
    for s in &p.inputs {
        i.inputs.push(var(
            &s.ident,
            signal_type(s.ty, false),
            format!("input {}", s.name),
        ));
    }
    for s in &p.outputs {
        i.outputs.push(var(
            &s.ident,
            signal_type(s.ty, true),
            format!("output {}", s.name),
        ));
    }
    if p.evolve == Evolution::UntilStable {
        i.outputs.push(var(
            &p.helpers.unstable,
            VarType::Bool,
            format!(
                "TRUE when the last scan still fired after {} passes (outputs not written)",
                p.max_passes
            ),
        ));
    }
    let count = |boolean: bool| {
        if boolean {
            VarType::Bool
        } else {
            VarType::Udint
        }
    };
    for pl in &p.places {
        i.locals.push(var(
            &pl.ident,
            count(pl.boolean),
            format!("marking of place {}", pl.label),
        ));
        if let Some(a) = &pl.avail {
            i.locals.push(var(
                a,
                VarType::Udint,
                format!("tokens of {} not yet taken in this pass", pl.label),
            ));
        }
        if let Some(n) = &pl.produced {
            i.locals.push(var(
                n,
                VarType::Udint,
                format!("tokens produced into {} in this pass", pl.label),
            ));
        }
    }
    for t in &p.transitions {
        i.locals.push(var(
            &t.ident,
            VarType::Bool,
            format!("transition {} fired in this pass", t.label),
        ));
    }
    for tm in &p.timers {
        i.locals.push(var(
            &tm.ident,
            VarType::Derived("TON".into()),
            format!("delay of arc {}", tm.arc),
        ));
    }
    i.locals.push(var(
        &p.helpers.init,
        VarType::Bool,
        "TRUE once the initial marking is set".into(),
    ));
    if p.evolve == Evolution::UntilStable {
        i.locals.push(var(
            &p.helpers.passes,
            VarType::Udint,
            "passes made in this scan".into(),
        ));
        i.locals.push(var(
            &p.helpers.fired,
            VarType::Bool,
            "something fired in this pass".into(),
        ));
    }
    i
}

/// The body of the program POU.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Body {
    /// Structured Text source.
    St(String),
    /// Instruction List source.
    Il(String),
    /// A graphical body: the language element's name (`LD`, `SFC`) and its content, already
    /// XML. `pou_extra` goes between the interface and the body (SFC's `actions` and
    /// `transitions`).
    Graphical {
        language: &'static str,
        content: String,
        pou_extra: String,
    },
}

/// A whole project: file and content headers, the program POU, and a configuration
/// `config` with resource `resource1` running the program every [`Program::period`].
pub fn project(p: &Program, interface: &Interface, body: &Body, created: &str) -> String {
    let mut out = String::new();
    let w = &mut out;
    let _ = writeln!(w, "<?xml version=\"1.0\" encoding=\"utf-8\"?>");
    let _ = writeln!(
        w,
        "<project xmlns=\"http://www.plcopen.org/xml/tc6_0201\" xmlns:xhtml=\"http://www.w3.org/1999/xhtml\">"
    );
    let _ = writeln!(
        w,
        "  <fileHeader companyName=\"petriplc\" productName=\"petriplc\" productVersion=\"{}\" creationDateTime=\"{}\" contentDescription=\"{}\"/>",
        env!("CARGO_PKG_VERSION"),
        xml(created),
        xml(&format!("Generated from the Petri net {} by petriplc", p.net_name)),
    );
    let _ = writeln!(w, "  <contentHeader name=\"{}\">", xml(&p.net_name));
    let _ = writeln!(w, "    <coordinateInfo>");
    for lang in ["fbd", "ld", "sfc"] {
        let _ = writeln!(
            w,
            "      <{lang}>\n        <scaling x=\"1\" y=\"1\"/>\n      </{lang}>"
        );
    }
    let _ = writeln!(w, "    </coordinateInfo>");
    let _ = writeln!(w, "  </contentHeader>");
    let _ = writeln!(w, "  <types>");
    let _ = writeln!(w, "    <dataTypes/>");
    let _ = writeln!(w, "    <pous>");
    let _ = writeln!(
        w,
        "      <pou name=\"{}\" pouType=\"program\">",
        xml(&p.pou)
    );
    let _ = writeln!(w, "        <interface>");
    for (tag, vars) in [
        ("inputVars", &interface.inputs),
        ("outputVars", &interface.outputs),
        ("localVars", &interface.locals),
    ] {
        if vars.is_empty() {
            continue;
        }
        let _ = writeln!(w, "          <{tag}>");
        for v in vars {
            write_var(w, v);
        }
        let _ = writeln!(w, "          </{tag}>");
    }
    let _ = writeln!(w, "        </interface>");
    match body {
        Body::St(text) | Body::Il(text) => {
            let tag = if matches!(body, Body::St(_)) {
                "ST"
            } else {
                "IL"
            };
            let _ = writeln!(w, "        <body>");
            let _ = writeln!(
                w,
                "          <{tag}>\n            <xhtml:p><![CDATA[{}]]></xhtml:p>\n          </{tag}>",
                text.replace("]]>", "]]]]><![CDATA[>")
            );
            let _ = writeln!(w, "        </body>");
        }
        Body::Graphical {
            language,
            content,
            pou_extra,
        } => {
            w.push_str(pou_extra);
            let _ = writeln!(w, "        <body>");
            let _ = writeln!(w, "          <{language}>");
            w.push_str(content);
            let _ = writeln!(w, "          </{language}>");
            let _ = writeln!(w, "        </body>");
        }
    }
    let _ = writeln!(
        w,
        "        <documentation>\n          <xhtml:p>{}</xhtml:p>\n        </documentation>",
        xml(&format!(
            "Petri net {}: step rule {}, evolution {}{}.",
            p.net_name,
            p.step.as_str(),
            p.evolve.as_str(),
            if p.boolean {
                ", BOOL markings"
            } else {
                ", integer markings"
            }
        ))
    );
    let _ = writeln!(w, "      </pou>");
    let _ = writeln!(w, "    </pous>");
    let _ = writeln!(w, "  </types>");
    let _ = writeln!(w, "  <instances>");
    let _ = writeln!(w, "    <configurations>");
    let _ = writeln!(w, "      <configuration name=\"config\">");
    let _ = writeln!(w, "        <resource name=\"resource1\">");
    let _ = writeln!(
        w,
        "          <task name=\"task0\" priority=\"0\" interval=\"{}\">",
        crate::iec_time(p.period)
    );
    let _ = writeln!(
        w,
        "            <pouInstance name=\"instance0\" typeName=\"{}\"/>",
        xml(&p.pou)
    );
    let _ = writeln!(w, "          </task>");
    let _ = writeln!(w, "        </resource>");
    let _ = writeln!(w, "      </configuration>");
    let _ = writeln!(w, "    </configurations>");
    let _ = writeln!(w, "  </instances>");
    let _ = writeln!(w, "</project>");
    out
}

fn write_var(w: &mut String, v: &Var) {
    let _ = writeln!(w, "            <variable name=\"{}\">", xml(&v.name));
    let ty = match &v.ty {
        VarType::Derived(name) => format!("<derived name=\"{}\"/>", xml(name)),
        other => format!("<{}/>", other.iec()),
    };
    let _ = writeln!(
        w,
        "              <type>\n                {ty}\n              </type>"
    );
    let _ = writeln!(
        w,
        "              <documentation>\n                <xhtml:p>{}</xhtml:p>\n              </documentation>",
        xml(&v.doc)
    );
    let _ = writeln!(w, "            </variable>");
}
