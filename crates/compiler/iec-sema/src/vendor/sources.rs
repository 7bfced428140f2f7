//! The vendor libraries' declarations written in Structured Text
//! (`petriplc_iec_syntax::builtin`: TwinCAT's `T_MaxString`, `__SYSTEM.TYPE_CLASS`,
//! `F_CheckMemoryArea`, `LEN2`…), added to a project that loads their library. A name the
//! project declares itself is the project's: the library's declaration of it is left out, as
//! a user's POU replaces a vendor one.

use std::collections::HashSet;

use petriplc_iec_syntax::ast::{Element, Library};
use petriplc_iec_syntax::{builtin, Diagnostics};

/// The global variable lists of the libraries, by their first variable.
const LISTS: &[(&str, &str)] = &[("_TaskInfo", "TwinCAT_SystemInfoVarList")];

/// `lib` with the declarations of the loaded libraries `libs` before its own; `None` when
/// none of them brings any.
pub fn with_sources(lib: &Library, libs: &[String], diags: &mut Diagnostics) -> Option<Library> {
    let mut added: Vec<Element> = Vec::new();
    for l in libs {
        if let Some(parsed) = builtin::library(l, diags) {
            added.extend(parsed.elements);
        }
    }
    if added.is_empty() {
        return None;
    }
    let own = declared(lib);
    let mut whole = Library::default();
    for e in added {
        match e {
            Element::Types(mut decls) => {
                decls.retain(|d| !own.contains(&d.name.key()));
                if !decls.is_empty() {
                    whole.elements.push(Element::Types(decls));
                }
            }
            Element::Pou(p) if own.contains(&p.name.key()) => {}
            Element::Globals(mut block) => {
                for v in &mut block.vars {
                    v.names.retain(|n| !own.contains(&n.key()));
                }
                // A library's global variable list is named by its first variable (ST has
                // no syntax for a list's name, which TwinCAT takes from the file).
                let first = block.vars.first().and_then(|v| v.names.first());
                if let Some((_, list)) = first.and_then(|n| LISTS.iter().find(|(v, _)| n.is(v))) {
                    block.list = Some(petriplc_iec_syntax::ast::Ident::new(
                        *list,
                        first.map_or_else(Default::default, |n| n.span),
                    ));
                }
                block.vars.retain(|v| !v.names.is_empty());
                if !block.vars.is_empty() {
                    whole.elements.push(Element::Globals(block));
                }
            }
            e => whole.elements.push(e),
        }
    }
    whole.elements.extend(lib.elements.iter().cloned());
    Some(whole)
}

/// Every name `lib` declares at its top level: types, POUs, global variables (upper case).
fn declared(lib: &Library) -> HashSet<String> {
    let mut names = HashSet::new();
    for e in &lib.elements {
        match e {
            Element::Types(decls) => names.extend(decls.iter().map(|d| d.name.key())),
            Element::Pou(p) => {
                names.insert(p.name.key());
            }
            Element::Globals(block) => {
                for v in &block.vars {
                    names.extend(v.names.iter().map(|n| n.key()));
                }
            }
            Element::Configuration(c) => {
                for b in c
                    .globals
                    .iter()
                    .chain(c.resources.iter().flat_map(|r| &r.globals))
                {
                    for v in &b.vars {
                        names.extend(v.names.iter().map(|n| n.key()));
                    }
                }
            }
        }
    }
    names
}
