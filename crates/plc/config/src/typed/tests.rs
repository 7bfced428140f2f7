//! Tests of layer 2: modules and their settings, points against modules, tables and the
//! synchronisation net, each with its errors.

use super::*;
use std::path::Path;

/// Reads `input` as `t.conf` and renders the typed configuration (one line per point,
/// module, place, transition, arc, rule and start) or the diagnostics.
fn check(input: &str, expect: &str) {
    let got = match crate::parse_str(input, "t.conf", Path::new("/nonexistent-dir")) {
        Ok(c) => render(&c),
        Err(e) => e.to_string(),
    };
    assert_eq!(got.trim_end(), expect.trim(), "input:\n{input}");
}

fn render(c: &PlcConfig) -> String {
    let mut out = String::new();
    for (k, v) in &c.plc {
        out.push_str(&format!("plc {k}={}\n", v.value));
    }
    if c.retain != RetainSettings::default() {
        out.push_str(&format!(
            "retain {:?} {:?}\n",
            c.retain.file.as_ref().map(|s| &s.value),
            c.retain.write
        ));
    }
    for p in &c.points {
        let at = p.at.map_or("-".into(), |(w, b)| format!("{w}.{b}"));
        out.push_str(&format!(
            "point {} {} {at} {:?}{} {:?}\n",
            p.name, p.owner, p.kind, p.bits, p.init
        ));
    }
    for m in &c.modules {
        if let Some(w) = m.watchdog {
            out.push_str(&format!("watchdog {} {w:?}\n", m.name));
        }
        out.push_str(&format!(
            "module {} {} {:?} {:?} {:?} {:?} {:?} {:?} {:?} {:?}\n",
            m.name,
            m.kind,
            m.args,
            m.scan_period,
            m.location,
            m.priority,
            m.on_failure,
            m.scan_beg,
            m.scan_end,
            m.settings.keys().collect::<Vec<_>>()
        ));
    }
    let s = &c.synch;
    for p in &s.places {
        out.push_str(&format!("place {} {}\n", p.name, p.tokens));
    }
    for (t, _) in &s.transitions {
        out.push_str(&format!("transition {t}\n"));
    }
    for a in &s.arcs {
        out.push_str(&format!("arc {} -{}-> {}\n", a.from, a.weight, a.to));
    }
    for r in &s.rules {
        out.push_str(&format!("synch {} -{}-> {}\n", r.from, r.weight, r.to));
    }
    for (m, _) in &s.starts {
        out.push_str(&format!("start {m}\n"));
    }
    out
}

#[test]
fn modules_and_their_settings() {
    check(
        "[PLC]\nplc_id = 7\nmodule a petrinet x.pnml -v\nmodule b \"/usr/bin/my prog\"\n\
         a: scan_period = T#10ms\n[a]\nlocation = shared\npriority = 50\non_failure = restart\n\
         own = thing\n[b]\nscan_period = 0.25\nlocation = isolate\non_failure = ignore\n",
        r#"plc plc_id=7
module a petrinet ["x.pnml", "-v"] Some(10ms) Shared Some(50) Restart None None ["location", "on_failure", "own", "priority", "scan_period"]
module b /usr/bin/my prog [] Some(250ms) Isolate None Ignore None None ["location", "on_failure", "scan_period"]"#,
    );
}

#[test]
fn module_setting_errors() {
    check(
        "[PLC]\nmodule a x\nmodule\nmodule a y\nmodule NULL z\nmodule plc z\n[a]\n\
         scan_period = fast\nlocation = remote\npriority = 0\non_failure = retry\n\
         scan_beg = T9\nscan_end = NULL\n[ghost]\nscan_period = 1\nown = 1\n[A]\npriority = 5\n\
         [Plc]\nx = 1\n",
        "t.conf:3: error[C030]: a module needs a name and a kind or program: `module NAME KIND-or-PATH [args]`
t.conf:4: error[C031]: module a is declared twice (first at t.conf:2): module names name their sections, so rename or remove one of them
t.conf:2: note: module a first declared here
t.conf:5: error[C032]: `NULL` is reserved: give the module another name
t.conf:6: error[C032]: `plc` is reserved: give the module another name
t.conf:8: error[C034]: `scan_period = fast` for module a: `fast` is not a duration: write a number with a unit (`30s`, `500ms`, `1m30s`), plain seconds (`1.5`) or an IEC literal (`T#1m30s`)
t.conf:9: error[C035]: `location = remote` for module a: write `local` (the default), `shared` or `isolate`
t.conf:10: error[C036]: `priority = 0` for module a: write a real-time priority from 1 to 99, or leave it out for normal scheduling
t.conf:11: error[C037]: `on_failure = retry` for module a: write `stop` (the default), `restart` or `ignore`
t.conf:12: error[C038]: `scan_beg = T9` for module a: `T9` is not a declared transition: declare it with `transition T9` in [PLC], or write NULL (no transitions are declared)
t.conf:18: error[C033]: `priority` is set for `A`, but no module A is declared (did you mean a?): add `module A KIND-or-PATH` to [PLC], or remove the setting
t.conf:20: error[C039]: section [Plc] would be ignored: section names are case-sensitive, write [PLC]
t.conf:15: error[C033]: `scan_period` is set for `ghost`, but no module ghost is declared: add `module ghost KIND-or-PATH` to [PLC], or remove the setting
t.conf:16: error[C033]: `own` is set for `ghost`, but no module ghost is declared: add `module ghost KIND-or-PATH` to [PLC], or remove the setting",
    );
}

#[test]
fn a_setting_nobody_reads_is_an_error() {
    // A module started by hand must be declared too, so nobody reads [Kbd].
    check(
        "[PLC]\nplc_id = line2\nmodule a x\nconfmap_key = 20\nscan_period = 1\nflavour = 3\n\
         [Kbd]\nkey 38 left\nquiet = 1\n",
        "t.conf:4: error[C012]: `confmap_key = 20` in [PLC]: nothing reads this setting (MatPLC's key of its configuration shared memory; petriplc names its shared memory after the plc id); [PLC] has only plc_id, retain_file, retain_write
t.conf:5: error[C012]: `scan_period = 1` in [PLC]: nothing reads this setting; [PLC] has only plc_id, retain_file, retain_write; `scan_period` is a module's setting: write it in the module's section ([NAME]) or as `NAME: scan_period = 1`
t.conf:6: error[C012]: `flavour = 3` in [PLC]: nothing reads this setting; [PLC] has only plc_id, retain_file, retain_write
t.conf:9: error[C033]: `quiet` is set for `Kbd`, but no module Kbd is declared: add `module Kbd KIND-or-PATH` to [PLC], or remove the setting
t.conf:8: error[C033]: a `key` row in section [Kbd], but no module Kbd is declared: add `module Kbd KIND-or-PATH` to [PLC], or remove the row",
    );
    check("[PLC]\nplc_id =\n", "t.conf:2: error[C013]: `plc_id` is empty: give the PLC's id (letters, digits, `_`, `-`, `.`) or remove the line");
}

#[test]
fn retain_and_watchdog_settings() {
    check(
        "[PLC]\nretain_file = state/plc.retain\nretain_write = change\nmodule a x\n\
         [a]\nwatchdog = T#50ms\n",
        r#"plc retain_file=state/plc.retain
plc retain_write=change
retain Some("state/plc.retain") Change
watchdog a 50ms
module a x [] None Local None Stop None None ["watchdog"]"#,
    );
    check(
        "[PLC]\nretain_write = 0.2\nmodule a x\n",
        r#"plc retain_write=0.2
retain None Every(200ms)
module a x [] None Local None Stop None None []"#,
    );
    check(
        "[PLC]\nretain_file =\nretain_write = often\nmodule a x\nmodule b y\n\
         [a]\nwatchdog = 0\n[b]\nwatchdog = soon\n",
        "t.conf:2: error[C061]: `retain_file` is empty: give the file that keeps the retentive values (relative to this configuration file's folder), or remove the line for the default
t.conf:3: error[C061]: `retain_write = often`: write `change` (every change, as soon as the previous write is done) or the shortest time between two writes (e.g. `T#500ms`, the default): `often` is not a duration: write a number with a unit (`30s`, `500ms`, `1m30s`), plain seconds (`1.5`) or an IEC literal (`T#1m30s`)
t.conf:7: error[C060]: `watchdog = 0` for module a: a watchdog must be longer than 0 (e.g. `T#100ms`); remove the line for none
t.conf:9: error[C060]: `watchdog = soon` for module b: `soon` is not a duration: write a number with a unit (`30s`, `500ms`, `1m30s`), plain seconds (`1.5`) or an IEC literal (`T#1m30s`)",
    );
}

#[test]
fn restart_settings() {
    check(
        "[PLC]\nmodule a x\n[a]\non_failure = restart\nrestart_delay = T#50ms\n\
         restart_delay_max = 2\nrestart_limit = 0\n",
        r#"module a x [] None Local None Restart None None ["on_failure", "restart_delay", "restart_delay_max", "restart_limit"]"#,
    );
    check(
        "[PLC]\nmodule a x\nmodule b y\nmodule c z\n[a]\non_failure = restart\n\
         restart_delay = soon\nrestart_delay_max = 0\nrestart_limit = -1\n\
         [b]\nrestart_limit = 3\n[c]\non_failure = restart\nrestart_delay = 20\n",
        "t.conf:7: error[C029]: `restart_delay = soon` for module a: `soon` is not a duration: write a number with a unit (`30s`, `500ms`, `1m30s`), plain seconds (`1.5`) or an IEC literal (`T#1m30s`)
t.conf:8: error[C029]: `restart_delay_max = 0` for module a: the longest delay between restarts must be longer than 0 (e.g. `T#10s`)
t.conf:9: error[C029]: `restart_limit = -1` for module a: write how many restarts in a row are allowed (a whole number; 0 for no limit)
t.conf:11: error[C029]: `restart_limit = 3` for module b: nothing reads it, because the module's on_failure is not `restart`; set `on_failure = restart` or remove the line
t.conf:14: error[C029]: module c: restart_delay (20s) is longer than restart_delay_max (10s): the delay starts at restart_delay and doubles up to restart_delay_max",
    );
}

#[test]
fn points_against_modules() {
    check(
        "[PLC]\nmodule m x\npoint a \"A\" m at 0.0 4\npoint b \"B\" m at 0.3\npoint c \"C\" m at 1\n\
         point d \"D\" m at 1.31\npoint a \"A again\" m\npoint e \"E\" nobody\npoint f \"F\" m at 0.4 28\n",
        "t.conf:7: error[C021]: point a is declared twice (first at t.conf:3): a point has one owner and one place, so rename or remove one of them
t.conf:3: note: point a first declared here
t.conf:8: error[C022]: the owner of point e, `nobody`, is not a declared module: add `module nobody KIND-or-PATH` to [PLC] or give the point another owner (declared modules: m)
t.conf:4: error[C028]: point b (bits 3) overlaps point a (bits 0-3, at t.conf:3) in word 0: each bit has one writer, so move one of them
t.conf:3: note: point a declared here
t.conf:6: error[C028]: point d (bits 31) overlaps point c (bits 0-31, at t.conf:5) in word 1: each bit has one writer, so move one of them
t.conf:5: note: point c declared here",
    );
    check(
        "[PLC]\nmodule m x\npoint a \"A\" m at 0.0 4\npoint b \"B\" m at 0.4 28\npoint c \"\" m\npoint d \"\" m\n",
        "point a m 0.0 Unsigned4 Unsigned(0)\npoint b m 0.4 Unsigned28 Unsigned(0)\n\
         point c m - Unsigned1 Unsigned(0)\npoint d m - Unsigned1 Unsigned(0)\nmodule m x [] None Local None Stop None None []",
    );
}

#[test]
fn tables() {
    check(
        "[PLC]\npoint_alias x \"\" y\nsynchpt a\nlog a b\nPoint a \"\" m\n",
        "t.conf:2: error[C011]: MatPLC's `point_alias` table is not supported: declare separate points instead
t.conf:3: error[C011]: MatPLC's `synchpt` table is not supported: use `scan_beg`/`scan_end` settings of the modules instead
t.conf:4: error[C010]: `log` is not a [PLC] table: the tables are point, module, place, transition, arc, synch, synch_start; settings are written `name = value`, and a module's own tables belong in its [module] section
t.conf:5: error[C010]: `Point` is not a [PLC] table: the tables are point, module, place, transition, arc, synch, synch_start; settings are written `name = value`, and a module's own tables belong in its [module] section",
    );
}

#[test]
fn advanced_synchronisation_net() {
    check(
        "[PLC]\nmodule a x\nplace P 2\nplace Q\ntransition Tb\ntransition Te\n\
         arc P --2--> Tb\narc Te -> Q\narc Q -0-> Te\n[a]\nscan_beg = Tb\nscan_end = Te\n",
        "module a x [] None Local None Stop Some(\"Tb\") Some(\"Te\") [\"scan_beg\", \"scan_end\"]
place P 2
place Q 0
transition Tb
transition Te
arc P -2-> Tb
arc Te -1-> Q
arc Q -0-> Te",
    );
}

#[test]
fn net_errors() {
    check(
        "[PLC]\nplace P x\nplace\nplace A 1 2\ntransition\ntransition T U\ntransition NULL\n\
         place P2\ntransition T\ntransition P2\nplace T\narc P -> T\narc P\narc P->T\n\
         arc P => T\narc X -> T\narc NULL -> P2\narc P2 -> P2\narc T -0-> P2\n",
        "t.conf:2: error[C040]: a place is `place NAME [TOKENS]` with TOKENS a whole number (0 when left out)
t.conf:3: error[C040]: a place is `place NAME [TOKENS]` with TOKENS a whole number (0 when left out)
t.conf:4: error[C040]: a place is `place NAME [TOKENS]` with TOKENS a whole number (0 when left out)
t.conf:5: error[C041]: a transition is `transition NAME`, one per row
t.conf:6: error[C041]: a transition is `transition NAME`, one per row
t.conf:13: error[C043]: `arc` takes three words, `arc FROM ARROW TO` (e.g. `arc A -> B`)
t.conf:14: error[C043]: `arc` takes three words, `arc FROM ARROW TO` (e.g. `arc A -> B`): put spaces around the arrow
t.conf:15: error[C044]: `=>` is not an arrow: write `->` for weight 1 or `-N->` for weight N
t.conf:7: error[C032]: `NULL` is reserved for the null transition: give the transition another name
t.conf:10: error[C042]: `P2` is already declared as a place at t.conf:8: places and transitions share one set of names, so rename one of them
t.conf:8: note: the place `P2` declared here
t.conf:11: error[C042]: `T` is already declared as a transition at t.conf:9: places and transitions share one set of names, so rename one of them
t.conf:9: note: the transition `T` declared here
t.conf:12: error[C045]: the arc names `P`, which is neither a place nor a transition: declare it with `place P` or `transition P`
t.conf:16: error[C045]: the arc names `X`, which is neither a place nor a transition: declare it with `place X` or `transition X`
t.conf:17: error[C045]: an arc cannot touch `NULL` (the null transition never fires anything): declare a transition and use it
t.conf:18: error[C046]: the arc goes from place `P2` to place `P2`: an arc joins a place and a transition
t.conf:19: error[C047]: the arc from transition `T` to place `P2` has weight 0, which only arcs from a place may have (\"fire only while the place is empty\"): give it a weight of 1 or more",
    );
}

#[test]
fn simple_synchronisation() {
    check(
        "[PLC]\nmodule a x\nmodule b y\nsynch a -> b\nsynch b -(3)-> a\nsynch_start a b\n",
        "module a x [] None Local None Stop None None []
module b y [] None Local None Stop None None []
synch a -1-> b
synch b -3-> a
start a
start b",
    );
    check(
        "[PLC]\nmodule a x\nsynch a --0--> a\nsynch a -> c\nsynch a\nsynch_start\nsynch_start a z\n\
         synch a <- a\n",
        "t.conf:3: error[C051]: `synch a --0--> a` has weight 0, which synch does not allow: use a weight of 1 or more (weight-0 arcs need the place/transition/arc form)
t.conf:5: error[C050]: `synch` takes three words, `synch MODULE1 ARROW MODULE2` (e.g. `synch A -> B`)
t.conf:6: error[C050]: `synch_start` needs at least one module: `synch_start MODULE [MODULE ...]`
t.conf:8: error[C044]: `<-` is not an arrow (arrows point from left to right: swap the two names): write `->` for weight 1 or `-N->` for weight N
t.conf:4: error[C052]: `synch` names `c`, which is not a declared module: declare it with `module c KIND-or-PATH` or correct the name (declared modules: a)
t.conf:7: error[C052]: `synch_start` names `z`, which is not a declared module: declare it with `module z KIND-or-PATH` or correct the name (declared modules: a)",
    );
}

#[test]
fn empty_configuration_is_valid() {
    check("", "");
    check("# nothing\n", "");
}
