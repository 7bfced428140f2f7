# Writes the LD/SFC conformance corpus (PLCopen TC6 v2.01 projects) into corpus-graphical/:
#   python3 crates/compiler/iec/tests/corpus_graphical.py
# Each project carries its expected values in an XML comment read by tests/conformance.rs.
import os
OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "corpus-graphical")

def var(name, ty, init=None):
    t = f"<{ty}/>" if ty.isupper() and ty not in ("TON","TOF","TP","CTU","CTD","R_TRIG","F_TRIG","SR","RS") else f'<derived name="{ty}"/>'
    iv = f'<initialValue><simpleValue value="{init}"/></initialValue>' if init is not None else ""
    return f'<variable name="{name}"><type>{t}</type>{iv}</variable>'

def project(spec, vars_in, vars_out, vars_local, lang, body, extra=""):
    def block(tag, vs):
        if not vs: return ""
        return f"<{tag}>" + "".join(var(*v) for v in vs) + f"</{tag}>"
    iface = block("inputVars", vars_in) + block("outputVars", vars_out) + block("localVars", vars_local)
    return f'''<?xml version="1.0" encoding="utf-8"?>
<!-- (* {spec}
*) -->
<project xmlns="http://www.plcopen.org/xml/tc6_0201" xmlns:xhtml="http://www.w3.org/1999/xhtml">
  <fileHeader companyName="petriplc" productName="petriplc corpus" productVersion="1" creationDateTime="2026-11-25T12:00:00"/>
  <contentHeader name="corpus">
    <coordinateInfo>
      <fbd><scaling x="1" y="1"/></fbd>
      <ld><scaling x="1" y="1"/></ld>
      <sfc><scaling x="1" y="1"/></sfc>
    </coordinateInfo>
  </contentHeader>
  <types>
    <dataTypes/>
    <pous>
      <pou name="main" pouType="program">
        <interface>{iface}</interface>
{extra}        <body>
          <{lang}>
{body}
          </{lang}>
        </body>
      </pou>
    </pous>
  </types>
  <instances>
    <configurations/>
  </instances>
</project>
'''

class G:
    """Elements of one graphical body, with positions on a grid."""
    def __init__(self):
        self.els = []; self.n = 0; self.y = 20
    def id(self):
        self.n += 1; return self.n
    def pos(self, x=None):
        self.y += 40
        return f'<position x="{x or 20}" y="{self.y}"/>'
    def cin(self, refs):
        if refs is None: return "<connectionPointIn/>"
        cs = "".join(f'<connection refLocalId="{r}"/>' if isinstance(r, int) else f'<connection refLocalId="{r[0]}" formalParameter="{r[1]}"/>' for r in refs)
        return f"<connectionPointIn>{cs}</connectionPointIn>"
    def left(self):
        i = self.id(); self.els.append(f'<leftPowerRail localId="{i}" height="40" width="3">{self.pos()}<connectionPointOut formalParameter=""/></leftPowerRail>'); return i
    def right(self, refs):
        i = self.id(); self.els.append(f'<rightPowerRail localId="{i}" height="40" width="3">{self.pos(400)}{self.cin(refs)}</rightPowerRail>'); return i
    def contact(self, refs, v, negated=False, edge=None, order=None):
        i = self.id()
        a = f' negated="{str(negated).lower()}"' + (f' edge="{edge}"' if edge else "") + (f' executionOrderId="{order}"' if order else "")
        self.els.append(f'<contact localId="{i}" height="15" width="21"{a}>{self.pos(70)}{self.cin(refs)}<connectionPointOut/><variable>{v}</variable></contact>'); return i
    def coil(self, refs, v, negated=False, storage=None, edge=None, order=None):
        i = self.id()
        a = f' negated="{str(negated).lower()}"' + (f' storage="{storage}"' if storage else "") + (f' edge="{edge}"' if edge else "") + (f' executionOrderId="{order}"' if order else "")
        self.els.append(f'<coil localId="{i}" height="15" width="21"{a}>{self.pos(130)}{self.cin(refs)}<connectionPointOut/><variable>{v}</variable></coil>'); return i
    def invar(self, e):
        i = self.id(); self.els.append(f'<inVariable localId="{i}" height="30" width="70">{self.pos(100)}<connectionPointOut/><expression>{e}</expression></inVariable>'); return i
    def outvar(self, refs, e, order=None):
        i = self.id(); a = f' executionOrderId="{order}"' if order else ""
        self.els.append(f'<outVariable localId="{i}" height="30" width="70"{a}>{self.pos(300)}{self.cin(refs)}<expression>{e}</expression></outVariable>'); return i
    def block(self, ty, inst, ins, outs, order=None):
        i = self.id()
        a = (f' instanceName="{inst}"' if inst else "") + (f' executionOrderId="{order}"' if order else "")
        # An input is (name, refs) or (name, refs, pin attributes); an output a name or (name, attributes).
        pin = lambda a: "".join(f' {k}="{v}"' for k, v in a.items())
        iv = "".join(f'<variable formalParameter="{v[0]}"{pin(v[2] if len(v) > 2 else {})}>{self.cin(v[1])}</variable>' for v in ins)
        ov = "".join(f'<variable formalParameter="{fp}"{pin(a)}><connectionPointOut/></variable>' for fp, a in ((o, {}) if isinstance(o, str) else o for o in outs))
        self.els.append(f'<block localId="{i}" width="70" height="70" typeName="{ty}"{a}>{self.pos(200)}<inputVariables>{iv}</inputVariables><inOutVariables/><outputVariables>{ov}</outputVariables></block>'); return i
    def connector(self, refs, name):
        i = self.id(); self.els.append(f'<connector localId="{i}" name="{name}" height="20" width="40">{self.pos(300)}{self.cin(refs)}</connector>'); return i
    def continuation(self, name):
        i = self.id(); self.els.append(f'<continuation localId="{i}" name="{name}" height="20" width="40">{self.pos(20)}<connectionPointOut/></continuation>'); return i
    def ret(self, refs):
        i = self.id(); self.els.append(f'<return localId="{i}" height="20" width="40">{self.pos(300)}{self.cin(refs)}</return>'); return i
    # SFC
    def step(self, name, refs=None, initial=False, action=False):
        i = self.id()
        a = ' initialStep="true"' if initial else ""
        cin = self.cin(refs) if refs else ""
        act = '<connectionPointOutAction formalParameter=""/>' if action else ""
        self.els.append(f'<step localId="{i}" height="30" width="90" name="{name}"{a}>{self.pos(100)}{cin}<connectionPointOut formalParameter=""/>{act}</step>'); return i
    def trans(self, refs, cond=None, ref=None, priority=None, conn=None, x=140):
        i = self.id()
        a = f' priority="{priority}"' if priority else ""
        if cond is not None:
            c = f'<inline name=""><ST><xhtml:p><![CDATA[{cond}]]></xhtml:p></ST></inline>'
        elif ref is not None:
            c = f'<reference name="{ref}"/>'
        else:
            c = self.cin(conn)
        self.els.append(f'<transition localId="{i}" height="2" width="20"{a}>{self.pos(x)}{self.cin(refs)}<connectionPointOut/><condition>{c}</condition></transition>'); return i
    def seldiv(self, ref, n):
        i = self.id(); outs = "".join(f'<connectionPointOut formalParameter="{k}"/>' for k in range(n))
        self.els.append(f'<selectionDivergence localId="{i}" height="1" width="200">{self.pos(100)}{self.cin([ref])}{outs}</selectionDivergence>'); return i
    def selconv(self, refs):
        i = self.id(); ins = "".join(self.cin([r]) for r in refs)
        self.els.append(f'<selectionConvergence localId="{i}" height="1" width="200">{self.pos(100)}{ins}<connectionPointOut/></selectionConvergence>'); return i
    def simdiv(self, ref, n):
        i = self.id(); outs = "".join(f'<connectionPointOut formalParameter="{k}"/>' for k in range(n))
        self.els.append(f'<simultaneousDivergence localId="{i}" height="3" width="200">{self.pos(100)}{self.cin([ref])}{outs}</simultaneousDivergence>'); return i
    def simconv(self, refs):
        i = self.id(); ins = "".join(self.cin([r]) for r in refs)
        self.els.append(f'<simultaneousConvergence localId="{i}" height="3" width="200">{self.pos(100)}{ins}<connectionPointOut/></simultaneousConvergence>'); return i
    def jump(self, ref, target):
        i = self.id(); self.els.append(f'<jumpStep localId="{i}" height="13" width="12" targetName="{target}">{self.pos(140)}{self.cin([ref])}</jumpStep>'); return i
    def actions(self, step, acts):
        i = self.id(); body = ""
        for k, a in enumerate(acts):
            q, target = a[0], a[1]; dur = f' duration="{a[2]}"' if len(a) > 2 and a[2] else ""
            self.n += 1
            if target.startswith("ST:"):
                t = f'<inline><ST><xhtml:p><![CDATA[{target[3:]}]]></xhtml:p></ST></inline>'
            else:
                t = f'<reference name="{target}"/>'
            body += f'<action localId="{self.n}" qualifier="{q}"{dur}><relPosition x="0" y="{30*k}"/>{t}</action>'
        self.els.append(f'<actionBlock localId="{i}" height="30" width="100">{self.pos(300)}{self.cin([step])}{body}</actionBlock>'); return i
    def text(self):
        return "\n".join("            " + e for e in self.els)

files = {}
def add(name, spec, ins, outs, locs, lang, g, extra=""):
    files[name] = project(spec, ins, outs, locs, lang, g.text(), extra)

B = "BOOL"
# --- LD ---
g = G(); l = g.left(); c = g.contact([l], "a"); q = g.coil([c], "q"); g.right([q])
add("ld01_contact_coil", "A normal contact drives a normal coil.\n   after 1: q = FALSE\n   set 2: a = TRUE\n   after 2: q = TRUE\n   set 3: a = FALSE\n   after 3: q = FALSE", [("a",B)], [("q",B)], [], "LD", g)

g = G(); l = g.left(); c = g.contact([l], "a", negated=True); q = g.coil([c], "q"); q2 = g.coil([c], "nq", negated=True); g.right([q, q2])
add("ld02_negated", "A negated contact and a negated coil.\n   after 1: q = TRUE, nq = FALSE\n   set 2: a = TRUE\n   after 2: q = FALSE, nq = TRUE", [("a",B)], [("q",B),("nq",B)], [], "LD", g)

g = G(); l = g.left(); a = g.contact([l], "a"); b = g.contact([a], "b"); q = g.coil([b], "q"); g.right([q])
add("ld03_series", "Contacts in series are an AND.\n   set 1: a = TRUE\n   after 1: q = FALSE\n   set 2: b = TRUE\n   after 2: q = TRUE\n   set 3: a = FALSE\n   after 3: q = FALSE", [("a",B),("b",B)], [("q",B)], [], "LD", g)

g = G(); l = g.left(); a = g.contact([l], "a"); b = g.contact([l], "b"); c = g.contact([a, b], "c"); q = g.coil([c], "q"); g.right([q])
add("ld04_parallel", "Parallel branches are an OR: (a OR b) AND c.\n   set 1: c = TRUE\n   after 1: q = FALSE\n   set 2: b = TRUE\n   after 2: q = TRUE\n   set 3: b = FALSE, a = TRUE\n   after 3: q = TRUE\n   set 4: c = FALSE\n   after 4: q = FALSE", [("a",B),("b",B),("c",B)], [("q",B)], [], "LD", g)

g = G(); l = g.left(); s = g.contact([l], "s"); qs = g.coil([s], "q", storage="set"); g.right([qs]); l2 = g.left(); r = g.contact([l2], "r"); qr = g.coil([r], "q", storage="reset"); g.right([qr])
add("ld05_set_reset", "Set and reset coils latch; the later rung wins.\n   set 2: s = TRUE\n   after 2: q = TRUE\n   set 3: s = FALSE\n   after 3: q = TRUE\n   set 4: r = TRUE\n   after 4: q = FALSE\n   set 5: s = TRUE\n   after 5: q = FALSE\n   set 6: r = FALSE\n   after 6: q = TRUE", [("s",B),("r",B)], [("q",B)], [], "LD", g)

g = G(); l = g.left(); c = g.contact([l], "a", edge="rising"); q = g.coil([c], "p"); g.right([q])
add("ld06_rising_contact", "A rising-edge contact conducts for one scan.\n   after 1: p = FALSE\n   set 2: a = TRUE\n   after 2: p = TRUE\n   after 3: p = FALSE\n   set 4: a = FALSE\n   after 4: p = FALSE\n   set 5: a = TRUE\n   after 5: p = TRUE", [("a",B)], [("p",B)], [], "LD", g)

g = G(); l = g.left(); c = g.contact([l], "a", edge="falling"); q = g.coil([c], "p"); g.right([q])
add("ld07_falling_contact", "A falling-edge contact conducts for one scan after its variable falls.\n   set 1: a = TRUE\n   after 1: p = FALSE\n   set 2: a = FALSE\n   after 2: p = TRUE\n   after 3: p = FALSE", [("a",B)], [("p",B)], [], "LD", g)

g = G(); l = g.left(); c = g.contact([l], "a"); q1 = g.coil([c], "q1"); q2 = g.coil([q1], "q2"); c2 = g.contact([q2], "b"); q3 = g.coil([c2], "q3"); g.right([q3])
add("ld08_coils_in_series", "A coil passes its power on to what follows it.\n   set 1: a = TRUE\n   after 1: q1 = TRUE, q2 = TRUE, q3 = FALSE\n   set 2: b = TRUE\n   after 2: q3 = TRUE\n   set 3: a = FALSE\n   after 3: q1 = FALSE, q2 = FALSE, q3 = FALSE", [("a",B),("b",B)], [("q1",B),("q2",B),("q3",B)], [], "LD", g)

g = G(); l = g.left(); c = g.contact([l], "go"); pt = g.invar("T#50ms"); t = g.block("TON", "t1", [("IN",[c]),("PT",[pt])], ["Q","ET"]); q = g.coil([(t,"Q")], "done"); g.right([q]); o = g.outvar([(t,"ET")], "et")
add("ld09_ton", "A TON instance in a rung; its elapsed time to a variable.\n   period: T#10ms\n   set 1: go = TRUE\n   after 5: done = FALSE, et = T#40ms\n   after 6: done = TRUE, et = T#50ms\n   set 7: go = FALSE\n   after 7: done = FALSE, et = T#0s", [("go",B)], [("done",B),("et","TIME")], [("t1","TON")], "LD", g)

g = G(); l = g.left(); c = g.contact([l], "pulse"); r = g.contact([l], "clear"); pv = g.invar("3"); t = g.block("CTU", "c1", [("CU",[c]),("R",[r]),("PV",[pv])], ["Q","CV"]); q = g.coil([(t,"Q")], "full"); g.right([q]); o = g.outvar([(t,"CV")], "n")
add("ld10_ctu", "A CTU instance counts rising edges of a contact's power.\n   set 1: pulse = TRUE\n   after 1: n = 1, full = FALSE\n   set 2: pulse = FALSE\n   set 3: pulse = TRUE\n   set 4: pulse = FALSE\n   set 5: pulse = TRUE\n   after 5: n = 3, full = TRUE\n   set 6: clear = TRUE\n   after 6: n = 0, full = FALSE", [("pulse",B),("clear",B)], [("full",B),("n","INT")], [("c1","CTU")], "LD", g)

g = G(); a = g.invar("x"); b = g.invar("y"); s = g.block("ADD", None, [("IN1",[a]),("IN2",[b])], ["OUT"]); m = g.invar("3"); p = g.block("MUL", None, [("IN1",[(s,"OUT")]),("IN2",[m])], ["OUT"]); g.outvar([(p,"OUT")], "z")
add("ld11_functions", "Functions in a network, result to an output variable: z := (x + y) * 3.\n   set 1: x = 2, y = 5\n   after 1: z = 21\n   set 2: y = -4\n   after 2: z = -6", [("x","INT"),("y","INT")], [("z","INT")], [], "LD", g)

g = G(); l = g.left(); a = g.invar("level"); k = g.invar("50"); gt = g.block("GT", None, [("IN1",[a]),("IN2",[k])], ["OUT"]); c = g.contact([l], "enable"); and_ = g.block("AND", None, [("IN1",[c]),("IN2",[(gt,"OUT")])], ["OUT"]); q = g.coil([(and_,"OUT")], "alarm"); g.right([q])
add("ld12_comparison", "A comparison function feeds a coil through AND.\n   set 1: enable = TRUE, level = 40\n   after 1: alarm = FALSE\n   set 2: level = 51\n   after 2: alarm = TRUE\n   set 3: enable = FALSE\n   after 3: alarm = FALSE", [("level","INT"),("enable",B)], [("alarm",B)], [], "LD", g)

g = G(); l = g.left(); a = g.contact([l], "a"); g.connector([a], "wire"); k = g.continuation("wire"); b = g.contact([k], "b"); q = g.coil([b], "q"); g.right([q])
add("ld13_connector", "A connector and its continuation carry power across the diagram.\n   set 1: a = TRUE\n   after 1: q = FALSE\n   set 2: b = TRUE\n   after 2: q = TRUE", [("a",B),("b",B)], [("q",B)], [], "LD", g)

g = G(); l = g.left(); c = g.contact([l], "stop"); g.ret([c]); l2 = g.left(); t = g.contact([l2], "stop", negated=True); q = g.coil([l2], "ran"); g.right([q])
add("ld14_return", "A conditional return leaves the rest of the body unrun.\n   after 1: ran = TRUE\n   set 2: stop = TRUE, ran = FALSE\n   after 2: ran = FALSE", [("stop",B)], [("ran",B)], [], "LD", g)

g = G(); l = g.left(); en = g.contact([l], "run"); c = g.contact([l], "tick"); pv = g.invar("100"); t = g.block("CTU", "c1", [("EN",[en]),("CU",[c]),("PV",[pv])], ["ENO","Q","CV"]); q = g.coil([(t,"ENO")], "running"); g.right([q]); g.outvar([(t,"CV")], "n")
add("ld15_en_eno", "EN of a block instance: the instance runs only when EN has power; ENO follows EN.\n   set 1: tick = TRUE\n   after 1: n = 0, running = FALSE\n   set 2: tick = FALSE, run = TRUE\n   set 3: tick = TRUE\n   after 3: n = 1, running = TRUE", [("run",B),("tick",B)], [("running",B),("n","INT")], [("c1","CTU")], "LD", g)

g = G(); l = g.left(); c = g.contact([l], "a"); q = g.coil([c], "up", edge="rising"); q2 = g.coil([c], "down", edge="falling"); g.right([q, q2])
add("ld16_edge_coils", "Rising and falling coils write TRUE for one scan at an edge of their power.\n   set 2: a = TRUE\n   after 2: up = TRUE, down = FALSE\n   after 3: up = FALSE\n   set 4: a = FALSE\n   after 4: down = TRUE\n   after 5: down = FALSE", [("a",B)], [("up",B),("down",B)], [], "LD", g)

g = G(); l = g.left(); c = g.contact([l], "b", order=1); q = g.coil([c], "c", order=2); g.right([q]); l2 = g.left(); a = g.contact([l2], "a"); qb = g.coil([a], "b", order=1); g.right([qb])
add("ld17_execution_order", "executionOrderId decides the order: b := a runs before c := b.\n   set 1: a = TRUE\n   after 1: b = TRUE, c = TRUE", [("a",B)], [("c",B)], [("b",B)], "LD", g)

g = G(); l = g.left(); a = g.contact([l], "a"); b = g.contact([a], "a", negated=True); q = g.coil([a], "a_copy"); q2 = g.coil([b], "never"); g.right([q, q2])
add("ld18_shared_power", "Power read by two elements is computed once; a contact and its negation in series never conduct.\n   set 1: a = TRUE\n   after 1: a_copy = TRUE, never = FALSE\n   set 2: a = FALSE\n   after 2: a_copy = FALSE, never = FALSE", [("a",B)], [("a_copy",B),("never",B)], [], "LD", g)

g = G(); l = g.left(); a = g.contact([l], "a"); t = g.invar("TRUE"); f = g.invar("FALSE")
p = g.block("AND", None, [("IN1",[a],{"edge":"rising"}),("IN2",[t])], ["OUT"]); g.outvar([(p,"OUT")], "pulse")
o = g.block("OR", None, [("IN1",[a],{"negated":"true"}),("IN2",[f])], [("OUT",{"negated":"true"})]); g.outvar([(o,"OUT")], "same")
pv = g.invar("2"); c = g.block("CTU", "c1", [("CU",[a],{"edge":"falling"}),("PV",[pv])], [("Q",{"negated":"true"}),"CV"]); g.outvar([(c,"Q")], "below"); g.outvar([(c,"CV")], "n")
pt = g.invar("T#10ms"); tm = g.block("TON", "t1", [("IN",[a]),("PT",[pt])], [("Q",{"edge":"rising"}),"ET"]); g.outvar([(tm,"Q")], "done_pulse"); g.right([l])
add("ld19_block_pins", "Edges and negations on block pins: a rising input gives a one-scan pulse, a negated input and output cancel, a falling input makes CTU count falls, a negated output, a rising output.\n   set 1: a = TRUE\n   after 1: pulse = TRUE, same = TRUE, n = 0, below = TRUE, done_pulse = FALSE\n   after 2: pulse = FALSE, same = TRUE, done_pulse = TRUE\n   set 3: a = FALSE\n   after 3: pulse = FALSE, same = FALSE, n = 1, below = TRUE, done_pulse = FALSE\n   set 4: a = TRUE\n   set 5: a = FALSE\n   after 5: n = 2, below = FALSE", [("a",B)], [("pulse",B),("same",B),("below",B),("n","INT"),("done_pulse",B)], [("c1","CTU"),("t1","TON")], "LD", g)

g = G(); l = g.left(); run = g.contact([l], "run"); x = g.invar("x"); five = g.invar("5")
s = g.block("ADD", None, [("EN",[run]),("IN1",[x]),("IN2",[five])], ["ENO","OUT"]); q = g.coil([(s,"ENO")], "added"); g.right([q]); g.outvar([(s,"OUT")], "y")
add("ld20_function_en_eno", "EN of a function: with EN FALSE the function does not run, its result is 0 (as matiec) and ENO is FALSE.\n   set 1: x = 2\n   after 1: y = 0, added = FALSE\n   set 2: run = TRUE\n   after 2: y = 7, added = TRUE\n   set 3: run = FALSE\n   after 3: y = 0, added = FALSE", [("run",B),("x","INT")], [("added",B),("y","INT")], [], "LD", g)

# --- FBD ---
g = G(); en = g.invar("go"); tick = g.invar("tick"); pv = g.invar("3")
c = g.block("CTU", "c1", [("EN",[en]),("CU",[tick],{"negated":"true"}),("PV",[pv])], ["ENO",("Q",{"negated":"true"}),"CV"])
g.outvar([(c,"ENO")], "ran"); g.outvar([(c,"Q")], "more"); g.outvar([(c,"CV")], "n")
add("fbd01_en_eno_pins", "FBD: a block instance with EN, a negated input and a negated output; ENO tells whether it ran.\n   set 1: tick = TRUE\n   after 1: ran = FALSE, n = 0, more = TRUE\n   set 2: go = TRUE\n   after 2: ran = TRUE, n = 0\n   set 3: tick = FALSE\n   after 3: n = 1, more = TRUE\n   set 4: tick = TRUE\n   set 5: tick = FALSE\n   after 5: n = 2\n   set 6: tick = TRUE\n   set 7: tick = FALSE\n   after 7: n = 3, more = FALSE\n   set 8: go = FALSE\n   after 8: ran = FALSE, more = FALSE", [("go",B),("tick",B)], [("ran",B),("more",B),("n","INT")], [("c1","CTU")], "FBD", g)

# --- SFC ---
def sfc_linear():
    g = G(); s0 = g.step("Idle", initial=True); t1 = g.trans([s0], "start"); s1 = g.step("Run", [t1], action=True); g.actions(s1, [("N", "motor")]); t2 = g.trans([s1], "stop"); g.jump(t2, "Idle"); return g
add("sfc01_linear", "Steps, transitions, a jump back, an N action on a BOOL output; step flags X.\n   after 1: motor = FALSE, Idle.X = TRUE, Run.X = FALSE\n   set 2: start = TRUE\n   after 2: motor = TRUE, Idle.X = FALSE, Run.X = TRUE\n   set 3: start = FALSE, stop = TRUE\n   after 3: motor = FALSE, Idle.X = TRUE, Run.X = FALSE", [("start",B),("stop",B)], [("motor",B)], [], "SFC", sfc_linear())

g = G(); s0 = g.step("S0", initial=True); d = g.seldiv(s0, 2); ta = g.trans([d], "a", priority=1); tb = g.trans([d], "b", priority=2); sa = g.step("SA", [ta]); sb = g.step("SB", [tb]); ta2 = g.trans([sa], "back"); tb2 = g.trans([sb], "back"); cv = g.selconv([ta2, tb2]); g.jump(cv, "S0")
add("sfc02_selection_priority", "A selection divergence: when both conditions hold the first by priority fires alone.\n   set 1: a = TRUE, b = TRUE\n   after 1: SA.X = TRUE, SB.X = FALSE, S0.X = FALSE\n   set 2: back = TRUE\n   after 2: S0.X = TRUE, SA.X = FALSE\n   set 3: back = FALSE, a = FALSE\n   after 3: SB.X = TRUE, SA.X = FALSE", [("a",B),("b",B),("back",B)], [], [], "SFC", g)

g = G(); s0 = g.step("S0", initial=True); t = g.trans([s0], "go"); d = g.simdiv(t, 2); sa = g.step("A", [(d,"0")]); sb = g.step("B", [(d,"1")]); ta = g.trans([sa], "fa"); sa2 = g.step("A2", [ta]); cv = g.simconv([sa2, sb]); tj = g.trans([cv], "join"); g.jump(tj, "S0")
add("sfc03_simultaneous", "A simultaneous divergence activates both branches; the join waits for both.\n   set 1: go = TRUE\n   after 1: A.X = TRUE, B.X = TRUE, S0.X = FALSE\n   set 2: go = FALSE, join = TRUE\n   after 2: A.X = TRUE, B.X = TRUE\n   set 3: fa = TRUE\n   after 3: A2.X = TRUE, A.X = FALSE, B.X = TRUE\n   after 4: S0.X = TRUE, A2.X = FALSE, B.X = FALSE", [("go",B),("fa",B),("join",B)], [], [], "SFC", g)

g = G(); s0 = g.step("Wait", initial=True, action=True); g.actions(s0, [("N", "waiting")]); t = g.trans([s0], "Wait.T >= T#50ms"); s1 = g.step("Done", [t], action=True); g.actions(s1, [("N","finished")]); t2 = g.trans([s1], "FALSE"); g.jump(t2, "Done")
add("sfc04_step_time", "Step time T: time since the step became active, updated at the start of each scan.\n   period: T#10ms\n   after 5: Wait.T = T#40ms, waiting = TRUE, finished = FALSE\n   after 6: Wait.T = T#50ms, Wait.X = FALSE, finished = TRUE, waiting = FALSE", [], [("waiting",B),("finished",B)], [], "SFC", g)

g = G(); s0 = g.step("S0", initial=True); t1 = g.trans([s0], "n1"); s1 = g.step("S1", [t1], action=True); g.actions(s1, [("S", "lamp")]); t2 = g.trans([s1], "n2"); s2 = g.step("S2", [t2]); t3 = g.trans([s2], "n3"); s3 = g.step("S3", [t3], action=True); g.actions(s3, [("R", "lamp")]); t4 = g.trans([s3], "TRUE"); g.jump(t4, "S0")
add("sfc05_set_reset", "S stores an action beyond its step; R in a later step resets it.\n   set 1: n1 = TRUE\n   after 1: lamp = TRUE\n   set 2: n1 = FALSE, n2 = TRUE\n   after 2: lamp = TRUE, S2.X = TRUE\n   set 3: n3 = TRUE\n   after 3: lamp = FALSE, S3.X = TRUE\n   after 4: lamp = FALSE, S0.X = TRUE", [("n1",B),("n2",B),("n3",B)], [("lamp",B)], [], "SFC", g)

g = G(); s0 = g.step("S0", initial=True, action=True); g.actions(s0, [("P", "ST:count := count + 1;"), ("N", "ST:scans := scans + 1;")]); t = g.trans([s0], "again"); g.jump(t, "S0")
add("sfc06_pulse", "P runs once when its step becomes active, N every scan it is active; a step left and re-entered in one scan pulses again.\n   after 1: count = 1, scans = 1\n   after 3: count = 1, scans = 3\n   set 4: again = TRUE\n   after 4: count = 2, scans = 4\n   after 5: count = 3", [("again",B)], [("count","INT"),("scans","INT")], [], "SFC", g)

g = G(); s0 = g.step("S0", initial=True, action=True); g.actions(s0, [("L", "early", "T#30ms"), ("D", "late", "T#30ms")]); t = g.trans([s0], "FALSE"); g.jump(t, "S0")
add("sfc07_time_limited_delayed", "L is active for its duration after the step starts, D from its duration on.\n   period: T#10ms\n   after 1: early = TRUE, late = FALSE\n   after 3: early = TRUE, late = FALSE\n   after 4: early = FALSE, late = TRUE\n   after 8: early = FALSE, late = TRUE", [], [("early",B),("late",B)], [], "SFC", g)

ACT = '''        <actions>
          <action name="Fill">
            <body>
              <ST><xhtml:p><![CDATA[level := level + 2;]]></xhtml:p></ST>
            </body>
          </action>
        </actions>
        <transitions>
          <transition name="Full">
            <body>
              <ST><xhtml:p><![CDATA[level >= 6]]></xhtml:p></ST>
            </body>
          </transition>
        </transitions>
'''
g = G(); s0 = g.step("Filling", initial=True, action=True); g.actions(s0, [("N", "Fill")]); t = g.trans([s0], ref="Full"); s1 = g.step("Stop", [t]); t2 = g.trans([s1], "FALSE"); g.jump(t2, "Stop")
add("sfc08_named_action_transition", "A named action in ST and a named transition (an expression) from the POU's actions and transitions.\n   after 1: level = 2, Filling.X = TRUE\n   after 3: level = 6, Filling.X = TRUE\n   after 4: level = 6, Stop.X = TRUE", [], [("level","INT")], [], "SFC", g, ACT)

g = G(); s0 = g.step("S0", initial=True); t = g.trans([s0], "go"); s1 = g.step("S1", [t], action=True); g.actions(s1, [("P1", "ST:entered := entered + 1;"), ("P0", "ST:left := left + 1;")]); t2 = g.trans([s1], "NOT go"); g.jump(t2, "S0")
add("sfc09_p1_p0", "P1 runs when the step is entered, P0 when it is left.\n   set 1: go = TRUE\n   after 1: entered = 1, left = 0\n   after 2: entered = 1, left = 0\n   set 3: go = FALSE\n   after 3: entered = 1, left = 1", [("go",B)], [("entered","INT"),("left","INT")], [], "SFC", g)

g = G(); s0 = g.step("S0", initial=True); t = g.trans([s0], "TRUE"); d = g.simdiv(t, 2); a = g.step("A", [(d,"0")]); b = g.step("B", [(d,"1")]); ta = g.trans([a], "TRUE"); a2 = g.step("A2", [ta]); tb = g.trans([b], "TRUE"); b2 = g.step("B2", [tb]); cv = g.simconv([a2, b2]); tj = g.trans([cv], "FALSE"); g.jump(tj, "S0")
add("sfc10_all_fire_together", "Every transition that can clear in a scan clears in that scan, judged on the steps active at its start: one step per scan along each branch.\n   after 1: A.X = TRUE, B.X = TRUE, S0.X = FALSE\n   after 2: A2.X = TRUE, B2.X = TRUE, A.X = FALSE, B.X = FALSE\n   after 3: A2.X = TRUE, B2.X = TRUE", [], [], [], "SFC", g)

g = G(); s0 = g.step("S0", initial=True, action=True); g.actions(s0, [("N", "ST:seen := S1.X;")]); t = g.trans([s0], "go"); s1 = g.step("S1", [t], action=True); g.actions(s1, [("N", "ST:seen := S1.X AND NOT S0.X;")]); t2 = g.trans([s1], "NOT go"); g.jump(t2, "S0")
add("sfc11_step_flags_in_actions", "Actions read step flags after the scan's evolution.\n   after 1: seen = FALSE\n   set 2: go = TRUE\n   after 2: seen = TRUE, S1.X = TRUE", [("go",B)], [("seen",B)], [], "SFC", g)

g = G(); s0 = g.step("S0", initial=True); l = g.left(); c = g.contact([l], "a"); c2 = g.contact([c], "b", negated=True); t = g.trans([s0], conn=[c2]); s1 = g.step("S1", [t]); t2 = g.trans([s1], "FALSE"); g.jump(t2, "S1")
add("sfc12_ld_condition", "A transition's condition drawn as contacts connected to it.\n   set 1: a = TRUE, b = TRUE\n   after 1: S0.X = TRUE\n   set 2: b = FALSE\n   after 2: S1.X = TRUE, S0.X = FALSE", [("a",B),("b",B)], [], [], "SFC", g)

g = G(); s0 = g.step("S0", initial=True); d = g.seldiv(s0, 2); tr = g.trans([d], "b", x=300); tl = g.trans([d], "a", x=60); sr = g.step("Right", [tr]); sl = g.step("Left", [tl]); t3 = g.trans([sr], "FALSE"); g.jump(t3, "Right"); t4 = g.trans([sl], "FALSE"); g.jump(t4, "Left")
add("sfc13_selection_left_to_right", "A selection divergence without priorities resolves left to right by position, whatever the document order.\n   set 1: a = TRUE, b = TRUE\n   after 1: Left.X = TRUE, Right.X = FALSE", [("a",B),("b",B)], [], [], "SFC", g)

for name, text in files.items():
    with open(os.path.join(OUT, name + ".xml"), "w") as f:
        f.write(text)
print(len(files))
