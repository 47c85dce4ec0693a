// paramdds console: plain JavaScript, no build step, no third-party code.
//
// State lives on the server (one monitor); this page shows one page of the node
// list and one node's rows, kept live by one EventSource (/api/events?node=…).
// An edit is parsed here (its notation), then validated by the server against the node's
// descriptor as the node validates it (POST /api/validate: the node's rules and words, never
// a copy of them here); the node has the last word on a set (its reason is shown under the field).
"use strict";

const PAGE = 50;
const S = {
  info: { read_only: true, token_required: false },
  query: "", offset: 0, total: 0, nodes: [],
  missing: [],          // over Zenoh: the sites the console lacks [{site, status, reason}], each a row
  selected: null, summary: null,
  rows: new Map(),      // name -> row {name, value, type, descriptor}
  dirty: new Map(),     // name -> value typed from the editor
  baseRevision: null,   // the revision the edits were started against (compare-and-set)
  es: null, listTimer: null,
  checkTimers: new Map(),  // name -> the timer of its pending validation (debounced edits)
  checks: new Map(),       // name -> sequence number of its newest validation (older answers are dropped)
  refusedTogether: null,   // the names of an atomic apply the node refused: its verdict on their combination
  timeline: null,          // the parameter whose timeline is open (null: none)
  timelineTimer: null,
};
const $ = (sel, root = document) => root.querySelector(sel);

// JSON with exact 64-bit integers: a number beyond ±2^53 is read as a BigInt from its source
// text (a plain Number would round it) and written back as its digits.
function parseJSON(text) {
  if (!/\d{16}/.test(text)) return JSON.parse(text);  // no number of 16+ digits: no reviver to pay for
  return JSON.parse(text, (k, v, ctx) =>
    typeof v === "number" && !Number.isSafeInteger(v) && ctx && /^-?\d+$/.test(ctx.source) ? BigInt(ctx.source) : v);
}
function toJSON(obj) { return JSON.stringify(obj, (k, v) => typeof v === "bigint" ? JSON.rawJSON(v.toString()) : v); }
// Control, invisible and bidirectional-formatting characters written as escapes, as the node
// writes them (Python's repr): a U+202E cannot turn 'gnp.exe' into 'exe.png', a newline shows.
const HIDDEN = /[\u0000-\u001f\u007f-\u009f\u00ad\u061c\u180e\u200b-\u200f\u2028-\u202e\u2060-\u2064\u2066-\u206f\ufeff\ufff9-\ufffb]/g;
function visible(s) {
  return s.replace(HIDDEN, (c) => ({ "\n": "\\n", "\t": "\\t", "\r": "\\r" })[c]
    || (c.charCodeAt(0) < 0x100 ? "\\x" + c.charCodeAt(0).toString(16).padStart(2, "0") : "\\u" + c.charCodeAt(0).toString(16).padStart(4, "0")));
}
const el = (tag, props = {}, ...kids) => {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(props)) {
    if (k === "class") e.className = v;
    else if (k === "text") e.textContent = v;
    else if (k.startsWith("data-")) e.setAttribute(k, v);
    else e[k] = v;
  }
  for (const k of kids) if (k != null) e.append(k);
  return e;
};

// -- formatting (the node's wording: Python-like reprs) -----------------------------------

function showScalar(v, type) {
  if (typeof v === "boolean") return v ? "true" : "false";
  if (typeof v === "string" && (type === "double" || type === "double_array") && ["nan", "inf", "-inf"].includes(v)) return v;
  if (typeof v === "string") return "'" + visible(v.replace(/\\/g, "\\\\").replace(/'/g, "\\'")) + "'";
  if (typeof v === "number" && (type === "double" || type === "double_array")) return Number.isInteger(v) ? v.toFixed(1) : String(v);
  return String(v);
}
function showValue(v, type) {
  if (v === null || v === undefined) return "not_set";
  if (type === "byte_array") return v.map((b) => b.toString(16).padStart(2, "0")).join(" ") || "(empty)";
  if (Array.isArray(v)) return "[" + v.map((x) => showScalar(x, type)).join(", ") + "]";
  return showScalar(v, type);
}
// A value as the table shows it and its editor takes it (one notation): a string array in
// JSON ("a" quoted, unprintable characters escaped), everything else as showValue.
function jsonString(x) { return JSON.stringify(x).replace(HIDDEN, (c) => "\\u" + c.charCodeAt(0).toString(16).padStart(4, "0")); }
function cellText(v, type) {
  if (type === "string_array" && Array.isArray(v)) return "[" + v.map(jsonString).join(", ") + "]";
  return showValue(v, type);
}
// A range end that does not bound anything: a double's ±1.79e308 (DBL_MAX) or infinity, an
// integer's int64 limit. The range is then shown open (≥ lo, ≤ hi) and gets no slider.
const DBL_MAX = 1.7976931348623157e308;
function num(x) { return x === "nan" ? NaN : x === "inf" ? Infinity : x === "-inf" ? -Infinity : x; }
function openEnd(x, isFloat) {
  if (isFloat) { const v = Number(num(x)); return !Number.isFinite(v) || Math.abs(v) >= DBL_MAX; }
  const v = typeof x === "bigint" ? x : BigInt(x);
  return v >= 9223372036854775807n || v <= -9223372036854775808n;
}
function rangeText(r, t) {
  const isFloat = t === "double", lo = openEnd(r.from_value, isFloat), hi = openEnd(r.to_value, isFloat);
  const step = r.step ? ` step ${r.step}` : "";
  if (lo && hi) return step ? step.trim() : "";
  if (hi) return `≥ ${showRangeEnd(r.from_value, t)}${step}`;
  if (lo) return `≤ ${showRangeEnd(r.to_value, t)}${step}`;
  return `[${showRangeEnd(r.from_value, t)}, ${showRangeEnd(r.to_value, t)}]${step}`;
}
function showRangeEnd(x, type) { return type.startsWith("double") ? showScalar(x, "double") : String(x); }
function constraintsText(d) {
  const parts = [];
  const r = d.integer_range || d.floating_point_range;
  const t = d.floating_point_range ? "double" : "integer";
  if (r) { const text = rangeText(r, t); if (text) parts.push(text); }
  for (const v of d.validators) parts.push(v.args.length ? `${v.kind}(${v.args.map((a) => toJSON(a)).join(", ")})` : v.kind);
  if (d.additional_constraints) parts.push(d.additional_constraints);
  return parts.join("; ");
}

// -- parsing an editor's text ---------------------------------------------------------------

function elementType(type) { return { bool_array: "bool", integer_array: "integer", double_array: "double", string_array: "string", byte_array: "integer" }[type]; }

function parseScalar(text, type) {
  const t = text.trim();
  if (type === "integer") {
    if (!/^[-+]?\d+$/.test(t)) throw new Error(`expected an integer, got '${text}'`);
    const big = BigInt(t.replace(/^\+/, ""));
    if (big < -(2n ** 63n) || big >= 2n ** 63n) throw new Error(`${t} does not fit in a 64-bit integer`);
    return Number.isSafeInteger(Number(big)) ? Number(big) : big;  // exact either way
  }
  if (type === "double") {
    if (["nan", "inf", "-inf"].includes(t.toLowerCase())) return t.toLowerCase();
    if (!/^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$/.test(t)) throw new Error(`expected a number, got '${text}'`);
    return Number(t);
  }
  return text;
}

function parseEditor(row, raw) {
  const type = row.descriptor.type !== "not_set" ? row.descriptor.type : row.type;
  if (type === "bool") return raw;
  if (type === "integer" || type === "double") return parseScalar(raw, type);
  if (type === "string") return raw;
  if (type === "byte_array") {
    const hex = raw.replace(/\s+/g, "").replace(/^0x/, "");
    if (!/^([0-9a-fA-F]{2})*$/.test(hex)) throw new Error("expected bytes as hex: an even number of 0-9, a-f digits");
    return hex;
  }
  let list;
  try { list = parseJSON(raw); } catch (e) { throw new Error("expected a list such as [1, 2, 3]"); }
  if (!Array.isArray(list)) throw new Error("expected a list such as [1, 2, 3]");
  const et = elementType(type);
  return list.map((x, i) => {
    const ok = et === "bool" ? typeof x === "boolean" : et === "string" ? typeof x === "string"
      : et === "integer" ? Number.isInteger(x) || typeof x === "bigint" : typeof x === "number" || ["nan", "inf", "-inf"].includes(x);
    if (!ok) throw new Error(`element ${i} (${toJSON(x)}) is not a ${et}`);
    return x;
  });
}

// -- API --------------------------------------------------------------------------------

// The operator's name, sent with every write as "as" and kept by this browser (localStorage);
// a token that names its operator wins over it at the console.
const OPERATOR_KEY = "paramdds-operator";
function operatorName() { return $("#operator").value.trim(); }
const WRITES = ["/api/set", "/api/delete", "/api/load"];

async function api(path, body) {
  const opts = { headers: {} };
  if (body !== undefined && WRITES.includes(path) && operatorName()) body = { ...body, as: operatorName() };
  const token = sessionStorage.getItem("paramdds-token") || $("#token").value;
  if (token) opts.headers["Authorization"] = "Bearer " + token;  // reads need it too off loopback
  if (body !== undefined) {
    opts.method = "POST";
    opts.headers["Content-Type"] = "application/json";
    opts.body = toJSON(body);
  }
  const res = await fetch(path, opts);
  let data = null;
  try { data = parseJSON(await res.text()); } catch (e) { data = { error: { code: "HTTP_" + res.status, message: res.statusText } }; }
  if (res.status === 401) $("#token-box").hidden = false;
  return { status: res.status, ok: res.ok, data };
}

// -- node list ------------------------------------------------------------------------------

async function loadNodes() {
  const q = encodeURIComponent(S.query);
  const { ok, data } = await api(`/api/nodes?q=${q}&offset=${S.offset}&limit=${PAGE}`);
  if (!ok) return;
  if (data.total && S.offset >= data.total) { S.offset = Math.max(0, Math.floor((data.total - 1) / PAGE) * PAGE); return loadNodes(); }
  S.total = data.total;
  S.nodes = data.nodes;
  S.missing = data.missing || [];
  renderNodes();
  if (window.paramddsFirstRender === undefined) window.paramddsFirstRender = performance.now();
}
function scheduleNodes(delay = 250) { clearTimeout(S.listTimer); S.listTimer = setTimeout(loadNodes, delay); }

function nodeItem(n) {
  const li = el("li", { "data-node": n.node, class: (n.online ? "" : "offline ") + (n.node === S.selected ? "selected" : ""), title: `${n.host} pid ${n.pid}` },
    el("span", { class: "n" }, el("span", { class: "dot" }), shownNode(n.node, n.origin),
      n.origin ? el("span", { class: "origin", title: `mirrored from ${n.origin} by the bridge`, text: n.origin }) : null,
      n.status ? el("span", { class: "status", title: STATUS_TITLES[n.status] || n.status, text: n.status }) : null),
    el("span", { class: "m", text: `${n.parameters} params · r${n.revision}` + (n.online ? "" : " · offline") }));
  li.addEventListener("click", () => select(n.node));
  return li;
}
// A site the console lacks (over Zenoh: its gateways unreachable, or not granted to this
// console): a row of its own, SITE/*, shown as an offline node is, with why.
function siteItem(m) {
  return el("li", { "data-site": m.site, class: "offline lacking", title: m.reason },
    el("span", { class: "n" }, el("span", { class: "dot" }), `${m.site}/*`,
      el("span", { class: "status", title: m.reason, text: m.status })),
    el("span", { class: "m", text: "site · offline" }));
}
function renderNodes() {
  $("#nodes").replaceChildren(...S.missing.map(siteItem), ...S.nodes.map(nodeItem));
  const last = Math.min(S.total, S.offset + PAGE);
  const lacking = S.missing.length ? ` · ${S.missing.length} site${S.missing.length === 1 ? "" : "s"} lacking` : "";
  $("#node-count").textContent = `${S.total} node${S.total === 1 ? "" : "s"}` + (S.query ? ` matching '${S.query}'` : "") + lacking;
  $("#page").textContent = S.total ? `${S.offset + 1}–${last} of ${S.total}` : "";
  $("#prev").disabled = S.offset === 0;
  $("#next").disabled = last >= S.total;
}
function updateNodes(summaries) {
  let unknown = false;
  for (const s of summaries) {
    const i = S.nodes.findIndex((n) => n.node === s.node);
    if (i < 0) { unknown = true; continue; }
    S.nodes[i] = s;
    $(`#nodes li[data-node="${CSS.escape(s.node)}"]`)?.replaceWith(nodeItem(s));
    if (s.node === S.selected) setSummary(s);
  }
  if (unknown) scheduleNodes();
}

// -- one node ---------------------------------------------------------------------------------

// A ROS 2 node (mirrored by the bridge) is shown with its leading slash, as ROS 2 writes it;
// the id the API takes and sends is the canonical one, without (both are accepted).
const STATUS_TITLES = {
  unreachable: "in the ROS 2 graph, but its parameter services do not answer (the bridge keeps trying)",
  stale: "the values shown are the last known: a set waits on its stalled process, or its site's gateway is away",
};
function shownNode(node, origin) { return origin === "ros2" ? "/" + node : node; }

function select(node) {
  node = node.replace(/^\/+/, "");
  if (S.selected !== node) { S.dirty.clear(); S.baseRevision = null; S.refusedTogether = null; banner(null); closeTimeline(); }
  checkNode(node);
  S.selected = node;
  if (location.hash !== "#node=" + encodeURIComponent(node)) history.replaceState(null, "", "#node=" + encodeURIComponent(node));
  document.querySelectorAll("#nodes li").forEach((li) => li.classList.toggle("selected", li.dataset.node === node));
  $("#empty").hidden = true;
  $("#node-view").hidden = false;
  $("#node-name").textContent = node;
  $("#dump").href = "/api/dump?node=" + encodeURIComponent(node);
  $("#dump").setAttribute("download", node.replace(/\//g, "_") + ".yaml");
  openStream();
}

// A node id from the link that the console cannot take (not a node name) leaves the node view
// with the reason; an unknown but valid one stays selected and shows when the node appears.
async function checkNode(node) {
  const { status, data } = await api("/api/node?node=" + encodeURIComponent(node));
  if (node !== S.selected || (status !== 400 && status !== 422)) return;  // 422: INVALID_NAME
  unselect(`Not a node: ${data.error ? data.error.message : node}`);
}
function unselect(why) {
  S.selected = null; S.summary = null;
  $("#node-view").hidden = true;
  $("#empty").hidden = false;
  $("#empty").textContent = why;
  history.replaceState(null, "", location.pathname);
  openStream();
}

function setSummary(s) {
  S.summary = s;
  if (s) $("#node-name").textContent = shownNode(s.node, s.origin);
  if (!s) { $("#node-meta").textContent = "unknown to this console: it shows here when it appears"; return; }
  $("#node-view").classList.toggle("offline", !s.online);
  $("#node-meta").textContent = `${s.online ? "online" : "offline"} · host ${s.host} · pid ${s.pid} · revision ${s.revision} · ${s.parameters} parameters`
    + (s.origin ? ` · mirrored from ${s.origin}` : "") + (s.status ? ` · ${s.status}` : "");
  $("#node-meta").dataset.revision = s.revision;
  $("#node-meta").dataset.incarnation = s.incarnation;
}
// The newer of the summary shown and a write's reply: a reply of another incarnation (a restart)
// wins, within one incarnation the higher revision does.
function advance(s, reply) {
  if (!s || reply.revision == null) return s;
  if (reply.incarnation !== s.incarnation) return { ...s, incarnation: reply.incarnation, revision: reply.revision };
  return { ...s, revision: Math.max(s.revision, reply.revision) };
}

function renderRows(rows) {
  S.rows = new Map(rows.map((r) => [r.name, r]));
  const body = $("#params tbody");
  body.replaceChildren(...rows.map(rowElement));
  filterRows();
  updateApply();
}

function filterRows() {
  const q = S.query.trim().toLowerCase();
  const nodeMatches = S.selected && S.selected.toLowerCase().includes(q);
  document.querySelectorAll("#params tbody tr").forEach((tr) => {
    tr.hidden = !!q && !nodeMatches && !tr.dataset.name.toLowerCase().includes(q);
  });
}

function editable(row) { return !S.info.read_only && !row.descriptor.read_only; }

function rowElement(row) {
  const d = row.descriptor;
  // the name opens the parameter's timeline (a focusable span: the row's only button is its editor's Set)
  const name = el("span", { class: "pname", role: "button", tabIndex: 0, title: "show its history", text: row.name });
  name.addEventListener("click", () => openTimeline(row.name));
  name.addEventListener("keydown", (e) => { if (e.key === "Enter" || e.key === " ") { e.preventDefault(); openTimeline(row.name); } });
  const tr = el("tr", { "data-name": row.name },
    el("td", { class: "name" }, name, d.read_only ? el("span", { class: "lock", title: "read-only: no editor", text: "read-only" }) : null),
    el("td", { class: "value" }, el("span", { class: "current", text: cellText(row.value, row.type) }),
      editable(row) ? editorFor(row) : null, el("div", { class: "error" })),
    el("td", { class: "type", text: row.type }),
    el("td", { class: "desc", text: d.description }),
    el("td", { class: "constraints", text: constraintsText(d) }),
    lastChangeCell(row.last_change));
  return tr;
}

// -- who changed what, and when -------------------------------------------------------------------

// An author as the node recorded it: the name, and "claimed" unless the node verified it
// (in plain mode every name is the writer's own word; DDS Security verifies the writer's certificate).
function author(who, verified) {
  return [el("span", { class: "who", text: visible(who) }),
    verified ? el("span", { class: "verified", title: "verified by the node (the writer's certificate)", text: "verified" })
      : el("span", { class: "claimed", title: "the writer's own word: not verified by the node", text: "claimed" })];
}
function shortTime(iso) {
  const t = new Date(iso);
  return t.toDateString() === new Date().toDateString() ? t.toLocaleTimeString() : t.toLocaleString();
}
function lastChangeCell(lc) {
  if (!lc) return el("td", { class: "last muted", title: "the node did not say who last changed it" });
  return el("td", { class: "last", title: `revision ${lc.revision} at ${lc.time} (UTC)` },
    ...author(lc.who, lc.verified), el("div", { class: "muted", text: `${lc.via} · r${lc.revision} · ${shortTime(lc.time)}` }));
}

// A parameter's timeline, newest first: the changes its node applied and the writes it refused.
async function openTimeline(name) {
  S.timeline = name;
  $("#timeline").hidden = false;
  $("#timeline-title").textContent = `History of ${name}`;
  await loadTimeline();
}
function closeTimeline() { S.timeline = null; $("#timeline").hidden = true; }
function timelineSoon() {
  if (S.timeline === null) return;
  clearTimeout(S.timelineTimer);
  S.timelineTimer = setTimeout(loadTimeline, 100);
}
async function loadTimeline() {
  const node = S.selected, name = S.timeline;
  if (!node || name === null) return;
  const { ok, data } = await api(`/api/history?node=${encodeURIComponent(node)}&name=${encodeURIComponent(name)}`);
  if (node !== S.selected || name !== S.timeline) return;
  const list = $("#timeline-list"), note = $("#timeline-note");
  if (!ok) { list.replaceChildren(); note.textContent = `No history: ${data.error ? data.error.message : "no answer"}`; return; }
  if (!data.kept) { list.replaceChildren(); note.textContent = `Node ${node} keeps no history (a node of an older release, or a foreign peer).`; return; }
  const notes = [];
  if (!data.records.length) notes.push("No change recorded.");
  if (data.more) notes.push(`The newest ${data.records.length} are shown.`);
  if (data.compacted) notes.push("Older history was dropped by retention: what follows is not the whole past.");
  note.textContent = notes.join(" ");
  list.replaceChildren(...data.records.map(timelineItem));
}
function timelineItem(r) {
  const old = r.old === null ? null : cellText(r.old, r.old_type), now = r.new === null ? null : cellText(r.new, r.new_type);
  const change = r.outcome === "refused" ? `refused ${now === null ? "delete" : now}: ${r.reason}`
    : old === null ? `added ${now}` : now === null ? `deleted (was ${old})` : `${old} → ${now}`;
  return el("li", { class: r.outcome, "data-seq": String(r.seq), title: `${r.time} (UTC)` },
    el("span", { class: "muted", text: `${shortTime(r.time)}  r${r.revision}  ` }), ...author(r.who, r.verified),
    el("span", { class: "muted", text: ` via ${r.via}` }), el("div", { class: "change", text: change }));
}

function editorText(row) {
  if (row.type === "byte_array") return row.value.map((b) => b.toString(16).padStart(2, "0")).join(" ");
  if (row.type === "double_array" && row.value.every((x) => typeof x === "number")) return showValue(row.value, row.type);
  if (row.type === "string_array") return cellText(row.value, row.type);
  if (Array.isArray(row.value)) return toJSON(row.value);
  if (row.type === "double" && typeof row.value === "number") return Number.isInteger(row.value) ? row.value.toFixed(1) : String(row.value);
  return row.value === null ? "" : String(row.value);
}

function editorFor(row) {
  const d = row.descriptor, type = d.type !== "not_set" ? d.type : row.type;
  const box = el("div", { class: "editor" });
  const choices = row.choices;  // the server's: a one_of validator's, or a JSON Schema enum's
  let input, read;
  if (type === "bool") {
    input = el("input", { type: "checkbox", checked: !!row.value, "data-role": "input" });
    read = () => input.checked;
  } else if (choices) {
    // the value held is offered too when it is none of them (a constraint the node does not
    // enforce, written as text): the editor shows what the node holds, never another value
    const offered = row.value == null || choices.some((c) => c === row.value) ? choices : [row.value, ...choices];
    input = el("select", { "data-role": "input" }, ...offered.map((c) => el("option", { value: String(c), text: String(c), selected: c === row.value })));
    read = () => { const c = offered.find((x) => String(x) === input.value); return type === "string" ? c : String(c); };
  } else if (type === "string" && typeof row.value === "string" && /[\n\r]/.test(row.value)) {
    // a multi-line string: a one-line field would drop its line breaks (Enter adds a line here,
    // Ctrl+Enter or Set applies)
    input = el("textarea", { value: row.value, rows: Math.min(8, row.value.split("\n").length + 1), "data-role": "input", spellcheck: false });
    read = () => input.value;
  } else {
    const r = d.integer_range || d.floating_point_range;
    input = el("input", { type: "text", value: editorText(row), "data-role": "input", spellcheck: false });
    const bounded = r && !openEnd(r.from_value, !!d.floating_point_range) && !openEnd(r.to_value, !!d.floating_point_range);
    if (bounded && (type === "integer" || type === "double")) {
      input.inputMode = "decimal";
      const slider = el("input", { type: "range", min: r.from_value, max: r.to_value, step: r.step || (type === "integer" ? 1 : "any"), value: row.value, "data-role": "slider" });
      slider.addEventListener("input", () => { input.value = type === "double" && Number.isInteger(Number(slider.value)) ? Number(slider.value).toFixed(1) : slider.value; markDirty(row.name); });
      box.append(input, slider);
    }
    read = () => input.value;
  }
  if (!box.contains(input)) box.prepend(input);
  const set = el("button", { type: "button", class: "set", text: "Set" });
  set.addEventListener("click", () => applyOne(row.name));
  box.append(set);
  input.addEventListener(type === "bool" || input.tagName === "SELECT" ? "change" : "input", () => markDirty(row.name));
  input.addEventListener("keydown", (e) => {
    if (e.key === "Enter" && (input.tagName !== "TEXTAREA" || e.ctrlKey || e.metaKey)) { e.preventDefault(); applyOne(row.name); }
  });
  box.readValue = read;
  return box;
}

function rowOf(name) { return $(`#params tbody tr[data-name="${CSS.escape(name)}"]`); }
function setError(name, text) {
  const tr = rowOf(name);
  if (tr) $(".error", tr).textContent = text || "";
  updateApply();  // an edit showing an error holds Apply back
}
// The pending edits whose field shows an error (the notation's, the console's or the node's).
function editsInError() { return [...S.dirty.keys()].filter((n) => rowOf(n)?.querySelector(".error")?.textContent); }

// The editor's value, parsed; shows the notation's error and returns undefined when it is not one.
function editorValue(name) {
  const row = S.rows.get(name), tr = rowOf(name);
  if (!row || !tr) return undefined;
  try { return parseEditor(row, $(".editor", tr).readValue()); } catch (e) { setError(name, e.message); return undefined; }
}

// -- validation by the server: the node's descriptor, the node's rules and words ----------------

const CHECK_DELAY = 150;  // ms after the last keystroke before an edit is validated

// The server's reasons for refusing `values` ({name: value}) on `node`: {name: reason}, "" when
// valid. When it cannot answer (offline, a token missing) nothing is refused here: a set asks again.
async function reasons(node, values) {
  const { ok, data } = await api("/api/validate", { node, values });
  const out = {};
  for (const r of (ok && data.results) || []) out[r.name] = r.valid ? "" : r.reason;
  return out;
}

// Validate the edits of `names` now; shows each one's reason (unless a newer edit of it was
// validated meanwhile) and returns {name: value} when all are valid, else undefined.
async function checkEdits(names) {
  const node = S.selected, values = {}, seqs = {};
  let parsed = true;
  for (const n of names) {
    clearTimeout(S.checkTimers.get(n));
    const v = editorValue(n);
    if (v === undefined) { parsed = false; continue; }
    values[n] = v;
    seqs[n] = (S.checks.get(n) || 0) + 1;
    S.checks.set(n, seqs[n]);
  }
  if (!Object.keys(values).length) return undefined;
  const found = await reasons(node, values);
  let valid = parsed;
  for (const n of Object.keys(values)) {
    const reason = found[n] || "";
    if (reason) valid = false;
    if (node === S.selected && S.checks.get(n) === seqs[n]) setError(n, reason);
  }
  return valid && node === S.selected ? values : undefined;
}

function checkSoon(name) {
  clearTimeout(S.checkTimers.get(name));
  S.checkTimers.set(name, setTimeout(() => { S.checkTimers.delete(name); checkEdits([name]); }, CHECK_DELAY));
}

function markDirty(name) {
  // a changed combination is no longer the one refused: the others' "not applied" goes (the
  // console checks this edit again; the node has the last word on the next apply)
  if (S.refusedTogether) { for (const n of S.refusedTogether) if (n !== name) setError(n, ""); S.refusedTogether = null; }
  if (S.dirty.size === 0) S.baseRevision = S.summary ? { incarnation: S.summary.incarnation, revision: S.summary.revision } : null;
  S.dirty.set(name, true);
  rowOf(name)?.classList.add("dirty");
  if (editorValue(name) !== undefined) checkSoon(name);  // a notation error shows at once
  updateApply();
}
function clearDirty(names) {
  for (const n of names) {
    S.dirty.delete(n); rowOf(n)?.classList.remove("dirty");
    clearTimeout(S.checkTimers.get(n)); S.checkTimers.delete(n);
    S.checks.set(n, (S.checks.get(n) || 0) + 1);  // an answer still on its way is not shown
  }
  if (S.dirty.size === 0) { S.baseRevision = null; S.refusedTogether = null; }
  updateApply();
}
function updateApply() {
  const n = S.dirty.size, bad = editsInError();
  $("#apply").disabled = n === 0 || S.info.read_only || bad.length > 0;
  $("#discard").disabled = n === 0;
  $("#apply").textContent = n ? `Apply ${n} change${n === 1 ? "" : "s"} atomically` : "Apply atomically";
  $("#apply").title = bad.length
    ? `not while ${bad.join(", ")} ${bad.length === 1 ? "shows an error" : "show errors"}: correct ${bad.length === 1 ? "it" : "them"} or discard`
    : S.summary && S.summary.origin
    ? `all or none, by the node itself; not compared with the values you started from (a node mirrored from ${S.summary.origin} has no revisions)`
    : "all or none, and only if the node has not changed since you started editing";
}

function banner(text, kind = "", items = null) {
  const b = $("#banner");
  if (!text) { b.hidden = true; return; }
  b.hidden = false;
  b.className = kind;
  b.replaceChildren(el("div", { text }), ...(items ? [el("ul", {}, ...items.map((t) => el("li", { text: t })))] : []));
}

function acked(names) {
  for (const n of names) {
    const tr = rowOf(n);
    if (!tr) continue;
    tr.classList.remove("acked"); void tr.offsetWidth; tr.classList.add("acked");
  }
}

function showResults(data, names) {
  if (data.results) {
    for (const r of data.results) setError(r.name, r.successful ? "" : r.reason);
  } else if (data.error) {
    if (names.length === 1) setError(names[0], data.error.message); else banner(data.error.message, "error");
  }
}

async function applyOne(name) {
  const node = S.selected, checked = await checkEdits([name]);
  if (checked === undefined || node !== S.selected) return;  // refused while its error is shown
  const value = checked[name];
  const { ok, data } = await api("/api/set", { node, values: { [name]: value } });
  if (node !== S.selected) return;
  showResults(data, [name]);
  if (name === S.timeline) timelineSoon();  // a refusal is in the timeline too, and sends no event
  if (!ok) return;
  // the page's own write moves the base of the other edits: this change is not "the node
  // changed meanwhile" (it went from the base to base + 1, and nobody else wrote in between)
  const base = S.baseRevision;
  if (base && data.incarnation === base.incarnation && data.revision === base.revision + 1) base.revision = data.revision;
  clearDirty([name]); acked([name]);
  if (S.summary) setSummary(advance(S.summary, data));
}

async function applyAll() {
  const names = [...S.dirty.keys()], node = S.selected, values = await checkEdits(names);
  if (node !== S.selected) return;
  if (values === undefined) {
    const bad = names.find((n) => rowOf(n)?.querySelector(".error")?.textContent) || names[0];
    banner(`Not sent: ${bad} is not valid.`, "error");
    return;
  }
  // a node mirrored from ROS 2 has no revision of its own to compare (the bridge refuses
  // compare-and-set there): its atomic set is sent without one, and the banner says so
  const mirrored = !!(S.summary && S.summary.origin), expected = mirrored ? null : S.baseRevision;
  const if_revision = expected ? `${expected.incarnation}:${expected.revision}` : null;
  const { ok, status, data } = await api("/api/set", { node, values, atomic: true, if_revision });
  if (node !== S.selected) return;
  if (names.includes(S.timeline)) timelineSoon();
  if (ok) {
    const unchecked = mirrored ? ` Not compared with the values you started from: node ${node} is mirrored from ${S.summary.origin}, which has no revisions.` : "";
    banner(`Applied ${names.length} changes atomically (revision ${data.revision}).${unchecked}`, "ok"); clearDirty(names); acked(names);
    if (S.summary) setSummary(advance(S.summary, data));
    return;
  }
  if (status === 409 && data.error && data.error.code === "CONFLICT") {
    clearDirty(names);
    if (data.rows) renderRows(data.rows);
    if (data.summary) setSummary(data.summary);
    const now = data.summary || data, restarted = expected && now.incarnation !== expected.incarnation;
    banner(`Not applied: node ${node} ${restarted ? "restarted" : "changed"} meanwhile (revision ${expected ? expected.revision : "?"} → ${now.revision}${restarted ? " of its new start" : ""}). The newer values are shown; edit again.`, "error");
    return;
  }
  showResults(data, names);
  if (data.results) S.refusedTogether = names;
  banner((data.error && data.error.message) || "The node refused the changes.", "error");
}

function discard() {
  const names = [...S.dirty.keys()];
  clearDirty(names);
  for (const n of names) { const row = S.rows.get(n), tr = rowOf(n); if (row && tr) { tr.replaceWith(rowElement(row)); } }
  filterRows();
}

async function loadFile(file) {
  const text = await file.text();
  const { data } = await api("/api/load", { node: S.selected, text });
  const results = data.results || [];
  const lines = results.map((r) => `${r.name}: ${r.successful ? "ok" : r.reason}`);
  const failed = results.filter((r) => !r.successful).length;
  if (!results.length) banner(`Load failed: ${data.error ? data.error.message : "no answer"}`, "error");
  else banner(`Loaded ${file.name}: ${results.length - failed} set, ${failed} refused.`, failed ? "error" : "ok", lines);
}

// -- live updates -------------------------------------------------------------------------------

function applyRow(row) {
  const old = S.rows.get(row.name);
  S.rows.set(row.name, row);
  const tr = rowOf(row.name);
  if (!tr) { $("#params tbody").append(rowElement(row)); filterRows(); return; }
  $(".current", tr).textContent = cellText(row.value, row.type);
  if (row.name === S.timeline) timelineSoon();
  if (S.dirty.has(row.name)) $("td.last", tr)?.replaceWith(lastChangeCell(row.last_change));
  if (!S.dirty.has(row.name)) {
    const fresh = rowElement(row);
    tr.replaceWith(fresh);
    if (old && toJSON(old.value) !== toJSON(row.value)) { fresh.classList.add("changed"); }
  }
  filterRows();
}

function log(events, skipped) {
  const list = $("#log");
  for (const e of events) {
    const when = new Date(e.stamp * 1000).toLocaleTimeString();
    if (e.site) {  // site_offline / site_online / site_status: one line for the whole site
      const how = e.event === "site_status" ? `  ${e.status || "ok"}` : "";
      list.prepend(el("li", { class: "k-" + e.event, text: `${when}  ${e.event}  ${e.site}${how}` }));
      continue;
    }
    const who = shownNode(e.node, e.origin);
    const what = e.name ? `${who} ${e.name}` + (e.value !== null && e.value !== undefined ? ` = ${cellText(e.value, e.type)}` : "")
      + (e.who ? ` by ${visible(e.who)}` : "")
      : e.event === "status" ? `${who} ${e.status || "ok"}` : who;
    list.prepend(el("li", { class: "k-" + e.event, text: `${when}  ${e.event.padEnd(8)} r${e.revision}  ${what}` }));
  }
  if (skipped) list.prepend(el("li", { class: "muted", text: `… ${skipped} more events` }));
  while (list.children.length > 200) list.lastChild.remove();
}

function openStream() {
  if (S.es) S.es.close();
  const es = new EventSource("/api/events" + (S.selected ? "?node=" + encodeURIComponent(S.selected) : ""));
  S.es = es;
  const state = $("#stream-state");
  // read the list again once subscribed: a node that appeared between the last read and
  // the subscription would otherwise stay missing until it changes
  es.onopen = () => { state.textContent = "live"; state.classList.add("live"); scheduleNodes(0); };
  es.onerror = () => { state.textContent = "reconnecting…"; state.classList.remove("live"); };
  es.addEventListener("node", (m) => {
    const d = parseJSON(m.data);
    if (d.node !== S.selected) return;
    setSummary(d.summary);
    const keep = new Map([...S.dirty.keys()].map((n) => [n, rowOf(n)]));
    renderRows(d.rows);
    for (const [n, tr] of keep) if (tr && rowOf(n)) rowOf(n).replaceWith(tr);
    updateApply();  // the edits kept may show errors
  });
  es.addEventListener("params", (m) => {
    const d = parseJSON(m.data);
    if (d.node !== S.selected) return;
    for (const row of d.rows) applyRow(row);
    for (const n of d.deleted) { S.rows.delete(n); rowOf(n)?.remove(); clearDirty([n]); if (n === S.timeline) timelineSoon(); }
    if (d.summary) setSummary(d.summary);
  });
  es.addEventListener("nodes", (m) => {
    const d = parseJSON(m.data);
    if (d.refresh) scheduleNodes(); else updateNodes(d.nodes);
  });
  es.addEventListener("log", (m) => { const d = parseJSON(m.data); log(d.events, d.skipped); });
  es.addEventListener("resync", () => { scheduleNodes(0); openStream(); });
}

// -- start ---------------------------------------------------------------------------------------

// Where reads need the token, the event stream and the dump link send it as a cookie (neither
// can send a header); same-site only, and writes still need the header.
function tokenCookie(token) {
  document.cookie = `paramdds-token=${encodeURIComponent(token)}; path=/; SameSite=Strict`;
}

async function start() {
  const { data } = await api("/api/info");
  S.info = data;
  const where = data.zenoh ? "zenoh " + data.zenoh : "domain " + data.domain;
  $("#mode").textContent = data.read_only ? "read-only console" : where;
  const saved = sessionStorage.getItem("paramdds-token");
  $("#token-box").hidden = !data.token_required || !!saved;
  if (saved) tokenCookie(saved);
  $("#load-label").hidden = data.read_only;
  $("#operator").hidden = data.read_only;
  $("#operator").value = localStorage.getItem(OPERATOR_KEY) || "";
  $("#operator").addEventListener("input", () => localStorage.setItem(OPERATOR_KEY, operatorName()));
  $("#timeline-close").addEventListener("click", closeTimeline);
  $("#apply").hidden = data.read_only;
  $("#discard").hidden = data.read_only;
  let gotToken = null;
  const tokenGiven = new Promise((resolve) => { gotToken = resolve; });
  $("#token").addEventListener("change", () => {
    const t = $("#token").value.trim();
    sessionStorage.setItem("paramdds-token", t);
    tokenCookie(t);
    gotToken();
  });
  $("#token-box").addEventListener("submit", (e) => e.preventDefault());
  let timer = null;
  $("#search").addEventListener("input", () => {
    clearTimeout(timer);
    timer = setTimeout(() => { S.query = $("#search").value; S.offset = 0; loadNodes(); filterRows(); }, 120);
  });
  $("#prev").addEventListener("click", () => { S.offset = Math.max(0, S.offset - PAGE); loadNodes(); });
  $("#next").addEventListener("click", () => { S.offset += PAGE; loadNodes(); });
  $("#apply").addEventListener("click", applyAll);
  $("#discard").addEventListener("click", discard);
  $("#load").addEventListener("change", (e) => { if (e.target.files[0]) loadFile(e.target.files[0]); e.target.value = ""; });
  if (data.token_for_reads && !saved) {  // reachable from other machines: reads need the token
    $("#stream-state").textContent = "needs the token";
    await tokenGiven;
  }
  await loadNodes();
  fromHash();
  window.addEventListener("hashchange", fromHash);  // a link or an edited address bar
}

// The node named by the address's #node= part; a part that does not decode leaves the node
// view with the reason (it threw here before, and the page stayed "connecting…").
function fromHash() {
  const m = location.hash.match(/^#node=(.*)$/);
  let wanted = null;
  if (m) {
    try { wanted = decodeURIComponent(m[1]); } catch (e) { wanted = null; }
  }
  if (wanted) { if (wanted !== S.selected) select(wanted); }
  else if (m) unselect("The link names no node (its #node= part is not valid): select one.");
  else if (!S.es) openStream();
}
start();
