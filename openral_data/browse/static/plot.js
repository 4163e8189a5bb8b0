"use strict";
// One feature's dimensions over the episode as an SVG chart: x in frames, y in the values, with axes, ticks and
// grid; each dimension can be hidden (its chip), and the y scale is shared by the shown dimensions or each
// dimension's own range ("each": a 0..1 gripper beside centimetre moves no longer flattens them); the quality
// spans of the episode are bands; the cursor follows the video; hovering reads every shown value at the frame
// under the pointer, a click seeks there. Plain DOM and SVG: no library, nothing from outside.
const SVG_NS = "http://www.w3.org/2000/svg";
const PALETTE = ["#2563eb", "#ea580c", "#16a34a", "#dc2626", "#9333ea", "#0891b2", "#db2777", "#65a30d", "#a16207",
  "#475569"];
const PAD = { left: 56, right: 12, top: 10, bottom: 26 };
const HEIGHT = 190;

function svgEl(tag, attrs) {
  const el = document.createElementNS(SVG_NS, tag);
  for (const [k, v] of Object.entries(attrs || {})) el.setAttribute(k, String(v));
  return el;
}

// about `count` round tick values covering lo..hi (1, 2, 5 times a power of ten apart)
function ticks(lo, hi, count) {
  if (!(hi > lo)) return [lo];
  const raw = (hi - lo) / Math.max(1, count);
  const power = Math.pow(10, Math.floor(Math.log10(raw)));
  const step = [1, 2, 5, 10].map((m) => m * power).find((s) => s >= raw) || 10 * power;
  const out = [];
  for (let v = Math.ceil(lo / step) * step; v <= hi + step * 1e-9; v += step) out.push(Math.abs(v) < step * 1e-9 ? 0 : v);
  return out;
}

// a value as a person reads it: at most 4 significant digits, exponent only when tiny or huge
function formatValue(v) {
  if (v === null || v === undefined) return "–";
  if (typeof v === "boolean") return String(v);
  if (v === 0) return "0";
  const a = Math.abs(v);
  if (a >= 1e5 || a < 1e-3) return v.toExponential(2);
  return String(Number(v.toPrecision(4)));
}

function extent(values) {
  let lo = Infinity, hi = -Infinity;
  for (const v of values) if (v !== null && Number.isFinite(v)) { if (v < lo) lo = v; if (v > hi) hi = v; }
  return lo <= hi ? [lo, hi] : [0, 1];
}

function padded([lo, hi]) {
  if (hi > lo) { const m = (hi - lo) * 0.06; return [lo - m, hi + m]; }
  const m = Math.abs(lo) > 0 ? Math.abs(lo) * 0.1 : 1;
  return [lo - m, hi + m];
}

class Plot {
  // feature: its name; series: [{name, values}] one per dimension; frames: the episode's length; spans: the quality
  // spans drawn here; seek(frame) moves the episode to a frame
  constructor(feature, series, frames, spans, seek) {
    this.feature = feature;
    this.series = series.map((s, i) => ({ ...s, color: PALETTE[i % PALETTE.length], shown: true,
      range: extent(s.values) }));
    this.frames = frames;
    this.spans = spans;
    this.seek = seek;
    this.frame = 0;
    this.scale = this.defaultScale();
    this.box = document.createElement("section");
    this.box.className = "card plot-card";
    this.box.dataset.feature = feature;
    this.head = document.createElement("header");
    this.body = document.createElement("div");
    this.body.className = "plot-body";
    this.readout = document.createElement("div");
    this.readout.className = "readout";
    this.readout.hidden = true;
    this.body.append(this.readout);
    this.box.append(this.head, this.body);
    this.header();
  }

  // "each" when the shown dimensions' ranges differ more than tenfold (one would flatten the others), else "shared"
  defaultScale() {
    const widths = this.series.map((s) => s.range[1] - s.range[0]).filter((w) => w > 0);
    if (widths.length < 2) return "shared";
    return Math.max(...widths) / Math.min(...widths) > 10 ? "each" : "shared";
  }

  header() {
    const title = document.createElement("h3");
    title.textContent = this.feature;
    const scale = document.createElement("select");
    scale.className = "scale";
    scale.title = "y scale";
    for (const [value, label] of [["shared", "shared y axis"], ["each", "each dimension its range"]]) {
      const o = document.createElement("option");
      o.value = value;
      o.textContent = label;
      scale.append(o);
    }
    scale.value = this.scale;
    scale.addEventListener("change", () => { this.scale = scale.value; this.draw(); });
    const chips = document.createElement("div");
    chips.className = "chips";
    for (const s of this.series) {
      const label = document.createElement("label");
      label.className = "chip";
      label.title = `${s.name}: ${formatValue(s.range[0])} … ${formatValue(s.range[1])}`;
      const box = document.createElement("input");
      box.type = "checkbox";
      box.checked = true;
      box.dataset.series = s.name;
      box.addEventListener("change", () => { s.shown = box.checked; this.draw(); });
      const swatch = document.createElement("i");
      swatch.style.background = s.color;
      label.append(box, swatch, s.name);
      chips.append(label);
    }
    const top = document.createElement("div");
    top.className = "plot-title";
    top.append(title, scale);
    this.head.append(top, chips);
  }

  // the y range of series `s` in the current scale
  yRange(s) {
    if (this.scale === "each") return padded(s.range);
    const shown = this.series.filter((t) => t.shown);
    const lo = Math.min(...shown.map((t) => t.range[0])), hi = Math.max(...shown.map((t) => t.range[1]));
    return padded(shown.length ? [lo, hi] : [0, 1]);
  }

  draw() {
    const width = Math.max(260, Math.floor(this.body.clientWidth || 600));
    this.width = width;
    const w = width - PAD.left - PAD.right, h = HEIGHT - PAD.top - PAD.bottom;
    this.x = (k) => PAD.left + (this.frames > 1 ? w * k / (this.frames - 1) : 0);
    const chart = svgEl("svg", { class: "plot", width, height: HEIGHT, viewBox: `0 0 ${width} ${HEIGHT}`,
      "data-feature": this.feature, "data-scale": this.scale });
    chart.append(svgEl("rect", { class: "frame", x: PAD.left, y: PAD.top, width: w, height: h }));
    this.drawSpans(chart, h);
    this.drawAxes(chart, w, h);
    for (const s of this.series) {
      const [lo, hi] = this.yRange(s);
      const y = (v) => PAD.top + h - h * (v - lo) / (hi - lo);
      const points = [];
      s.values.forEach((v, k) => { if (v !== null) points.push(`${this.x(k).toFixed(1)},${y(v).toFixed(1)}`); });
      const line = svgEl("polyline", { points: points.join(" "), fill: "none", stroke: s.color, "stroke-width": 1.6,
        "data-series": s.name, "stroke-linejoin": "round" });
      if (!s.shown) line.setAttribute("visibility", "hidden");
      chart.append(line);
    }
    this.hover = svgEl("line", { class: "hover", y1: PAD.top, y2: PAD.top + h, visibility: "hidden" });
    this.cursor = svgEl("line", { class: "cursor", y1: PAD.top, y2: PAD.top + h });
    chart.append(this.hover, this.cursor);
    chart.addEventListener("mousemove", (e) => this.read(this.frameAt(chart, e)));
    chart.addEventListener("mouseleave", () => { this.readout.hidden = true; this.hover.setAttribute("visibility", "hidden"); });
    chart.addEventListener("click", (e) => this.seek(this.frameAt(chart, e)));
    if (this.chart) this.chart.replaceWith(chart); else this.body.prepend(chart);
    this.chart = chart;
    this.move(this.frame);
  }

  drawAxes(chart, w, h) {
    const axis = svgEl("g", { class: "axis" });
    if (this.scale === "shared") {
      const [lo, hi] = this.yRange(this.series.find((s) => s.shown) || this.series[0]);
      for (const v of ticks(lo, hi, 4)) {
        const y = PAD.top + h - h * (v - lo) / (hi - lo);
        axis.append(svgEl("line", { class: "grid", x1: PAD.left, x2: PAD.left + w, y1: y, y2: y }));
        const t = svgEl("text", { x: PAD.left - 6, y: y + 4, "text-anchor": "end" });
        t.textContent = formatValue(v);
        axis.append(t);
      }
    } else {  // each dimension on its own range: the axis reads as a share of it (hover gives the values)
      const [lo, hi] = padded([0, 1]);
      for (const [share, label] of [[0, "min"], [0.5, ""], [1, "max"]]) {
        const y = PAD.top + h - h * (share - lo) / (hi - lo);
        axis.append(svgEl("line", { class: "grid", x1: PAD.left, x2: PAD.left + w, y1: y, y2: y }));
        const t = svgEl("text", { x: PAD.left - 6, y: y + 4, "text-anchor": "end" });
        t.textContent = label;
        axis.append(t);
      }
    }
    for (const k of ticks(0, this.frames - 1, Math.max(2, Math.floor(w / 70))).filter(Number.isInteger)) {
      const x = this.x(k);
      axis.append(svgEl("line", { class: "tick", x1: x, x2: x, y1: PAD.top + h, y2: PAD.top + h + 4 }));
      const t = svgEl("text", { x, y: PAD.top + h + 16, "text-anchor": "middle" });
      t.textContent = String(k);
      axis.append(t);
    }
    const unit = svgEl("text", { class: "unit", x: PAD.left - 14, y: PAD.top + h + 16, "text-anchor": "end" });
    unit.textContent = "frame";
    axis.append(unit);
    chart.append(axis);
  }

  drawSpans(chart, h) {
    for (const span of this.spans) {
      const a = this.x(span.start_frame - 0.5 < 0 ? 0 : span.start_frame - 0.5);
      const b = this.x(Math.min(this.frames - 1, span.end_frame + 0.5));
      const rect = svgEl("rect", { class: `span check-${span.check}`, x: a, y: PAD.top, width: Math.max(2, b - a),
        height: h, "data-check": span.check });
      const title = svgEl("title");
      title.textContent = spanText(span);
      rect.append(title);
      chart.append(rect);
    }
  }

  frameAt(chart, event) {
    const box = chart.getBoundingClientRect();
    const x = (event.clientX - box.left) * (this.width / box.width);
    const w = this.width - PAD.left - PAD.right;
    return Math.max(0, Math.min(this.frames - 1, Math.round((x - PAD.left) / w * (this.frames - 1))));
  }

  // the readout at frame k: each shown dimension's value
  read(k) {
    const x = this.x(k);
    this.hover.setAttribute("x1", x);
    this.hover.setAttribute("x2", x);
    this.hover.setAttribute("visibility", "visible");
    const rows = [document.createElement("b")];
    rows[0].textContent = `frame ${k}`;
    for (const s of this.series.filter((t) => t.shown)) {
      const row = document.createElement("div");
      row.dataset.series = s.name;
      const swatch = document.createElement("i");
      swatch.style.background = s.color;
      const value = document.createElement("span");
      value.className = "value";
      value.textContent = formatValue(s.values[k]);
      row.append(swatch, `${s.name} `, value);
      rows.push(row);
    }
    this.readout.replaceChildren(...rows);
    this.readout.hidden = false;
    const left = x + 12 + 180 > this.width ? x - 12 - 180 : x + 12;
    this.readout.style.left = `${Math.max(0, left)}px`;
  }

  move(k) {
    this.frame = k;
    if (!this.cursor) return;
    const x = this.x(k);
    this.cursor.setAttribute("x1", x);
    this.cursor.setAttribute("x2", x);
  }
}

function spanText(s) {
  const frames = s.start_frame === s.end_frame ? `frame ${s.start_frame}` : `frames ${s.start_frame}–${s.end_frame}`;
  const measured = s.value === null || s.value === undefined ? "" :
    `: ${formatValue(s.value)}${s.threshold === null || s.threshold === undefined ? "" : ` (threshold ${formatValue(s.threshold)})`}`;
  return `${s.check} · ${s.subject} · ${frames}${measured}${s.detail ? ` · ${s.detail}` : ""}` +
    (s.flag === false ? " (informational)" : "");
}
