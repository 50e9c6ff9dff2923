// The emulator's live panel: each served module's state, loop, link and walker (the truth beside
// what the module sent), with buttons for the control channel's faults
// (firmware_sim/app/web/panel.py says what the model holds).
"use strict";

(() => {
  const {el, text, fmt, Plan, polyline} = Live;
  const COLORS = ["var(--left)", "var(--right)", "#7a3fbf", "#1f5fbf", "#b5761a", "#444"];
  const plan = new Plan(document.getElementById("plan"));
  const paths = [];  // per module: {truth, sent, here, there}
  const cards = [];

  function html(tag, attrs, parent, content) {
    const e = el(tag, attrs, parent, false);
    if (content !== undefined) e.textContent = content;
    return e;
  }

  function kv(parent, rows) {
    const box = html("div", {class: "kv"}, parent);
    for (const [label, id] of rows) {
      html("div", {}, box, label);
      html("div", {id}, box, "–");
    }
    return box;
  }

  async function press(i, command, arg) {
    const reply = document.getElementById(`reply-${i}`);
    reply.textContent = `${command}…`;
    try {
      const r = await fetch("control", {
        method: "POST",
        headers: {"Content-Type": "application/json", "X-Live-Control": "1"},
        body: JSON.stringify({module: i, command, arg}),
      });
      const answer = r.ok ? await r.json() : {reply: `${r.status} ${await r.text()}`};
      reply.textContent = answer.reply;
      reply.dataset.ok = answer.ok ? "1" : "0";
    } catch (e) {
      reply.textContent = String(e);
    }
  }

  function card(i, label, control) {
    const box = html("section", {class: "card module", id: `module-${i}`}, document.getElementById("modules"));
    const h = html("h2", {}, box);
    html("span", {style: `color:${COLORS[i % COLORS.length]}`}, h, `● ${label}`);
    html("span", {class: "pill", id: `run-${i}`}, h, "–");
    html("small", {id: `clock-${i}`}, h, "");
    html("div", {class: "muted"}, box, "running process functions");
    html("div", {class: "chips", id: `slots-${i}`}, box);
    const t = html("table", {}, box);
    t.innerHTML = "<thead><tr><th>interface</th><th>outputs on (state/divider)</th><th>mode</th><th>packets</th><th>queue</th><th>port</th></tr></thead><tbody></tbody>";
    t.id = `outputs-${i}`;
    const grid = html("div", {style: "display:grid;grid-template-columns:1fr 1fr 1fr;gap:10px;margin-top:6px"}, box);
    const loop = html("div", {}, grid);
    html("div", {class: "muted"}, loop, "loop");
    kv(loop, [["tick mean / max", `tick-${i}`], ["overruns", `overruns-${i}`], ["lag now / max", `lag-${i}`],
              ["late at a host", `late-${i}`]]);
    const link = html("div", {}, grid);
    html("div", {class: "muted"}, link, "link");
    kv(link, [["state", `link-${i}`], ["disconnects / stalls", `faults-${i}`], ["lost / corrupted", `lost-${i}`],
              ["hosts", `hosts-${i}`]]);
    const walker = html("div", {}, grid);
    html("div", {class: "muted"}, walker, "walker");
    kv(walker, [["true N / E", `true-${i}`], ["sent N / E", `sent-${i}`], ["steps sent", `steps-${i}`],
                ["apart now", `apart-${i}`]]);
    const c = html("div", {class: "controls"}, box);
    const button = (command, input) => {
      const b = html("button", {id: `btn-${i}-${command}`, "data-module": i, "data-command": command}, c, command);
      b.disabled = !control;
      b.addEventListener("click", () => press(i, command, input ? Number(input.value) : undefined));
    };
    button("disconnect");
    button("reconnect");
    const stall = html("input", {id: `arg-${i}-stall`, type: "number", min: "0", step: "0.5", value: "2", title: "seconds"});
    button("stall", stall); c.appendChild(stall); html("span", {class: "muted"}, c, "s");
    const corrupt = html("input", {id: `arg-${i}-corrupt`, type: "number", min: "0", step: "1", value: "20", title: "bytes"});
    button("corrupt", corrupt); c.appendChild(corrupt);
    const drop = html("input", {id: `arg-${i}-drop`, type: "number", min: "0", step: "1", value: "20", title: "bytes"});
    button("drop", drop); c.appendChild(drop);
    html("span", {class: "reply", id: `reply-${i}`}, c, control ? "" : "buttons off (serve --web-control)");
    const color = COLORS[i % COLORS.length];
    paths[i] = {
      truth: el("polyline", {class: "truth-path", id: `truth-${i}`}, plan.layers),
      sent: el("polyline", {class: "sent-path", id: `sent-path-${i}`, style: `stroke:${color}`}, plan.layers),
      there: el("circle", {class: "sent-here", style: `stroke:${color}`}, plan.layers),
      here: el("circle", {class: "truth-here"}, plan.layers),
    };
    const legend = document.getElementById("legend");
    if (!legend.childElementCount) html("span", {}, legend).innerHTML = `<i style="background:#c9ced6;height:7px"></i>the truth`;
    html("span", {}, legend).innerHTML = `<i style="background:${color}"></i>${label}: its steps`;
    return box;
  }

  function drawModule(m, i) {
    const running = m.running && !m.error;
    const run = text(`run-${i}`, m.error ? "failed" : running ? "running" : "stopped");
    run.className = `pill ${m.error ? "bad" : running ? "ok" : "warn"}`;
    run.title = m.error || "";
    text(`clock-${i}`, `t = ${fmt(m.t, 1)} s · ×${fmt(m.ratio, 2)}`);
    const slots = document.getElementById(`slots-${i}`);
    const names = m.slots || [];
    if (slots.dataset.names !== names.join(" ")) {
      slots.dataset.names = names.join(" ");
      slots.replaceChildren(...(names.length ? names : ["(none)"]).map((n) => {
        const chip = html("span", {class: names.length ? "chip" : "chip off"});
        chip.textContent = n;
        return chip;
      }));
    }
    const body = document.querySelector(`#outputs-${i} tbody`);
    const outs = m.outputs || [];
    while (body.rows.length > outs.length) body.deleteRow(-1);
    outs.forEach((o, k) => {
      const row = body.rows[k] || body.insertRow();
      while (row.cells.length < 6) row.insertCell();
      const cond = m.conditional && m.conditional.ifaces.includes(o.iface)
        ? [`on ${m.conditional.flag}: ${m.conditional.states.join(" ")}`] : [];
      const states = [...o.states.map(([, name, d]) => `${name}/${d}`), ...cond].join(" · ") || "none";
      const port = !o.served ? "not served" : o.connected ? "up" : "down";
      [o.iface, states, o.lossless ? "lossless" : "lossy", o.packets, o.queue, port]
        .forEach((v, c) => text(row.cells[c], v));
      row.cells[1].style.whiteSpace = "normal";
      row.cells[5].className = !o.served ? "muted" : o.connected ? "up" : "down";
    });
    text(`tick-${i}`, `${fmt(m.loop_us_mean, 1)} / ${fmt(m.loop_us_max, 0)} µs`);
    const over = text(`overruns-${i}`, m.overruns);
    over.className = m.overruns ? "alert" : "";
    text(`lag-${i}`, `${fmt(m.lag_ms, 1)} / ${fmt(m.lag_max_ms, 1)} ms`);
    text(`late-${i}`, `${m.late_bytes} B`);
    const links = m.links || [];
    const attached = (m.hosts || []).some((h) => h.paired && h.kind !== "gps-pty");
    const state = links.map((l) => `${l.name} ${l.connected ? (l.stalled ? "stalled" : "up") : attached ? "DOWN" : "no host"}`)
      .join(", ") || "–";
    const ls = text(`link-${i}`, state);
    ls.className = links.some((l) => !l.connected || l.stalled) ? "down" : "up";
    ls.dataset.connected = links.every((l) => l.connected) ? "1" : "0";
    text(`faults-${i}`, links.map((l) => `${l.disconnects} / ${l.stalls}`).join(", ") || "–");
    text(`lost-${i}`, links.map((l) => `${l.lost} / ${l.corrupted} B`).join(", ") || "–");
    text(`hosts-${i}`, (m.hosts || []).map((h) => `${h.kind} ${h.paired ? "on" : "off"}`).join(", "));
    const w = m.walker || {};
    text(`true-${i}`, w.truth ? `${fmt(w.truth[0])} / ${fmt(w.truth[1])} m · ${fmt(w.truth[3], 0)}°` : "no truth (a recording)");
    text(`sent-${i}`, w.sent ? `${fmt(w.sent[0])} / ${fmt(w.sent[1])} m` : "–");
    const steps = text(`steps-${i}`, `${w.steps}${w.missed ? ` (${w.missed} not seen)` : ""}`);
    steps.dataset.steps = w.steps;
    text(`apart-${i}`, w.apart === null || w.apart === undefined ? "–" : `${fmt(w.apart)} m`);
  }

  function drawPlan(mirror) {
    const s = mirror.series, modules = mirror.values.modules || [];
    const pts = [];
    modules.forEach((m, i) => {
      for (const p of s[`truth.${i}`] || []) pts.push(p);
      for (const p of s[`sent.${i}`] || []) pts.push(p);
      const w = m.walker || {};
      if (w.truth) pts.push(w.truth);
      if (w.sent) pts.push(w.sent);
    });
    plan.fit(pts);
    plan.grid();
    const r = plan.size * 0.007;
    modules.forEach((m, i) => {
      const p = paths[i];
      if (!p) return;
      p.truth.setAttribute("points", polyline((s[`truth.${i}`] || []).map(([n, e]) => [e, -n])));
      p.sent.setAttribute("points", polyline((s[`sent.${i}`] || []).map(([n, e]) => [e, -n])));
      const w = m.walker || {};
      for (const [c, where] of [[p.here, w.truth], [p.there, w.sent]]) {
        if (!where) { c.setAttribute("display", "none"); continue; }
        c.removeAttribute("display");
        c.setAttribute("cx", where[1]);
        c.setAttribute("cy", -where[0]);
        c.setAttribute("r", r);
      }
    });
  }

  function drawActions(mirror) {
    const acts = mirror.values.actions || [];
    text("actions", acts.length ? "last faults: " + acts.slice(-4).map((a) => `${a.line} → ${a.reply}`).join(" · ") : "");
  }

  Live.start((mirror) => {
    const v = mirror.values, modules = v.modules || [];
    const cs = text("control-state", v.control ? "fault buttons on" : "fault buttons off");
    cs.className = `pill ${v.control ? "warn" : ""}`;
    const labels = v.labels || modules.map((m) => m.label);
    while (cards.length < labels.length) cards.push(card(cards.length, labels[cards.length], v.control));
    modules.forEach(drawModule);
    drawPlan(mirror);
    drawActions(mirror);
    const g = v.gps;
    text("gps", g ? `GPS ${g.paired ? "on" : "off"}: ${g.sentences} sentences, ${g.dropped_sentences} dropped` : "");
  }, {
    onConnection: (up) => {
      const c = document.getElementById("connection");
      c.textContent = up ? "live" : "disconnected";
      c.className = `pill ${up ? "ok" : "bad"}`;
    },
  });
})();
