// The petriplc HMI page: follows the hmi module's event stream of snapshots (points, modules,
// net markings), keeps the tables and the nets' tokens up to date, and sends forces with the
// token the PLC printed at start-up (kept in sessionStorage for this tab only).
"use strict";

const TOKEN_KEY = "petriplc-hmi-token";
// Up to this many tokens are dots, more a number: as the server draws them (svg.rs).
const MAX_DOTS = 4;
const DOTS = [[], [[0, 0]], [[-5, 0], [5, 0]], [[0, -5], [-5, 4], [5, 4]], [[-5, -5], [5, -5], [-5, 5], [5, 5]]];
const SVG_NS = "http://www.w3.org/2000/svg";
// No snapshot for this long (the server sends one every 5 s at least): the connection is dead.
const STALE_MS = 12000;

const $ = (sel, root = document) => root.querySelector(sel);
const pointsBody = $("#points tbody");
const modulesBody = $("#modules tbody");
const netsBox = $("#nets");
const connection = $("#connection");
const message = $("#message");

let source = null;
let lastMessage = 0;
let pointNames = "";
let lostConnection = false;
// Per module: { svg, places: Map(label -> element), transitions: [...] }.
const nets = new Map();

function setConnection(state, text) {
  connection.dataset.state = state;
  connection.textContent = text;
}

function say(text, kind) {
  message.textContent = text;
  message.dataset.kind = kind;
}

function token() {
  return sessionStorage.getItem(TOKEN_KEY) || "";
}

function showTokenState() {
  const state = $("#token-state");
  const has = token() !== "";
  state.dataset.hasToken = has ? "yes" : "no";
  state.textContent = has ? "token set: forcing allowed" : "no token: forcing is refused";
}

// ---- the event stream ----

function connect() {
  if (source) source.close();
  setConnection("connecting", lostConnection ? "reconnecting…" : "connecting…");
  source = new EventSource("events");
  source.addEventListener("open", () => {
    setConnection("connected", "connected");
    // After a restart of the PLC the nets may be others.
    if (lostConnection) loadNets();
    lostConnection = false;
  });
  source.addEventListener("snapshot", (e) => {
    lastMessage = Date.now();
    if (connection.dataset.state !== "connected") setConnection("connected", "connected");
    let snap;
    try {
      snap = JSON.parse(e.data);
    } catch (err) {
      return;
    }
    render(snap);
  });
  source.addEventListener("error", () => {
    lostConnection = true;
    setConnection("disconnected", "disconnected: reconnecting…");
    // A stream the browser gave up on (the server answered with an error) is started again.
    if (source.readyState === EventSource.CLOSED) setTimeout(connect, 2000);
  });
}

setInterval(() => {
  if (lastMessage && Date.now() - lastMessage > STALE_MS) {
    lastMessage = 0;
    lostConnection = true;
    setConnection("disconnected", "no data: reconnecting…");
    connect();
  }
}, 2000);

function render(snap) {
  $("#clock").textContent = "PLC time " + snap.time_s.toFixed(1) + " s";
  renderPoints(snap.points);
  renderModules(snap.modules);
  for (const n of snap.nets) renderMarking(n.module, n.marking);
}

// ---- points ----

function cell(row, text, cls) {
  const td = document.createElement("td");
  td.textContent = text;
  if (cls) td.className = cls;
  row.appendChild(td);
  return td;
}

function button(text, label, testid, onclick) {
  const b = document.createElement("button");
  b.type = "button";
  b.textContent = text;
  b.setAttribute("aria-label", label);
  b.dataset.testid = testid;
  b.addEventListener("click", onclick);
  return b;
}

function buildPoints(points) {
  pointsBody.replaceChildren();
  for (const p of points) {
    const tr = document.createElement("tr");
    tr.dataset.point = p.name;
    tr.dataset.testid = "point-" + p.name;
    cell(tr, p.name).setAttribute("scope", "row");
    cell(tr, p.description);
    cell(tr, p.owner);
    cell(tr, p.kind);
    const value = cell(tr, "", "value");
    value.dataset.testid = "value-" + p.name;
    value.setAttribute("aria-label", "value of " + p.name);
    const forced = cell(tr, "", "forced");
    const badge = document.createElement("span");
    badge.className = "badge";
    badge.textContent = "forced";
    badge.hidden = true;
    badge.dataset.testid = "forced-" + p.name;
    forced.appendChild(badge);
    const controls = cell(tr, "", "force");
    if (p.kind === "bool") {
      controls.append(
        button("1", "force " + p.name + " to 1", "force1-" + p.name, () => force(p.name, 1)),
        button("0", "force " + p.name + " to 0", "force0-" + p.name, () => force(p.name, 0)),
      );
    } else {
      const input = document.createElement("input");
      input.type = "number";
      input.step = p.kind === "f32" ? "any" : "1";
      input.setAttribute("aria-label", "value to force " + p.name + " to");
      input.dataset.testid = "force-input-" + p.name;
      controls.append(
        input,
        button("Force", "force " + p.name, "force-" + p.name, () => {
          if (input.value.trim() === "") {
            say("Enter a value to force " + p.name + " to.", "error");
            input.focus();
          } else {
            force(p.name, input.value.trim());
          }
        }),
      );
    }
    controls.append(button("Release", "release " + p.name, "release-" + p.name, () => release(p.name)));
    pointsBody.appendChild(tr);
  }
}

function showValue(v) {
  if (v === null || v === undefined) return "—";
  return String(v);
}

function renderPoints(points) {
  const names = points.map((p) => p.name).join(" ");
  if (names !== pointNames) {
    buildPoints(points);
    pointNames = names;
  }
  const rows = pointsBody.children;
  points.forEach((p, i) => {
    const tr = rows[i];
    const value = tr.children[4];
    const text = showValue(p.value);
    if (value.textContent !== text) value.textContent = text;
    value.dataset.on = p.kind === "bool" && p.value === 1 ? "1" : "0";
    tr.classList.toggle("forced", p.forced);
    tr.dataset.forced = p.forced ? "yes" : "no";
    tr.children[5].firstChild.hidden = !p.forced;
  });
}

// ---- modules ----

function renderModules(modules) {
  const us = (v) => (v >= 1000 ? Math.round(v) : v.toFixed(0));
  if (modulesBody.children.length !== modules.length) {
    modulesBody.replaceChildren();
    for (const m of modules) {
      const tr = document.createElement("tr");
      tr.dataset.module = m.name;
      tr.dataset.testid = "module-" + m.name;
      for (let i = 0; i < 9; i++) cell(tr, "", i >= 3 && i < 8 ? "num" : "");
      modulesBody.appendChild(tr);
    }
  }
  modules.forEach((m, i) => {
    const tr = modulesBody.children[i];
    tr.dataset.module = m.name;
    const texts = [
      m.name,
      m.kind,
      m.state,
      String(m.scans),
      us(m.cycle_us[1]) + " / " + us(m.cycle_us[2]),
      us(m.late_us[1]) + " / " + us(m.late_us[2]),
      String(m.overruns),
      String(m.restarts),
      m.detail,
    ];
    texts.forEach((t, k) => {
      if (tr.children[k].textContent !== t) tr.children[k].textContent = t;
    });
    tr.children[2].className = "state-" + m.state;
  });
}

// ---- nets ----

async function loadNets() {
  let list;
  try {
    const r = await fetch("api/nets", { cache: "no-store" });
    if (!r.ok) return;
    list = await r.json();
  } catch (err) {
    return;
  }
  nets.clear();
  netsBox.replaceChildren();
  if (list.length === 0) {
    const p = document.createElement("p");
    p.className = "empty";
    p.textContent = "No petrinet module.";
    netsBox.appendChild(p);
  }
  for (const n of list) {
    const fig = document.createElement("figure");
    fig.dataset.module = n.module;
    fig.dataset.testid = "net-" + n.module;
    const cap = document.createElement("figcaption");
    cap.textContent = "module " + n.module + " — " + n.file;
    fig.appendChild(cap);
    const doc = new DOMParser().parseFromString(n.svg, "image/svg+xml");
    const svg = document.importNode(doc.documentElement, true);
    fig.appendChild(svg);
    netsBox.appendChild(fig);
    const places = new Map();
    for (const g of svg.querySelectorAll("g.place")) {
      places.set(g.dataset.place, g);
      g.classList.toggle("marked", Number(g.dataset.tokens) > 0);
    }
    const transitions = [];
    for (const g of svg.querySelectorAll("g.transition")) {
      const label = g.dataset.transition;
      const arcs = [...svg.querySelectorAll("path.arc")].filter((a) => a.dataset.transition === label);
      transitions.push({
        g,
        inputs: arcs.filter((a) => a.dataset.dir === "in").map((a) => a.dataset.place),
        outputs: arcs.filter((a) => a.dataset.dir === "out").map((a) => a.dataset.place),
      });
    }
    const layer = document.createElementNS(SVG_NS, "g");
    layer.setAttribute("class", "moving");
    svg.appendChild(layer);
    nets.set(n.module, { svg, places, transitions, layer });
  }
}

function tokensSvg(g, tokens) {
  const x = Number(g.dataset.cx);
  const y = Number(g.dataset.cy);
  const box = g.querySelector("g.tokens");
  box.replaceChildren();
  if (tokens > MAX_DOTS) {
    const t = document.createElementNS(SVG_NS, "text");
    t.setAttribute("class", "token-count");
    t.setAttribute("x", x);
    t.setAttribute("y", y + 4);
    t.setAttribute("text-anchor", "middle");
    t.setAttribute("font-weight", "bold");
    t.setAttribute("fill", "#1a5fb4");
    t.textContent = String(tokens);
    box.appendChild(t);
    return;
  }
  for (const [dx, dy] of DOTS[tokens]) {
    const c = document.createElementNS(SVG_NS, "circle");
    c.setAttribute("class", "token");
    c.setAttribute("cx", x + dx);
    c.setAttribute("cy", y + dy);
    c.setAttribute("r", "3.5");
    c.setAttribute("fill", "#1a5fb4");
    box.appendChild(c);
  }
}

function renderMarking(module, marking) {
  const net = nets.get(module);
  if (!net) return;
  const delta = new Map();
  for (const [label, tokens] of marking) {
    const g = net.places.get(label);
    if (!g) continue;
    const before = Number(g.dataset.tokens);
    if (before === tokens) continue;
    delta.set(label, tokens - before);
    g.dataset.tokens = String(tokens);
    tokensSvg(g, tokens);
    g.classList.toggle("marked", tokens > 0);
  }
  if (delta.size > 0) animate(net, delta);
}

// A transition whose input places all lost tokens and one of whose output places gained
// some has fired: a dot travels from each input through the bar to each output.
function animate(net, delta) {
  if (window.matchMedia("(prefers-reduced-motion: reduce)").matches) return;
  for (const t of net.transitions) {
    const lost = t.inputs.every((p) => (delta.get(p) || 0) < 0);
    const gained = t.outputs.some((p) => (delta.get(p) || 0) > 0);
    const fired =
      t.inputs.length + t.outputs.length > 0 &&
      (t.inputs.length === 0 || lost) &&
      (t.outputs.length === 0 || gained);
    if (!fired) continue;
    t.g.classList.add("fired");
    setTimeout(() => t.g.classList.remove("fired"), 400);
    const at = (g) => [Number(g.dataset.cx), Number(g.dataset.cy)];
    const mid = at(t.g);
    const froms = t.inputs.map((p) => at(net.places.get(p)));
    const tos = t.outputs.filter((p) => (delta.get(p) || 0) > 0).map((p) => at(net.places.get(p)));
    for (const from of froms.length ? froms : [mid]) {
      for (const to of tos.length ? tos : [mid]) move(net.layer, from, mid, to);
    }
  }
}

function move(layer, from, mid, to) {
  const dot = document.createElementNS(SVG_NS, "circle");
  dot.setAttribute("class", "token moving-token");
  dot.setAttribute("r", "3.5");
  dot.setAttribute("cx", "0");
  dot.setAttribute("cy", "0");
  dot.setAttribute("fill", "#1a5fb4");
  layer.appendChild(dot);
  const tr = ([x, y]) => ({ transform: `translate(${x}px, ${y}px)` });
  const anim = dot.animate([tr(from), tr(mid), tr(to)], { duration: 450, easing: "ease-in-out" });
  anim.onfinish = () => dot.remove();
  anim.oncancel = () => dot.remove();
}

// ---- forcing ----

async function send(path, body) {
  const headers = { "Content-Type": "application/json" };
  const t = token();
  if (t) headers.Authorization = "Bearer " + t;
  let r;
  try {
    r = await fetch(path, { method: "POST", headers, body: JSON.stringify(body) });
  } catch (err) {
    say("Not sent: the PLC cannot be reached.", "error");
    return;
  }
  let reply = {};
  try {
    reply = await r.json();
  } catch (err) {
    reply = {};
  }
  if (r.status === 401) {
    sessionStorage.removeItem(TOKEN_KEY);
    showTokenState();
    say("Refused: " + (reply.error || "forcing needs the token printed when the PLC started."), "error");
    $("#token").focus();
  } else if (!r.ok) {
    say("Refused: " + (reply.error || r.statusText), "error");
  } else if (reply.queued) {
    say(reply.message, "ok");
  } else if (reply.forced) {
    say(reply.point + " forced to " + reply.value + ".", "ok");
  } else {
    say(reply.point + " released.", "ok");
  }
}

function force(point, value) {
  return send("api/force", { point, value });
}

function release(point) {
  return send("api/unforce", { point });
}

$("#token-form").addEventListener("submit", (e) => {
  e.preventDefault();
  const input = $("#token");
  const t = input.value.trim();
  if (t) sessionStorage.setItem(TOKEN_KEY, t);
  input.value = "";
  showTokenState();
  say(t ? "Token set for this tab." : "Enter the token printed when the PLC started.", t ? "ok" : "error");
});

$("#token-forget").addEventListener("click", () => {
  sessionStorage.removeItem(TOKEN_KEY);
  showTokenState();
  say("Token forgotten.", "ok");
});

showTokenState();
loadNets().then(connect);
