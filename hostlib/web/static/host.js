// The walk's live page: the plan view (track, 1σ ellipses, each foot, GPS fixes, compass readings),
// the height profile, the heading and each link's counters, drawn from the server's model
// (hostlib/web/feed.py says what each series holds). The page holds a bounded number of
// elements: one path or polyline per kind of mark, at most MAX_ELLIPSES ellipses.
"use strict";

(() => {
  const {el, text, fmt, Plan, polyline, dots} = Live;
  const MAX_ELLIPSES = 24;
  const FIX_USED = 3;

  const plan = new Plan(document.getElementById("plan"));
  const ellipseLayer = plan.layer("ellipses");
  const trackLine = el("polyline", {class: "track", id: "track"}, plan.layer(""));
  const feet = {
    left: el("path", {class: "dots foot-left", id: "foot-left"}, plan.layers),
    right: el("path", {class: "dots foot-right", id: "foot-right"}, plan.layers),
  };
  const fixUsed = el("path", {class: "dots fix-used", id: "fixes-used"}, plan.layers);
  const fixOther = el("path", {class: "dots fix-other", id: "fixes-other"}, plan.layers);
  const compassUsed = el("path", {class: "ticks compass-used", id: "compass-used"}, plan.layers);
  const compassRejected = el("path", {class: "ticks compass-rejected", id: "compass-rejected"}, plan.layers);
  const hereHeading = el("line", {class: "here-heading"}, plan.layers);
  const here = el("circle", {class: "here", r: 0.3}, plan.layers);
  const ellipses = [];

  const heightSvg = document.getElementById("height");
  const heightZero = el("line", {class: "zero"}, heightSvg);
  const heightLine = el("polyline", {class: "line", id: "height-line"}, heightSvg);
  const headingSvg = document.getElementById("headings");
  const headingGrid = [];
  const headingPath = el("path", {class: "line", id: "heading-line"}, headingSvg);

  function shownEllipses(track) {
    const n = track.length;
    if (!n) return [];
    const stride = Math.max(1, Math.ceil(n / (MAX_ELLIPSES - 1)));
    const out = [];
    for (let i = 0; i < n - 1; i += stride) out.push(track[i]);
    out.push(track[n - 1]);
    return out.slice(-MAX_ELLIPSES);
  }

  function drawPlan(m) {
    const s = m.series;
    const track = s.track || [];
    const shown = shownEllipses(track);
    const pts = track.map((p) => [p[1], p[2]]);
    for (const side of ["left", "right"]) for (const p of s[side] || []) pts.push([p[1], p[2]]);
    for (const p of s.fixes || []) pts.push([p[0], p[1]]);
    for (const p of shown) {
      pts.push([p[1] + p[5], p[2] + p[5]]);
      pts.push([p[1] - p[5], p[2] - p[5]]);
    }
    plan.fit(pts);
    plan.grid();
    const size = plan.size;

    trackLine.setAttribute("points", polyline(track.map((p) => [p[2], -p[1]])));
    while (ellipses.length < shown.length) ellipses.push(el("ellipse", {}, ellipseLayer));
    ellipses.forEach((e, i) => {
      const p = shown[i];
      if (!p) { e.setAttribute("display", "none"); return; }
      e.removeAttribute("display");
      e.setAttribute("rx", Math.max(p[5], 1e-3));
      e.setAttribute("ry", Math.max(p[6], 1e-3));
      e.setAttribute("transform", `translate(${p[2]},${-p[1]}) rotate(${-p[7]})`);
    });
    for (const side of ["left", "right"]) feet[side].setAttribute("d", dots((s[side] || []).map((p) => [p[2], -p[1]])));
    const fixes = s.fixes || [];
    fixUsed.setAttribute("d", dots(fixes.filter((f) => f[2] === FIX_USED).map((f) => [f[1], -f[0]])));
    fixOther.setAttribute("d", dots(fixes.filter((f) => f[2] !== FIX_USED).map((f) => [f[1], -f[0]])));
    const tick = size * 0.025;
    const ticks = (used) => (s.compass || []).filter((c) => c[3] === used).map((c) => {
      const h = (c[2] * Math.PI) / 180;
      return `M${c[1]} ${-c[0]}l${tick * Math.sin(h)} ${-tick * Math.cos(h)}`;
    }).join("");
    compassUsed.setAttribute("d", ticks(1));
    compassRejected.setAttribute("d", ticks(0));
    const last = track[track.length - 1];
    if (last) {
      const h = (last[4] * Math.PI) / 180, r = size * 0.008;
      here.setAttribute("cx", last[2]);
      here.setAttribute("cy", -last[1]);
      here.setAttribute("r", r);
      hereHeading.setAttribute("x1", last[2]);
      hereHeading.setAttribute("y1", -last[1]);
      hereHeading.setAttribute("x2", last[2] + 4 * r * Math.sin(h));
      hereHeading.setAttribute("y2", -last[1] - 4 * r * Math.cos(h));
    }
    text("plan-note", `· ${track.length} points${(s.compass || []).length ? `, ${(s.compass || []).length} compass readings` : ""}`);
  }

  function drawProfiles(m) {
    const track = m.series.track || [];
    // height over distance
    const d1 = Math.max(1, ...track.map((p) => p[8]));
    const hs = track.map((p) => p[3]);
    let h0 = Math.min(0, ...hs), h1 = Math.max(0, ...hs);
    if (h1 - h0 < 0.2) { const c = (h0 + h1) / 2; h0 = c - 0.1; h1 = c + 0.1; }
    const pad = (h1 - h0) * 0.1;
    heightSvg.setAttribute("viewBox", `0 ${-(h1 + pad)} ${d1} ${h1 - h0 + 2 * pad}`);
    heightZero.setAttribute("x1", 0); heightZero.setAttribute("x2", d1);
    heightZero.setAttribute("y1", 0); heightZero.setAttribute("y2", 0);
    heightLine.setAttribute("points", polyline(track.map((p) => [p[8], -p[3]])));
    text("height-range", hs.length ? `${fmt(Math.min(...hs))} … ${fmt(Math.max(...hs))} m over ${fmt(d1, 1)} m` : "");
    // heading over the steps, unwrapped (a turn is a climb, not a jump at north)
    const k1 = Math.max(1, track.length ? track[track.length - 1][0] : 1);
    const unwrapped = [];
    let prev = null, turns = 0;
    for (const p of track) {
      if (prev !== null) turns += Math.round((prev - p[4]) / 360);
      unwrapped.push([p[0], p[4] + 360 * turns]);
      prev = p[4];
    }
    const ds = unwrapped.map((p) => p[1]);
    let a0 = Math.min(0, ...ds), a1 = Math.max(90, ...ds);
    a0 = Math.floor(a0 / 90) * 90; a1 = Math.ceil(a1 / 90) * 90;
    headingSvg.setAttribute("viewBox", `0 ${-a1 - 5} ${k1} ${a1 - a0 + 10}`);
    while (headingGrid.length < Math.min((a1 - a0) / 90 + 1, 40)) {
      headingGrid.push(headingSvg.insertBefore(el("line", {class: "zero"}), headingPath));
    }
    headingGrid.forEach((g, i) => {
      const deg = a0 + 90 * i;
      if (deg > a1) { g.setAttribute("display", "none"); return; }
      g.removeAttribute("display");
      g.setAttribute("x1", 0); g.setAttribute("x2", k1); g.setAttribute("y1", -deg); g.setAttribute("y2", -deg);
    });
    headingPath.setAttribute("d", unwrapped.map(([k, deg], i) => `${i ? "L" : "M"}${k} ${-deg}`).join(""));
    text("headings-range", track.length ? `${fmt(Math.min(...ds), 0)} … ${fmt(Math.max(...ds), 0)}° unwrapped, grid 90°, over ${k1} steps` : "");
  }

  function drawLinks(m) {
    const links = m.values.links || [];
    const body = document.querySelector("#links tbody");
    while (body.rows.length > links.length) body.deleteRow(-1);
    links.forEach((l, i) => {
      let row = body.rows[i];
      if (!row) {
        row = body.insertRow();
        row.id = `link-${i}`;
        for (const f of ["name", "state", "packets", "step_packets", "steps", "gaps", "garbage", "distance"]) {
          const c = row.insertCell();
          c.dataset.field = f;
        }
      }
      const cell = (f) => row.querySelector(`[data-field="${f}"]`);
      const port = l.name.split("/").pop();
      text(cell("name"), l.side ? `${l.side} · ${port}` : port);
      cell("name").title = l.name;
      const state = l.failed ? "failed" : l.up ? "up" : "down";
      text(cell("state"), state);
      cell("state").className = state === "up" ? "up" : "down";
      cell("state").title = l.failed || (l.link_drops ? `${l.link_drops} link drops` : "");
      text(cell("packets"), l.packets);
      text(cell("step_packets"), l.step_packets);
      text(cell("steps"), l.steps);
      text(cell("gaps"), `${l.gaps} (${l.missing})`);
      cell("gaps").dataset.gaps = l.gaps;
      cell("gaps").className = l.gaps ? "alert" : "";
      text(cell("garbage"), `${l.garbage} B`);
      cell("garbage").className = l.garbage ? "alert" : "";
      text(cell("distance"), fmt(l.distance, 1));
    });
  }

  function drawHeading(m) {
    const b = m.values.body;
    if (!b) return;
    document.getElementById("needle").setAttribute("transform", `rotate(${b.heading})`);
    text("heading", `${fmt(b.heading, 1)}°`);
    text("position", `north ${fmt(b.north)} m · east ${fmt(b.east)} m · height ${fmt(b.height)} m`);
    text("sigma", `1σ ${fmt(b.sigma, 3)} m after ${b.steps} steps`);
  }

  function drawAids(m) {
    const a = m.values.aids;
    const rows = [];
    if (!a) {
      rows.push(["aids", "none (track --fusion --compass / --gps)"]);
    } else {
      if (a.compass) {
        rows.push(["compass used", a.compass_updates]);
        rows.push(["compass rejected: gate / field", `${a.compass_rejected} / ${a.compass_field_rejected}`]);
        rows.push(["compass skipped / refused", `${a.compass_skipped} / ${a.compass_refused}`]);
      }
      if (a.gps) {
        rows.push(["GPS updates", a.gps_updates]);
        rows.push(["GPS between updates / before alignment", `${a.gps_skipped} / ${a.gps_before_alignment}`]);
      }
      if (a.receiver) {
        const r = a.receiver;
        rows.push(["receiver fixes", `${r.fixes} (${r.without_fix} without a fix, ${r.garbled} garbled)`]);
        rows.push(["receiver", r.lost ? `GONE: ${r.lost}` : r.url]);
      }
      rows.push(["declination", `${fmt(a.declination_deg, 2)}°`]);
      text("aligned", a.aligned_by ? `aligned by ${a.aligned_by}` : "not aligned: the module's frame");
    }
    const body = document.querySelector("#aids tbody");
    while (body.rows.length > rows.length) body.deleteRow(-1);
    rows.forEach(([k, v], i) => {
      const row = body.rows[i] || body.insertRow();
      if (!row.cells.length) { row.insertCell(); row.insertCell(); }
      text(row.cells[0], k);
      text(row.cells[1], v);
      row.cells[1].className = k === "compass rejected" && v ? "alert" : "";
    });
  }

  function drawHeader(m) {
    const v = m.values;
    text("title", v.title || "");
    const state = document.getElementById("state");
    text(state, v.state || "–");
    state.className = `pill ${v.state === "walking" ? "ok" : v.state === "ended" ? "warn" : ""}`;
    document.querySelectorAll(".feet-only").forEach((e) => { e.style.display = v.mode === "two feet" ? "" : "none"; });
    text("legend-track", v.mode === "two feet" ? "body (fused)" : "track");
  }

  function elapsed(m) {
    const v = m.values;
    if (!v.started) return;
    const s = Math.max(0, Date.now() / 1000 - v.started);
    text("elapsed", `${Math.floor(s / 60)}:${String(Math.floor(s % 60)).padStart(2, "0")}`);
  }

  const mirror = Live.start((m) => {
    drawHeader(m);
    drawPlan(m);
    drawProfiles(m);
    drawLinks(m);
    drawHeading(m);
    drawAids(m);
    elapsed(m);
  }, {
    onConnection: (up) => {
      const c = document.getElementById("connection");
      c.textContent = up ? "live" : "disconnected";
      c.className = `pill ${up ? "ok" : "bad"}`;
    },
  });
  setInterval(() => { if (mirror.values.state === "walking") elapsed(mirror); }, 1000);
})();
