"use strict";
// One episode. Each camera's mp4 is shared by many episodes: the page plays only the episode's span of it (from
// its from/to timestamps: the player's own controls, which show the whole file, are replaced by ours, and playback
// pauses on the episode's last frame), the first camera leading the others. A frame slider with a counter, the
// quality spans on a timeline under it and on the plots (plot.js), previous/next episode (under the table's
// --where when the page was opened from a filtered table), and keys: ←/→ a frame, space play/pause.
const parts = location.pathname.split("/");
const ds = parts[2];
const ep = Number(parts[4]);
const where = new URLSearchParams(location.search).get("where") || "";
const plots = [];
const stills = [];  // depth cameras, pictures, masks: an <img> of the frame at the cursor (drawn on the server)
const frames = { fps: 1, length: 1 };
let leader = null;  // {video, cam}: the camera the others follow
let current = 0;

function el(tag, attrs, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) {
    if (k === "class") e.className = v; else if (k in e) e[k] = v; else e.setAttribute(k, v);
  }
  e.append(...children);
  return e;
}

function clamp(k) { return Math.max(0, Math.min(frames.length - 1, k)); }
function frameOf(video, cam) { return clamp(Math.round((video.currentTime - cam.from) * frames.fps)); }
function query() { return where ? `?${new URLSearchParams({ where })}` : ""; }

// the page at frame k: cursor, slider, counter, stills
function show(k) {
  current = k;
  for (const p of plots) p.move(k);
  for (const d of stills) {
    if (d.dataset.frame !== String(k)) { d.dataset.frame = String(k); d.src = `${d.dataset.base}/${k}`; }
  }
  document.getElementById("frame").value = String(k);
  const t = (k / frames.fps).toFixed(2);
  document.getElementById("counter").textContent = `frame ${k} / ${frames.length - 1} · ${t} s`;
  const marker = document.getElementById("timeline-cursor");
  if (marker) { marker.setAttribute("x1", String(xOnTimeline(k))); marker.setAttribute("x2", String(xOnTimeline(k))); }
}

// go to frame k: the leading video seeks there (the others follow it), or, without a video, the page moves
function seek(k) {
  k = clamp(k);
  if (leader === null) { show(k); return; }
  leader.video.pause();
  leader.video.currentTime = leader.cam.from + k / frames.fps;
  show(k);
}

function camera(cam) {
  const video = el("video", { muted: true, preload: "auto", playsInline: true });
  video.dataset.camera = cam.key;
  video.dataset.from = cam.from;
  video.dataset.to = cam.to;
  video.src = `/d/${ds}/video/${ep}/${cam.url.split("/").pop()}#t=${cam.from},${cam.to}`;
  video.addEventListener("loadedmetadata", () => { video.currentTime = cam.from; });
  const figure = el("figure", { class: "cam" }, video, el("figcaption", {}, cam.key));
  document.getElementById("cameras").append(figure);
  if (leader === null) { leader = { video, cam }; lead(video, cam); return; }
  const follow = () => { video.currentTime = cam.from + (leader.video.currentTime - leader.cam.from); };
  leader.video.addEventListener("seeked", follow);
  leader.video.addEventListener("play", () => { follow(); video.play(); });
  leader.video.addEventListener("pause", () => { video.pause(); follow(); });
}

// the leading video: never past the episode's last frame (checked at every frame shown while playing)
function lead(video, cam) {
  const last = cam.from + (frames.length - 1) / frames.fps;
  const stopAtEnd = () => {
    if (video.currentTime < last + 0.5 / frames.fps) return false;
    video.pause();
    if (Math.abs(video.currentTime - last) > 1e-4) video.currentTime = last;
    return true;
  };
  const watch = () => {
    if (!stopAtEnd()) show(frameOf(video, cam));
    if (!video.paused && video.requestVideoFrameCallback) video.requestVideoFrameCallback(watch);
  };
  video.addEventListener("play", () => {
    if (frameOf(video, cam) >= frames.length - 1) video.currentTime = cam.from;  // at the end: from the start again
    if (video.requestVideoFrameCallback) video.requestVideoFrameCallback(watch);
    document.getElementById("play").textContent = "❚❚ pause";
  });
  video.addEventListener("pause", () => { document.getElementById("play").textContent = "▶ play"; });
  video.addEventListener("timeupdate", () => { if (!stopAtEnd()) show(frameOf(video, cam)); });
  video.addEventListener("seeked", () => show(frameOf(video, cam)));
}

function still(base, key, text, kind) {
  const img = el("img", { class: kind, alt: text });
  Object.assign(img.dataset, { camera: key, base, frame: "0" });
  img.src = `${base}/0`;
  stills.push(img);
  document.getElementById("cameras").append(el("figure", { class: "cam" }, img, el("figcaption", {}, text)));
}

function xOnTimeline(k) { return frames.length > 1 ? 1000 * k / (frames.length - 1) : 0; }

// the slider with its counter, play/pause, and the quality spans on a strip under it
function transport(spans) {
  const slider = el("input", { type: "range", id: "frame", min: "0", max: String(frames.length - 1), value: "0" });
  slider.setAttribute("aria-label", "frame");
  slider.addEventListener("input", () => seek(Number(slider.value)));
  const play = el("button", { id: "play", type: "button", disabled: leader === null }, "▶ play");
  play.addEventListener("click", () => { if (leader.video.paused) leader.video.play(); else leader.video.pause(); });
  const strip = document.createElementNS(SVG_NS, "svg");
  for (const [k, v] of Object.entries({ id: "timeline", viewBox: "0 0 1000 12", preserveAspectRatio: "none" })) {
    strip.setAttribute(k, v);
  }
  for (const s of spans) {
    const a = Math.max(0, xOnTimeline(s.start_frame - 0.5)), b = Math.min(1000, xOnTimeline(s.end_frame + 0.5));
    const rect = svgEl("rect", { class: `span check-${s.check}`, x: a, y: 0, width: Math.max(4, b - a), height: 12,
      "data-check": s.check });
    const title = svgEl("title");
    title.textContent = spanText(s);
    rect.append(title);
    strip.append(rect);
  }
  strip.append(svgEl("line", { id: "timeline-cursor", x1: 0, x2: 0, y1: 0, y2: 12 }));
  document.getElementById("transport").append(
    el("div", { class: "controls" }, play, el("span", { id: "counter", class: "counter" })), slider, strip);
}

function findings(q) {
  const list = document.getElementById("findings");
  if (!q.computed) {
    list.append(el("li", { class: "muted" }, "no quality table cached: `openral-data quality DATASET` computes it"));
    return;
  }
  document.getElementById("flags").replaceChildren(...(q.flags.length ? q.flags.map((f) =>
    el("span", { class: `badge bad check-${f}` }, f)) : [el("span", { class: "badge good" }, "no quality flag")]));
  for (const s of q.spans) {
    const go = el("button", { type: "button", class: `finding check-${s.check}` }, spanText(s));
    go.addEventListener("click", () => seek(s.start_frame));
    list.append(el("li", {}, go));
  }
}

function header(info, near) {
  document.getElementById("back").href = `/d/${ds}/${query()}`;
  document.getElementById("back").textContent = `${info.dataset}: episodes${where ? " (filtered)" : ""}`;
  document.title = `${info.dataset} · episode ${info.episode_index}`;
  document.getElementById("title").textContent = `episode ${info.episode_index}`;
  for (const side of ["previous", "next"]) {
    const link = document.getElementById(side);
    const to = near[side];
    if (to === null) { link.removeAttribute("href"); link.classList.add("disabled"); continue; }
    link.href = `/d/${ds}/episode/${to}${query()}`;
    link.dataset.episode = String(to);
    link.textContent = side === "previous" ? `← episode ${to}` : `episode ${to} →`;
  }
  document.getElementById("task").textContent = info.tasks.join(" / ");
  const ok = info.success === null ? ["unknown", ""] : info.success ? ["success", "good"] : ["failure", "bad"];
  const facts = [el("span", { class: `badge ${ok[1]}` }, ok[0]), el("span", { class: "badge" }, `${info.length} frames`),
    el("span", { class: "badge" }, `${info.fps} fps`)];
  if (info.seed !== null) facts.push(el("span", { class: "badge" }, `seed ${info.seed}`));
  document.getElementById("facts").replaceChildren(...facts);
  const results = Object.entries(info.results).map(([k, v]) => `${k} ${v === null ? "–" : v}`);
  document.getElementById("results").textContent = results.join("; ");
  rerun(info.rerun);
}

// a deeper look in rerun: the command that serves this episode in its web viewer, and a link to the viewer when
// `browse --rerun-url` named one (it shows the episode its `view --serve` was started for)
function rerun(r) {
  const div = document.getElementById("rerun");
  if (r.url) div.append(el("a", { href: r.url, target: "_blank", rel: "noopener" }, "open in rerun's web viewer"));
  div.append(el("pre", {}, r.command));
}

function keys(event) {
  if (event.target instanceof HTMLInputElement && event.target.type !== "range") return;
  if (event.target instanceof HTMLSelectElement || event.target instanceof HTMLButtonElement) return;
  if (event.key === "ArrowRight" || event.key === "ArrowLeft") {
    event.preventDefault();
    seek(current + (event.key === "ArrowRight" ? 1 : -1));
  } else if (event.key === " " && leader !== null) {
    event.preventDefault();
    if (leader.video.paused) leader.video.play(); else leader.video.pause();
  }
}

async function main() {
  const api = `/api/d/${ds}/episode/${ep}`;
  const [info, data, near, q] = await Promise.all([api, `${api}/series`, `${api}/neighbours${query()}`,
    `${api}/quality`].map((u) => fetch(u).then((r) => r.json())));
  frames.fps = info.fps;
  frames.length = info.length;
  header(info, near);
  for (const cam of info.cameras) {
    if (cam.depth) {
      const number = cam.url.split("/").pop();
      still(`/d/${ds}/depth/${ep}/${number}`, cam.key, `${cam.key} (depth, ${cam.depth}; near bright, far dark)`, "depth");
    } else if (cam.picture !== undefined) {
      const what = cam.kind === "mask" ? "segmentation mask: one colour per object, background black" : "image frames";
      still(`/d/${ds}/picture/${ep}/${cam.picture}`, cam.key, `${cam.key} (${what})`, cam.kind);
    } else {
      camera(cam);
    }
  }
  transport(q.spans);
  findings(q);
  const features = [...new Set(data.series.map((s) => s.feature))];
  for (const f of features) {
    const mine = q.spans.filter((s) => s.subject === "episode" || s.subject.startsWith(`${f}[`));
    const p = new Plot(f, data.series.filter((s) => s.feature === f), frames.length, mine, seek);
    document.getElementById("plots").append(p.box);
    plots.push(p);
    p.draw();
  }
  show(0);
  let resized = null;
  window.addEventListener("resize", () => {
    clearTimeout(resized);
    resized = setTimeout(() => plots.forEach((p) => p.draw()), 150);
  });
  document.addEventListener("keydown", keys);
  document.body.dataset.ready = "1";
}
main();
