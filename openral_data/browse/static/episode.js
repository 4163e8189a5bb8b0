"use strict";
// One episode: each camera's mp4 (shared by many episodes) played over the episode's span only, the first camera
// leading the others; one SVG plot per feature with a cursor at the video's time.
const parts = location.pathname.split("/");
const ds = parts[2];
const ep = parts[4];
const SVG = "http://www.w3.org/2000/svg";
const W = 800, H = 160;
const COLORS = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"];
const cursors = [];
const depths = [];  // depth cameras, pictures, masks: an <img> of the frame at the cursor (drawn on the server)
let duration = 1;
let frames = { fps: 1, length: 1 };

function svg(tag, attrs) {
  const el = document.createElementNS(SVG, tag);
  for (const [k, v] of Object.entries(attrs)) el.setAttribute(k, String(v));
  return el;
}

function plot(feature, series, times) {
  const values = series.flatMap((s) => s.values).filter((v) => v !== null);
  const lo = Math.min(...values), hi = Math.max(...values);
  const span = hi > lo ? hi - lo : 1;
  const box = document.createElement("div");
  const h = document.createElement("h3");
  h.textContent = feature;
  const chart = svg("svg", { class: "plot", width: W, height: H, viewBox: `0 0 ${W} ${H}`, "data-feature": feature });
  series.forEach((s, i) => {
    const points = s.values.map((v, k) => v === null ? null :
      `${(W * times[k] / duration).toFixed(1)},${(H - 4 - (H - 8) * (v - lo) / span).toFixed(1)}`).filter((p) => p);
    const line = svg("polyline", {
      points: points.join(" "), fill: "none", stroke: COLORS[i % COLORS.length], "stroke-width": 1.2,
      "data-series": s.name,
    });
    const title = svg("title", {});
    title.textContent = s.name;
    line.append(title);
    chart.append(line);
  });
  const cursor = svg("line", { x1: 0, x2: 0, y1: 0, y2: H, stroke: "#000", "stroke-width": 1, class: "cursor" });
  chart.append(cursor);
  cursors.push(cursor);
  const legend = document.createElement("div");
  legend.className = "legend";
  series.forEach((s, i) => {
    const span = document.createElement("span");
    span.style.color = COLORS[i % COLORS.length];
    span.textContent = s.name;
    legend.append(span);
  });
  box.append(h, chart, legend);
  document.getElementById("plots").append(box);
}

function moveCursor(t) {
  const x = (W * t / duration).toFixed(1);
  for (const c of cursors) { c.setAttribute("x1", x); c.setAttribute("x2", x); }
  const k = Math.max(0, Math.min(frames.length - 1, Math.round(t * frames.fps)));
  for (const d of depths) {
    if (d.dataset.frame !== String(k)) { d.dataset.frame = String(k); d.src = `${d.dataset.base}/${k}`; }
  }
  const slider = document.getElementById("frame");
  if (slider) slider.value = String(k);
}

// frame k by hand: seeks the leading video when there is one, else moves the cursor (pictures, masks, depth, plots)
function frameSlider(leader) {
  const slider = document.createElement("input");
  Object.assign(slider, { type: "range", id: "frame", min: "0", max: String(frames.length - 1), value: "0" });
  slider.addEventListener("input", () => {
    const t = Number(slider.value) / frames.fps;
    if (leader !== null) leader.video.currentTime = leader.cam.from + t;
    else moveCursor(t);
  });
  const label = document.createElement("label");
  label.append("frame ", slider);
  document.getElementById("cameras").before(label);
}

function depth(cam) {
  still(cam, `/d/${ds}/depth/${ep}/${cam.url.split("/").pop()}`, `${cam.key} (depth, ${cam.depth}; near bright, far dark)`, "depth");
}

function picture(cam) {
  const what = cam.kind === "mask" ? "segmentation mask: one colour per object, background black" : "image frames";
  still(cam, `/d/${ds}/picture/${ep}/${cam.picture}`, `${cam.key} (${what})`, cam.kind);
}

// a frame drawn on the server (depth, pictures, masks): an <img> the cursor moves to frame k
function still(cam, base, text, kind) {
  const figure = document.createElement("figure");
  const caption = document.createElement("figcaption");
  caption.textContent = text;
  const img = document.createElement("img");
  img.className = kind;
  img.dataset.camera = cam.key;
  img.dataset.base = base;
  img.dataset.frame = "0";
  img.src = `${img.dataset.base}/0`;
  depths.push(img);
  figure.append(img, caption);
  document.getElementById("cameras").append(figure);
}

function camera(cam, leader) {
  const figure = document.createElement("figure");
  const caption = document.createElement("figcaption");
  caption.textContent = cam.key;
  const video = document.createElement("video");
  video.controls = leader === null;
  video.muted = true;
  video.preload = "auto";
  video.dataset.camera = cam.key;
  video.dataset.from = cam.from;
  video.dataset.to = cam.to;
  video.src = `/d/${ds}/video/${ep}/${cam.url.split("/").pop()}#t=${cam.from},${cam.to}`;
  video.addEventListener("loadedmetadata", () => { video.currentTime = cam.from; });
  if (leader === null) {
    video.addEventListener("timeupdate", () => {
      if (video.currentTime >= cam.to) video.pause();
      moveCursor(Math.max(0, video.currentTime - cam.from));
    });
  } else {  // follow the leading camera: same offset into the episode
    const follow = () => {
      video.currentTime = cam.from + (leader.video.currentTime - leader.cam.from);
    };
    leader.video.addEventListener("seeked", follow);
    leader.video.addEventListener("play", () => { follow(); video.play(); });
    leader.video.addEventListener("pause", () => { video.pause(); follow(); });
  }
  figure.append(video, caption);
  document.getElementById("cameras").append(figure);
  return { video, cam };
}

// a deeper look in rerun: the command that serves this episode in its web viewer, and a link to the viewer when
// `browse --rerun-url` named one (it shows the episode its `view --serve` was started for)
function rerun(r) {
  const div = document.getElementById("rerun");
  if (r.url) {
    const a = document.createElement("a");
    a.href = r.url;
    a.target = "_blank";
    a.rel = "noopener";
    a.textContent = "open in rerun's web viewer";
    div.append(a);
  }
  const pre = document.createElement("pre");
  pre.textContent = r.command;
  div.append(pre);
}

async function main() {
  const info = await (await fetch(`/api/d/${ds}/episode/${ep}`)).json();
  document.getElementById("back").href = `/d/${ds}/`;
  document.getElementById("title").textContent = `${info.dataset}: episode ${info.episode_index}`;
  document.getElementById("task").textContent = info.tasks.join(" / ");
  const success = info.success === null ? "unknown" : String(info.success);
  document.getElementById("facts").textContent =
    `${info.length} frames at ${info.fps} fps; success: ${success}` + (info.seed === null ? "" : `; seed ${info.seed}`);
  const results = Object.entries(info.results).map(([k, v]) => `${k} ${v === null ? "–" : v}`);
  document.getElementById("results").textContent = results.join("; ");
  rerun(info.rerun);
  duration = Math.max((info.length - 1) / info.fps, 1e-6);  // frame k is at k / fps: the last at the right edge
  let leader = null;
  frames = { fps: info.fps, length: info.length };
  for (const cam of info.cameras) {
    if (cam.depth) { depth(cam); continue; }
    if (cam.picture !== undefined) { picture(cam); continue; }
    const shown = camera(cam, leader);
    if (leader === null) leader = shown;
  }
  frameSlider(leader);
  const data = await (await fetch(`/api/d/${ds}/episode/${ep}/series`)).json();
  const features = [...new Set(data.series.map((s) => s.feature))];
  for (const f of features) plot(f, data.series.filter((s) => s.feature === f), data.timestamps);
  document.body.dataset.ready = "1";
}
main();
