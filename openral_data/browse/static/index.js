"use strict";
fetch("/api/datasets").then((r) => r.json()).then((list) => {
  const ul = document.getElementById("datasets");
  list.forEach((d, i) => {
    const li = document.createElement("li");
    const a = document.createElement("a");
    a.href = `/d/${i}/`;
    a.textContent = d.label;
    li.append(a, ` — ${d.episodes} episodes, ${d.fps} fps, ${d.path}`);
    ul.append(li);
  });
});
