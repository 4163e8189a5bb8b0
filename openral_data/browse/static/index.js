"use strict";
fetch("/api/datasets").then((r) => r.json()).then((list) => {
  const ul = document.getElementById("datasets");
  list.forEach((d, i) => {
    const li = document.createElement("li");
    const a = document.createElement("a");
    a.href = `/d/${i}/`;
    a.textContent = d.label;
    li.append(a, ` — ${d.episodes} episodes, ${d.fps} fps, ${d.path}`);
    if (i > 0) {  // side by side with the first (any pair: /compare?a=I&b=J)
      const c = document.createElement("a");
      c.href = `/compare?a=0&b=${i}`;
      c.className = "compare";
      c.textContent = `compare with ${list[0].label}`;
      li.append(" — ", c);
    }
    ul.append(li);
  });
});
