// paramdds console: plain JavaScript, no build step, no third-party code.
//
// State lives on the server (one monitor); this page shows one page of the node
// list and one node's rows, kept live by one EventSource (/api/events?node=…).
// Edits are validated here from the descriptor before anything is sent; the server
// validates again and the node has the last word (its reason is shown under the field).
"use strict";

const PAGE = 50;
const S = {
  info: { read_only: true, token_required: false },
  query: "", offset: 0, total: 0, nodes: [],
  selected: null, summary: null,
  rows: new Map(),      // name -> row {name, value, type, descriptor}
  dirty: new Map(),     // name -> value typed from the editor
  baseRevision: null,   // the revision the edits were started against (compare-and-set)
  es: null, listTimer: null,
};
const $ = (sel, root = document) => root.querySelector(sel);
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
  if (typeof v === "string") return "'" + v.replace(/\\/g, "\\\\").replace(/'/g, "\\'") + "'";
  if (typeof v === "number" && (type === "double" || type === "double_array")) return Number.isInteger(v) ? v.toFixed(1) : String(v);
  return String(v);
}
function showValue(v, type) {
  if (v === null || v === undefined) return "not_set";
  if (type === "byte_array") return v.map((b) => b.toString(16).padStart(2, "0")).join(" ") || "(empty)";
  if (Array.isArray(v)) return "[" + v.map((x) => showScalar(x, type)).join(", ") + "]";
  return showScalar(v, type);
}
function showRangeEnd(x, type) { return type.startsWith("double") ? showScalar(x, "double") : String(x); }

function constraintsText(d) {
  const parts = [];
  const r = d.integer_range || d.floating_point_range;
  const t = d.floating_point_range ? "double" : "integer";
  if (r) parts.push(`[${showRangeEnd(r.from_value, t)}, ${showRangeEnd(r.to_value, t)}]` + (r.step ? ` step ${r.step}` : ""));
  for (const v of d.validators) parts.push(v.args.length ? `${v.kind}(${v.args.map((a) => JSON.stringify(a)).join(", ")})` : v.kind);
  if (d.additional_constraints) parts.push(d.additional_constraints);
  return parts.join("; ");
}

// -- validation from the descriptor --------------------------------------------------------

const TOL = 1e-6;
function elementType(type) { return { bool_array: "bool", integer_array: "integer", double_array: "double", string_array: "string", byte_array: "integer" }[type]; }

function parseScalar(text, type) {
  const t = text.trim();
  if (type === "integer") {
    if (!/^[-+]?\d+$/.test(t)) throw new Error(`expected an integer, got '${text}'`);
    const n = Number(t);
    if (!Number.isSafeInteger(n)) throw new Error(`${t} is beyond what this editor can send exactly (±2^53)`);
    return n;
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
  try { list = JSON.parse(raw); } catch (e) { throw new Error("expected a list such as [1, 2, 3]"); }
  if (!Array.isArray(list)) throw new Error("expected a list such as [1, 2, 3]");
  const et = elementType(type);
  return list.map((x, i) => {
    const ok = et === "bool" ? typeof x === "boolean" : et === "string" ? typeof x === "string"
      : et === "integer" ? Number.isInteger(x) : typeof x === "number" || ["nan", "inf", "-inf"].includes(x);
    if (!ok) throw new Error(`element ${i} (${JSON.stringify(x)}) is not a ${et}`);
    return x;
  });
}

function num(x) { return x === "nan" ? NaN : x === "inf" ? Infinity : x === "-inf" ? -Infinity : x; }
function elems(v) { return Array.isArray(v) ? v : [v]; }
function onGrid(v, lo, step, isFloat) {
  if (!step) return true;
  if (!isFloat) return (v - lo) % step === 0;
  const k = Math.round((v - lo) / step), near = lo + k * step;
  return Math.abs(v - near) <= TOL * Math.max(Math.abs(v), Math.abs(near)) || Math.abs(v - near) <= TOL * step;
}

// The first rule `value` breaks, worded as the node words it; null when it keeps them all.
function violation(name, row, value) {
  const d = row.descriptor, type = d.type !== "not_set" ? d.type : row.type;
  const shown = type === "byte_array" ? showValue(value.match(/../g)?.map((h) => parseInt(h, 16)) ?? [], type) : showValue(value, type);
  const who = `Parameter '${name}' with value ${shown} must`;
  const r = d.integer_range || d.floating_point_range;
  if (r && type !== "byte_array") {
    const isFloat = !!d.floating_point_range;
    for (const x of elems(value)) {
      const v = num(x);
      const atEnd = isFloat ? (Math.abs(v - r.from_value) <= TOL * Math.abs(r.from_value) || Math.abs(v - r.to_value) <= TOL * Math.abs(r.to_value)) : (v === r.from_value || v === r.to_value);
      if (atEnd) continue;
      if (!(Number.isFinite(v) && v >= r.from_value && v <= r.to_value && onGrid(v, r.from_value, r.step, isFloat))) {
        const grid = r.step ? ` in steps of ${showRangeEnd(r.step, type)}` : "";
        return `${who} be within [${showRangeEnd(r.from_value, type)}, ${showRangeEnd(r.to_value, type)}]${grid}`;
      }
    }
  }
  const list = Array.isArray(value) ? value : type === "byte_array" ? (value.match(/../g) || []) : null;
  for (const val of d.validators) {
    const a = val.args.map(num), size = list ? list.length : typeof value === "string" ? [...value].length : 0;
    const scalar = num(value);
    const broken = {
      bounds: () => !(scalar >= a[0] && scalar <= a[1]) && `be within bounds [${val.args[0]}, ${val.args[1]}]`,
      lower_bounds: () => !(scalar >= a[0]) && `be at least ${val.args[0]}`,
      upper_bounds: () => !(scalar <= a[0]) && `be at most ${val.args[0]}`,
      gt: () => !(scalar > a[0]) && `be greater than ${val.args[0]}`,
      lt: () => !(scalar < a[0]) && `be less than ${val.args[0]}`,
      gt_eq: () => !(scalar >= a[0]) && `be at least ${val.args[0]}`,
      lt_eq: () => !(scalar <= a[0]) && `be at most ${val.args[0]}`,
      one_of: () => !val.args[0].some((c) => c === value) && `be one of ${JSON.stringify(val.args[0])}`,
      size_gt: () => !(size > a[0]) && `have more than ${a[0]} elements`,
      size_lt: () => !(size < a[0]) && `have fewer than ${a[0]} elements`,
      fixed_size: () => size !== a[0] && `have exactly ${a[0]} elements`,
      not_empty: () => size === 0 && "not be empty",
      unique: () => list && new Set(list.map(String)).size !== list.length && "have unique elements",
      subset_of: () => list && list.some((x) => !val.args[0].includes(x)) && `only hold elements of ${JSON.stringify(val.args[0])}`,
      element_bounds: () => list && list.some((x) => !(num(x) >= a[0] && num(x) <= a[1])) && `have every element within [${val.args[0]}, ${val.args[1]}]`,
      lower_element_bounds: () => list && list.some((x) => !(num(x) >= a[0])) && `have every element at least ${val.args[0]}`,
      upper_element_bounds: () => list && list.some((x) => !(num(x) <= a[0])) && `have every element at most ${val.args[0]}`,
    }[val.kind];
    const rule = broken ? broken() : false;
    if (rule) return `${who} ${rule}`;
  }
  return null;
}

// -- API --------------------------------------------------------------------------------

async function api(path, body) {
  const opts = { headers: {} };
  if (body !== undefined) {
    opts.method = "POST";
    opts.headers["Content-Type"] = "application/json";
    const token = sessionStorage.getItem("paramdds-token") || $("#token").value;
    if (token) opts.headers["Authorization"] = "Bearer " + token;
    opts.body = JSON.stringify(body);
  }
  const res = await fetch(path, opts);
  let data = null;
  try { data = await res.json(); } catch (e) { data = { error: { code: "HTTP_" + res.status, message: res.statusText } }; }
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
  renderNodes();
  if (window.paramddsFirstRender === undefined) window.paramddsFirstRender = performance.now();
}
function scheduleNodes(delay = 250) { clearTimeout(S.listTimer); S.listTimer = setTimeout(loadNodes, delay); }

function nodeItem(n) {
  const li = el("li", { "data-node": n.node, class: (n.online ? "" : "offline ") + (n.node === S.selected ? "selected" : ""), title: `${n.host} pid ${n.pid}` },
    el("span", { class: "n" }, el("span", { class: "dot" }), n.node),
    el("span", { class: "m", text: `${n.parameters} params · r${n.revision}` + (n.online ? "" : " · offline") }));
  li.addEventListener("click", () => select(n.node));
  return li;
}
function renderNodes() {
  $("#nodes").replaceChildren(...S.nodes.map(nodeItem));
  const last = Math.min(S.total, S.offset + PAGE);
  $("#node-count").textContent = `${S.total} node${S.total === 1 ? "" : "s"}` + (S.query ? ` matching '${S.query}'` : "");
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

function select(node) {
  if (S.selected !== node) { S.dirty.clear(); S.baseRevision = null; banner(null); }
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

function setSummary(s) {
  S.summary = s;
  if (!s) { $("#node-meta").textContent = "unknown node"; return; }
  $("#node-view").classList.toggle("offline", !s.online);
  $("#node-meta").textContent = `${s.online ? "online" : "offline"} · host ${s.host} · pid ${s.pid} · revision ${s.revision} · ${s.parameters} parameters`;
  $("#node-meta").dataset.revision = s.revision;
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
  const tr = el("tr", { "data-name": row.name },
    el("td", { class: "name" }, row.name, d.read_only ? el("span", { class: "lock", title: "read-only: no editor", text: "read-only" }) : null),
    el("td", { class: "value" }, el("span", { class: "current", text: showValue(row.value, row.type) }),
      editable(row) ? editorFor(row) : null, el("div", { class: "error" })),
    el("td", { class: "type", text: row.type }),
    el("td", { class: "desc", text: d.description }),
    el("td", { class: "constraints", text: constraintsText(d) }));
  return tr;
}

function editorText(row) {
  if (row.type === "byte_array") return row.value.map((b) => b.toString(16).padStart(2, "0")).join(" ");
  if (row.type === "double_array" && row.value.every((x) => typeof x === "number")) return showValue(row.value, row.type);
  if (Array.isArray(row.value)) return JSON.stringify(row.value);
  if (row.type === "double" && typeof row.value === "number") return Number.isInteger(row.value) ? row.value.toFixed(1) : String(row.value);
  return row.value === null ? "" : String(row.value);
}

function editorFor(row) {
  const d = row.descriptor, type = d.type !== "not_set" ? d.type : row.type;
  const box = el("div", { class: "editor" });
  const oneOf = d.validators.find((v) => v.kind === "one_of");
  let input, read;
  if (type === "bool") {
    input = el("input", { type: "checkbox", checked: !!row.value, "data-role": "input" });
    read = () => input.checked;
  } else if (oneOf && !type.endsWith("_array")) {
    input = el("select", { "data-role": "input" }, ...oneOf.args[0].map((c) => el("option", { value: String(c), text: String(c), selected: c === row.value })));
    read = () => { const c = oneOf.args[0].find((x) => String(x) === input.value); return type === "string" ? c : String(c); };
  } else {
    const r = d.integer_range || d.floating_point_range;
    input = el("input", { type: "text", value: editorText(row), "data-role": "input", spellcheck: false });
    if (r && (type === "integer" || type === "double")) {
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
  input.addEventListener("keydown", (e) => { if (e.key === "Enter") applyOne(row.name); });
  box.readValue = read;
  return box;
}

function rowOf(name) { return $(`#params tbody tr[data-name="${CSS.escape(name)}"]`); }
function setError(name, text) { const tr = rowOf(name); if (tr) $(".error", tr).textContent = text || ""; }

// The editor's value, parsed and checked; sets the inline error and returns undefined when bad.
function editorValue(name) {
  const row = S.rows.get(name), tr = rowOf(name);
  if (!row || !tr) return undefined;
  let value;
  try { value = parseEditor(row, $(".editor", tr).readValue()); } catch (e) { setError(name, e.message); return undefined; }
  const bad = violation(name, row, value);
  setError(name, bad);
  return bad ? undefined : value;
}

function markDirty(name) {
  if (S.dirty.size === 0) S.baseRevision = S.summary ? S.summary.revision : null;
  S.dirty.set(name, true);
  rowOf(name)?.classList.add("dirty");
  editorValue(name);
  updateApply();
}
function clearDirty(names) {
  for (const n of names) { S.dirty.delete(n); rowOf(n)?.classList.remove("dirty"); }
  if (S.dirty.size === 0) S.baseRevision = null;
  updateApply();
}
function updateApply() {
  const n = S.dirty.size;
  $("#apply").disabled = n === 0 || S.info.read_only;
  $("#discard").disabled = n === 0;
  $("#apply").textContent = n ? `Apply ${n} change${n === 1 ? "" : "s"} atomically` : "Apply atomically";
}

function banner(text, kind = "", items = null) {
  const b = $("#banner");
  if (!text) { b.hidden = true; return; }
  b.hidden = false;
  b.className = kind;
  b.replaceChildren(el("div", { text }), items ? el("ul", {}, ...items.map((t) => el("li", { text: t }))) : null);
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
  const value = editorValue(name);
  if (value === undefined) return;
  const node = S.selected;
  const { ok, data } = await api("/api/set", { node, values: { [name]: value } });
  if (node !== S.selected) return;
  showResults(data, [name]);
  if (ok) { clearDirty([name]); acked([name]); if (data.revision != null && S.summary) setSummary({ ...S.summary, revision: Math.max(S.summary.revision, data.revision) }); }
}

async function applyAll() {
  const names = [...S.dirty.keys()], values = {};
  for (const n of names) {
    const v = editorValue(n);
    if (v === undefined) { banner(`Not sent: ${n} is not valid.`, "error"); return; }
    values[n] = v;
  }
  const node = S.selected, expected = S.baseRevision;
  const { ok, status, data } = await api("/api/set", { node, values, atomic: true, if_revision: expected });
  if (node !== S.selected) return;
  if (ok) { banner(`Applied ${names.length} changes atomically (revision ${data.revision}).`, "ok"); clearDirty(names); acked(names); return; }
  if (status === 409 && data.error && data.error.code === "CONFLICT") {
    clearDirty(names);
    if (data.rows) renderRows(data.rows);
    if (data.summary) setSummary(data.summary);
    banner(`Not applied: node ${node} changed meanwhile (revision ${expected} → ${data.summary ? data.summary.revision : data.revision}). The newer values are shown; edit again.`, "error");
    return;
  }
  showResults(data, names);
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
  $(".current", tr).textContent = showValue(row.value, row.type);
  if (!S.dirty.has(row.name)) {
    const fresh = rowElement(row);
    tr.replaceWith(fresh);
    if (old && JSON.stringify(old.value) !== JSON.stringify(row.value)) { fresh.classList.add("changed"); }
  }
  filterRows();
}

function log(events, skipped) {
  const list = $("#log");
  for (const e of events) {
    const when = new Date(e.stamp * 1000).toLocaleTimeString();
    const what = e.name ? `${e.node} ${e.name}` + (e.value !== null && e.value !== undefined ? ` = ${JSON.stringify(e.value)}` : "") : e.node;
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
    const d = JSON.parse(m.data);
    if (d.node !== S.selected) return;
    setSummary(d.summary);
    const keep = new Map([...S.dirty.keys()].map((n) => [n, rowOf(n)]));
    renderRows(d.rows);
    for (const [n, tr] of keep) if (tr && rowOf(n)) rowOf(n).replaceWith(tr);
  });
  es.addEventListener("params", (m) => {
    const d = JSON.parse(m.data);
    if (d.node !== S.selected) return;
    for (const row of d.rows) applyRow(row);
    for (const n of d.deleted) { S.rows.delete(n); rowOf(n)?.remove(); clearDirty([n]); }
    if (d.summary) setSummary(d.summary);
  });
  es.addEventListener("nodes", (m) => {
    const d = JSON.parse(m.data);
    if (d.refresh) scheduleNodes(); else updateNodes(d.nodes);
  });
  es.addEventListener("log", (m) => { const d = JSON.parse(m.data); log(d.events, d.skipped); });
  es.addEventListener("resync", () => { scheduleNodes(0); openStream(); });
}

// -- start ---------------------------------------------------------------------------------------

async function start() {
  const { data } = await api("/api/info");
  S.info = data;
  $("#mode").textContent = data.read_only ? "read-only console" : "domain " + data.domain;
  $("#token-box").hidden = !data.token_required || !!sessionStorage.getItem("paramdds-token");
  $("#load-label").hidden = data.read_only;
  $("#apply").hidden = data.read_only;
  $("#discard").hidden = data.read_only;
  $("#token").addEventListener("change", () => sessionStorage.setItem("paramdds-token", $("#token").value.trim()));
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
  const m = location.hash.match(/^#node=(.+)$/);
  await loadNodes();
  if (m) select(decodeURIComponent(m[1])); else openStream();
}
start();
