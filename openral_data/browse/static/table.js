"use strict";
// The episodes table: every query goes to the server (paging, sorting, the --where filter); the selection only
// prints commands, it never changes anything.
const ds = location.pathname.split("/")[2];
// the dataset's columns by these titles; a results folder's columns (browse DATASET RESULTS) as the server names them
const TITLES = { episode_index: "episode", duration_s: "duration (s)" };
let columns = [];
const state = { where: new URLSearchParams(location.search).get("where") || "", sort: "episode_index", desc: false, offset: 0, limit: 50, total: 0 };
const selected = new Set();

function text(v) {
  if (v === null || v === undefined) return "";
  if (typeof v === "number" && !Number.isInteger(v)) return Math.abs(v) < 0.01 && v !== 0 ? v.toExponential(1) : v.toFixed(2);
  return String(v);
}

function header(list) {
  columns = list.map((c) => [c.key, TITLES[c.key] || c.label]);
  const tr = document.querySelector("#episodes thead tr");
  for (const [key, label] of columns) {
    const th = document.createElement("th");
    th.className = "sortable";
    th.dataset.column = key;
    th.textContent = label;
    th.addEventListener("click", () => {
      state.desc = state.sort === key ? !state.desc : false;
      state.sort = key;
      state.offset = 0;
      load();
    });
    tr.append(th);
  }
}

function percent(x) { return (100 * x).toFixed(1) + " %"; }

let latest = 0; // the newest request: an older response arriving after it is dropped (two quick clicks)

async function load() {
  const mine = ++latest;
  const q = new URLSearchParams({
    where: state.where, sort: state.sort, desc: state.desc ? "1" : "0",
    offset: String(state.offset), limit: String(state.limit),
  });
  const r = await fetch(`/api/d/${ds}/episodes?${q}`);
  const body = await r.json();
  if (mine !== latest) return;
  const error = document.getElementById("error");
  if (!r.ok) { error.textContent = body.error; return; }
  error.textContent = "";
  if (!columns.length) header(body.columns);
  state.total = body.total;
  let summary = `${body.total} episodes`;
  if (body.known) {
    summary += `; success ${body.successes}/${body.known} = ${percent(body.rate)}` +
      ` (95 % Wilson interval ${percent(body.interval[0])} – ${percent(body.interval[1])})`;
  }
  document.getElementById("summary").textContent = summary;
  const tbody = document.querySelector("#episodes tbody");
  tbody.replaceChildren();
  for (const row of body.rows) {
    const tr = document.createElement("tr");
    tr.dataset.episode = row.episode_index;
    const box = document.createElement("input");
    box.type = "checkbox";
    box.checked = selected.has(row.episode_index);
    box.addEventListener("change", () => {
      if (box.checked) selected.add(row.episode_index); else selected.delete(row.episode_index);
      commands();
    });
    const td = document.createElement("td");
    td.append(box);
    tr.append(td);
    for (const [key] of columns) {
      const cell = document.createElement("td");
      if (key === "episode_index") {
        const a = document.createElement("a");
        // the episode page's previous/next then step through this filter's episodes
        a.href = `/d/${ds}/episode/${row.episode_index}` + (state.where ? `?${new URLSearchParams({ where: state.where })}` : "");
        a.textContent = text(row[key]);
        cell.append(a);
      } else {
        cell.textContent = text(row[key]);
      }
      tr.append(cell);
    }
    tbody.append(tr);
  }
  const last = Math.min(state.offset + state.limit, body.total);
  document.getElementById("page").textContent = `${body.total ? state.offset + 1 : 0}–${last} of ${body.total}`;
  commands();
}

// the commands for the ticked episodes the filter keeps: one ticked and then hidden by a --where is left out
async function commands() {
  const ticked = [...selected].sort((a, b) => a - b);
  const q = new URLSearchParams({ episodes: ticked.join(","), where: state.where });
  const r = await fetch(`/api/d/${ds}/commands?${q}`);
  const body = await r.json();
  if (!r.ok) return;  // a bad --where: the table says why
  let text = body.picked.length ? `selected: ${body.picked.join(", ")}` : "no episode selected";
  if (body.hidden.length) text += ` (ticked but hidden by the filter, left out: ${body.hidden.join(", ")})`;
  document.getElementById("selected").textContent = text;
  const div = document.getElementById("commands");
  div.replaceChildren();
  for (const [name, command] of Object.entries(body.commands)) {
    const pre = document.createElement("pre");
    pre.id = `command-${name}`;
    pre.textContent = command;
    div.append(pre);
  }
}

document.getElementById("filter").addEventListener("submit", (event) => {
  event.preventDefault();
  state.where = document.getElementById("where").value;
  state.offset = 0;
  load();
});
document.getElementById("prev").addEventListener("click", () => {
  state.offset = Math.max(0, state.offset - state.limit); load();
});
document.getElementById("next").addEventListener("click", () => {
  if (state.offset + state.limit < state.total) { state.offset += state.limit; load(); }
});
document.getElementById("where").value = state.where;
fetch("/api/datasets").then((r) => r.json()).then((list) => {
  document.getElementById("title").textContent = `${list[ds].label}: episodes`;
});
load();
