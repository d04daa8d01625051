// vdevd web view (issue 23 §3): plain JavaScript, no framework, no build step.
// The live state arrives on a websocket (/ws); every button sends one protocol request
// (POST /api/op, the ops of proto/PROTOCOL.md) or runs/pauses the clock (POST /api/clock).
"use strict";

const $ = (id) => document.getElementById(id);
const state = { layout: null, toggles: {}, irqRows: 0, scopeTimer: null };
const MAX_IRQ_ROWS = 200;
const AXIS_BUTTONS = [  // [id, label, action, params(axis, active)]
  ["limpos", "+lim", "set_limit", (a, on) => ({ axis: a, side: "positive", active: on })],
  ["limneg", "-lim", "set_limit", (a, on) => ({ axis: a, side: "negative", active: on })],
  ["home", "home", "set_home", (a, on) => ({ axis: a, active: on })],
  ["amp", "amp fault", "set_amp_fault", (a, on) => ({ axis: a, active: on })],
];
const PUSH_COUNTS = 100;  // the counts a push button moves its axis by hand (backdoor `push`)
const COLORS = ["#2457a6", "#c0392b", "#1e8449", "#8e44ad", "#d35400", "#16a085", "#7f8c8d", "#b7950b"];

function el(tag, attrs = {}, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k === "class") e.className = v; else if (k === "text") e.textContent = v; else e.setAttribute(k, v);
  }
  for (const c of children) e.append(c);
  return e;
}

function showError(message) {
  const box = $("error");
  box.textContent = message;
  box.hidden = false;
}

function clearError() { $("error").hidden = true; }

// One request: {ok: result}, or null after showing the error the daemon gave.
async function post(path, body) {
  let reply;
  try {
    const r = await fetch(path, { method: "POST", headers: { "Content-Type": "application/json" },
                                  body: JSON.stringify(body) });
    reply = await r.json();
  } catch (err) {
    showError(`${path}: ${err}`);
    return null;
  }
  if (reply.error) {
    showError(`${reply.error.code}: ${reply.error.message}`);
    return null;
  }
  clearError();
  return { ok: reply.ok };
}

const op = (body) => post("/api/op", body);
const axisParam = (name) => (/^\d+$/.test(name) ? Number(name) : name);
const fmt = (v) => (v === null || v === undefined ? "-" : String(Number(v.toFixed(3))));
const hex = (v) => "0x" + (v >>> 0).toString(16);

// -- the layout: one section a card ----------------------------------------------------------
function buildLayout(layout) {
  state.layout = layout;
  const root = $("cards");
  root.replaceChildren();
  const scopeCard = $("scope-card");
  const chosen = scopeCard.value;
  scopeCard.replaceChildren();
  for (const card of layout.hello.cards) {
    const axes = layout.axes[card.name] || [];
    root.append(buildCard(card, axes));
    if (axes.length) scopeCard.append(el("option", { value: card.name, text: card.name }));
  }
  if (chosen) scopeCard.value = chosen;
  const signals = $("scope-signals");
  signals.replaceChildren();
  for (const s of layout.signals) {
    const box = el("input", { type: "checkbox", value: s, id: `sig-${s}` });
    box.checked = ["position", "velocity", "error"].includes(s);
    signals.append(el("label", {}, box, " " + s));
  }
  $("clock-mode").textContent = layout.hello.clock.mode;
}

function buildCard(card, axes) {
  const sec = el("section", { class: "card", id: `card-${card.name}` });
  const head = el("div", { class: "card-head" }, el("h2", { text: card.name }),
                  el("span", { class: "type", text: card.type }),
                  el("span", { class: "label", id: `ticks-${card.name}`, text: "" }));
  if (card.controls.set_estop) head.append(toggleButton(card.name, "E-stop", `btn-estop-${card.name}`,
    (on) => ({ op: "control", card: card.name, action: "set_estop", params: { active: on } })));
  sec.append(head);
  if (axes.length) {
    const table = el("table");
    table.append(el("thead", {}, el("tr", {}, ...["axis", "position", "command", "velocity", "error",
      "output", "status", "inputs", "outputs", "backdoor", "flags"].map((h, i) =>
      el("th", { class: i === 0 || i > 8 ? "name" : "", text: h })))));
    const body = el("tbody");
    for (const axis of axes) {
      const id = `${card.name}-${axis}`;
      const row = el("tr", { id: `axis-${id}` }, el("td", { class: "name", text: axis }));
      for (const k of ["position", "command", "velocity", "error", "output", "status", "inputs", "outputs"]) {
        row.append(el("td", { class: "num", id: `${k}-${id}`, text: "-" }));
      }
      const buttons = el("td", { class: "buttons" });
      for (const [name, label, action, params] of AXIS_BUTTONS) {
        if (!card.controls[action]) continue;
        const key = `${name}-${id}`;
        buttons.append(toggleButton(key, label, `btn-${key}`,
          (on) => ({ op: "control", card: card.name, action, params: params(axisParam(axis), on) })));
      }
      if (card.controls.push) buttons.append(pushButton(card.name, axis, -PUSH_COUNTS),
                                             pushButton(card.name, axis, PUSH_COUNTS));
      row.append(buttons, el("td", { class: "flags", id: `flags-${id}` }));
      body.append(row);
    }
    table.append(body);
    sec.append(table);
  }
  sec.append(controlForm(card));
  return sec;
}

// A button that sets an input active, then inactive at the next press.
function toggleButton(key, label, id, request) {
  const b = el("button", { type: "button", id, text: label, title: "backdoor: press to set, again to clear" });
  b.addEventListener("click", async () => {
    const on = !state.toggles[key];
    if (await op(request(on))) {
      state.toggles[key] = on;
      b.classList.toggle("active", on);
    }
  });
  return b;
}

// A button that moves the axis by hand by `counts` (backdoor `push`), each press.
function pushButton(cardName, axis, counts) {
  const label = `push ${counts > 0 ? "+" : ""}${counts}`;
  const b = el("button", { type: "button", id: `btn-push${counts > 0 ? "pos" : "neg"}-${cardName}-${axis}`,
                           text: label, title: `backdoor push: the axis moved by hand by ${counts} counts` });
  b.addEventListener("click", () =>
    op({ op: "control", card: cardName, action: "push", params: { axis: axisParam(axis), counts } }));
  return b;
}

// Any backdoor action of the card, its params as JSON.
function controlForm(card) {
  const select = el("select", { id: `action-${card.name}` });
  for (const [name, sig] of Object.entries(card.controls)) {
    select.append(el("option", { value: name, text: name, title: `${sig.params} ${sig.doc}` }));
  }
  const params = el("input", { class: "params", id: `params-${card.name}`, placeholder: '{"axis": "A"}' });
  const result = el("span", { class: "result", id: `result-${card.name}` });
  const run = el("button", { type: "button", id: `btn-control-${card.name}`, text: "control" });
  run.addEventListener("click", async () => {
    let p = {};
    if (params.value.trim()) {
      try { p = JSON.parse(params.value); } catch (err) { showError(`params: not JSON: ${err.message}`); return; }
    }
    const r = await op({ op: "control", card: card.name, action: select.value, params: p });
    result.textContent = r ? JSON.stringify(r.ok) : "";
  });
  return el("div", { class: "controls" }, select, params, run, result);
}

// -- the live state -------------------------------------------------------------------------------
function showState(s) {
  $("clock-now").textContent = (s.clock.now_ns / 1e9).toFixed(6);
  $("clock-mode").textContent = s.clock.mode;
  const running = $("clock-running");
  running.textContent = s.running ? "running" : "paused";
  running.className = s.running ? "badge ok" : "badge";
  if (s.run_error) showError(`run stopped: ${s.run_error}`);
  if (!state.layout) return;
  for (const [name, c] of Object.entries(s.cards)) {
    const axes = state.layout.axes[name] || [];
    const ticks = $(`ticks-${name}`);
    if (ticks) ticks.textContent = `tick ${c.ticks}`;
    axes.forEach((axis, i) => {
      const id = `${name}-${axis}`;
      for (const k of ["position", "command", "velocity", "error", "output"]) {
        const cell = $(`${k}-${id}`);
        if (cell && c[k]) cell.textContent = fmt(c[k][i]);
      }
      for (const k of ["status", "inputs", "outputs"]) {
        const cell = $(`${k}-${id}`);
        if (cell && c[k]) cell.textContent = hex(c[k][i]);
      }
      const flags = $(`flags-${id}`);
      if (flags && c.flags) showFlags(flags, c.flags[i]);
    });
  }
  addIrqs(s.irqs, s.missed_irqs);
}

function showFlags(cell, bits) {
  const names = [];
  for (const [bit, name] of Object.entries(state.layout.flags)) {
    if (bits & (1 << Number(bit))) names.push(name);
  }
  const text = names.join(" ");
  if (cell.dataset.names === text) return;
  cell.dataset.names = text;
  cell.replaceChildren(...names.map((n) => el("span", {
    class: /LIMIT|FAULT|LOSS|TRIP|ABORTED/.test(n) ? "badge on" : "badge", text: n })));
}

function addIrqs(irqs, missed) {
  const body = $("irqs").tBodies[0];
  for (const e of irqs) {
    body.prepend(el("tr", {}, el("td", { text: e.card }), el("td", { text: e.line }),
      el("td", { text: String(e.seq) }), el("td", { text: (e.sim_time_ns / 1e9).toFixed(6) }),
      el("td", { text: hex(e.status) })));
    state.irqRows += 1;
  }
  while (state.irqRows > MAX_IRQ_ROWS) { body.lastChild.remove(); state.irqRows -= 1; }
  if (missed) {
    const badge = $("irq-missed");
    const total = Number(badge.dataset.total || 0) + missed;
    badge.dataset.total = total;
    badge.textContent = `${total} not shown`;
    badge.hidden = false;
  }
}

function connect() {
  const ws = new WebSocket(`${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/ws`);
  const link = $("link");
  ws.onopen = () => { link.textContent = "live"; link.className = "badge ok"; };
  ws.onmessage = (m) => {
    const msg = JSON.parse(m.data);
    if (msg.kind === "layout") buildLayout(msg); else if (msg.kind === "state") showState(msg);
  };
  ws.onclose = () => {
    link.textContent = "disconnected"; link.className = "badge off";
    setTimeout(connect, 1000);
  };
}

// -- the clock --------------------------------------------------------------------------------------
function clockButtons() {
  $("btn-step").addEventListener("click", () =>
    op({ op: "sim", action: "step", seconds: Number($("step-size").value) }));
  $("btn-run").addEventListener("click", () => post("/api/clock", { action: "run" }));
  $("btn-pause").addEventListener("click", () => post("/api/clock", { action: "pause" }));
}

// -- the scope ----------------------------------------------------------------------------------------
function scopeButtons() {
  $("scope-form").addEventListener("submit", async (ev) => {
    ev.preventDefault();
    const card = $("scope-card").value;
    const signals = [...document.querySelectorAll("#scope-signals input:checked")].map((b) => b.value);
    const req = { op: "scope", card, action: "arm", seconds: Number($("scope-seconds").value),
                  every: Number($("scope-every").value), signals };
    const axes = $("scope-axes").value.split(",").map((a) => a.trim()).filter((a) => a);
    if (axes.length) req.axes = axes.map(axisParam);
    const r = await op(req);
    if (r) { showScopeStatus(r.ok); watchScope(card); }
  });
  $("btn-scope-read").addEventListener("click", () => readScope($("scope-card").value));
  $("btn-scope-clear").addEventListener("click", async () => {
    const card = $("scope-card").value;
    await op({ op: "scope", card, action: "clear" });
    stopWatch();
    $("scope-status").textContent = "idle";
    drawScope(null);
  });
}

function showScopeStatus(st) {
  $("scope-status").textContent = st.state === "idle" ? "idle"
    : `${st.state}: ${st.available} of ${st.samples} samples (every ${st.every} ticks, ${st.columns.length} columns)`;
}

function stopWatch() { if (state.scopeTimer) { clearInterval(state.scopeTimer); state.scopeTimer = null; } }

// While armed, the status every half second; the trace once it is done.
function watchScope(card) {
  stopWatch();
  state.scopeTimer = setInterval(async () => {
    const r = await op({ op: "scope", card, action: "status" });
    if (!r) { stopWatch(); return; }
    const st = r.ok;
    showScopeStatus(st);
    if (st.state === "done" || st.state === "idle") { stopWatch(); if (st.state === "done") readScope(card); }
  }, 500);
}

async function readScope(card) {
  const trace = { time_s: [], columns: {} };
  let start = 0;
  while (start !== null && trace.time_s.length < 100000) {
    const reply = await op({ op: "scope", card, action: "read", start });
    if (!reply) return;
    const r = reply.ok;
    trace.time_s.push(...r.time_s);
    for (const [k, v] of Object.entries(r.columns)) (trace.columns[k] = trace.columns[k] || []).push(...v);
    start = r.count ? r.next : null;
  }
  drawScope(trace);
}

// One panel a signal, one line an axis, against simulated time.
function drawScope(trace) {
  const canvas = $("scope-canvas");
  const g = canvas.getContext("2d");
  g.clearRect(0, 0, canvas.width, canvas.height);
  canvas.dataset.samples = trace ? trace.time_s.length : 0;
  if (!trace || !trace.time_s.length) return;
  const bySignal = {};
  for (const name of Object.keys(trace.columns)) {
    const [axis, signal] = name.split(".");
    (bySignal[signal] = bySignal[signal] || []).push([axis, trace.columns[name]]);
  }
  const signals = Object.keys(bySignal);
  const t = trace.time_s, t0 = t[0], t1 = t[t.length - 1] > t0 ? t[t.length - 1] : t0 + 1e-9;
  const left = 64, right = 10, h = canvas.height / signals.length;
  g.font = "11px system-ui, sans-serif";
  signals.forEach((signal, p) => {
    const top = p * h + 14, bottom = (p + 1) * h - 18;
    let lo = Infinity, hi = -Infinity;
    for (const [, values] of bySignal[signal]) for (const v of values) {
      if (v !== null) { if (v < lo) lo = v; if (v > hi) hi = v; }
    }
    if (!isFinite(lo)) { lo = 0; hi = 1; }
    if (hi === lo) { hi += 1; lo -= 1; }
    const x = (s) => left + (s - t0) / (t1 - t0) * (canvas.width - left - right);
    const y = (v) => bottom - (v - lo) / (hi - lo) * (bottom - top);
    g.strokeStyle = "#d8dde5"; g.strokeRect(left, top, canvas.width - left - right, bottom - top);
    g.fillStyle = "#1c2430"; g.fillText(signal, left + 4, top - 3);
    g.fillStyle = "#5b6677";
    g.fillText(String(Number(hi.toPrecision(4))), 2, top + 9);
    g.fillText(String(Number(lo.toPrecision(4))), 2, bottom);
    if (p === signals.length - 1) {
      g.fillText(`${t0.toFixed(3)} s`, left, bottom + 13);
      g.fillText(`${t1.toFixed(3)} s`, canvas.width - right - 50, bottom + 13);
    }
    const stride = Math.max(1, Math.floor(t.length / (2 * canvas.width)));
    bySignal[signal].forEach(([axis, values], i) => {
      g.strokeStyle = COLORS[i % COLORS.length];
      g.beginPath();
      let pen = false;
      for (let k = 0; k < values.length; k += stride) {
        if (values[k] === null) { pen = false; continue; }
        if (pen) g.lineTo(x(t[k]), y(values[k])); else g.moveTo(x(t[k]), y(values[k]));
        pen = true;
      }
      g.stroke();
      g.fillStyle = COLORS[i % COLORS.length];
      g.fillText(axis, canvas.width - right - 12 * (bySignal[signal].length - i), top - 3);
    });
  });
}

document.addEventListener("DOMContentLoaded", () => {
  clockButtons();
  scopeButtons();
  connect();
});
