"use strict";
// Two datasets side by side on the same columns, under the same --where (the server computes both tables, their
// success rates with Wilson intervals and the difference B - A with its Newcombe interval).
const params = new URLSearchParams(location.search);
const pair = { a: params.get("a") || "0", b: params.get("b") || "1" };
const state = { where: "", sort: "episode_index", desc: false };

function text(v) {
  if (v === null || v === undefined) return "";
  if (typeof v === "number" && !Number.isInteger(v)) return v.toFixed(2);
  return String(v);
}

function percent(x) { return (100 * x).toFixed(1) + " %"; }

function side(name, body) {
  const div = document.getElementById(`side-${name}`);
  const h = document.createElement("h2");
  const link = document.createElement("a");
  link.href = `/d/${pair[name]}/`;
  link.textContent = body.label;
  h.append(`${name.toUpperCase()}: `, link);
  const p = document.createElement("p");
  p.className = "summary";
  p.textContent = `${body.total} episodes` + (body.known ? `; success ${body.successes}/${body.known} = ` +
    `${percent(body.rate)} (95 % Wilson ${percent(body.interval[0])} – ${percent(body.interval[1])})` : "");
  const table = document.createElement("table");
  const head = document.createElement("tr");
  for (const c of body.columns) {
    const th = document.createElement("th");
    th.className = "sortable";
    th.dataset.column = c.key;
    th.textContent = c.label;
    th.addEventListener("click", () => {
      state.desc = state.sort === c.key ? !state.desc : false;
      state.sort = c.key;
      load();
    });
    head.append(th);
  }
  table.append(head);
  for (const row of body.rows) {
    const tr = document.createElement("tr");
    tr.dataset.episode = row.episode_index;
    for (const c of body.columns) {
      const td = document.createElement("td");
      if (c.key === "episode_index") {
        const a = document.createElement("a");
        a.href = `/d/${pair[name]}/episode/${row.episode_index}`;
        a.textContent = text(row[c.key]);
        td.append(a);
      } else {
        td.textContent = text(row[c.key]);
      }
      tr.append(td);
    }
    table.append(tr);
  }
  div.replaceChildren(h, p, table);
}

async function load() {
  const q = new URLSearchParams({ ...pair, where: state.where, sort: state.sort, desc: state.desc ? "1" : "0" });
  const r = await fetch(`/api/compare?${q}`);
  const body = await r.json();
  document.getElementById("error").textContent = r.ok ? "" : body.error;
  if (!r.ok) return;
  side("a", body.a);
  side("b", body.b);
  const d = body.difference;
  document.getElementById("difference").textContent = d === null ? "success rate difference: unknown" :
    `success rate B − A: ${percent(d.rate)} (95 % Newcombe ${percent(d.interval[0])} – ${percent(d.interval[1])}; ` +
    `Fisher exact p = ${d.fisher_p.toPrecision(3)})`;
  document.body.dataset.ready = "1";
}

document.getElementById("filter").addEventListener("submit", (event) => {
  event.preventDefault();
  state.where = document.getElementById("where").value;
  load();
});
load();
