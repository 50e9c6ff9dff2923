// What both live pages share (the walk's and the emulator's panel): the event stream and the
// mirror of the server's model, a render on the next frame after news, and small SVG helpers.
// Hand-written, no library: the pages load nothing from the network.
"use strict";

const Live = (() => {
  const SVG = "http://www.w3.org/2000/svg";

  /** An element (SVG when svg is true) with attributes, appended to parent if given. */
  function el(tag, attrs = {}, parent = null, svg = true) {
    const e = svg ? document.createElementNS(SVG, tag) : document.createElement(tag);
    for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
    if (parent) parent.appendChild(e);
    return e;
  }

  /** Set an element's text if it changed (by id, or the element). */
  function text(idOrEl, value) {
    const e = typeof idOrEl === "string" ? document.getElementById(idOrEl) : idOrEl;
    if (e && e.textContent !== String(value)) e.textContent = value;
    return e;
  }

  function fmt(v, digits = 2) {
    return v === null || v === undefined || Number.isNaN(v) ? "–" : Number(v).toFixed(digits);
  }

  /** A step of 1, 2 or 5 × 10^k giving about `count` lines over `span`. */
  function niceStep(span, count = 6) {
    const raw = Math.max(span, 1e-9) / count;
    const p = Math.pow(10, Math.floor(Math.log10(raw)));
    const m = raw / p;
    return (m < 1.5 ? 1 : m < 3.5 ? 2 : m < 7.5 ? 5 : 10) * p;
  }

  /** Bounds {x0, x1, y0, y1} of points [[x, y], …] widened by `pad` of their size, at least `min`. */
  function bounds(points, pad = 0.08, min = 4) {
    let x0 = Infinity, x1 = -Infinity, y0 = Infinity, y1 = -Infinity;
    for (const [x, y] of points) {
      if (x === null || y === null) continue;
      if (x < x0) x0 = x;
      if (x > x1) x1 = x;
      if (y < y0) y0 = y;
      if (y > y1) y1 = y;
    }
    if (!Number.isFinite(x0)) { x0 = -min / 2; x1 = min / 2; y0 = -min / 2; y1 = min / 2; }
    const cx = (x0 + x1) / 2, cy = (y0 + y1) / 2;
    const w = Math.max(x1 - x0, min) * (1 + 2 * pad), h = Math.max(y1 - y0, min) * (1 + 2 * pad);
    return {x0: cx - w / 2, x1: cx + w / 2, y0: cy - h / 2, y1: cy + h / 2};
  }

  /**
   * A plan view in an <svg>: north up, east to the right, metres; `fit(points)` sets its view to
   * hold them (equal scale), `grid()` redraws a bounded grid with labels, `xy(n, e)` is where a
   * point goes (x = east, y = −north).
   */
  class Plan {
    constructor(svg) {
      this.svg = svg;
      this.grid_g = el("g", {class: "grid"}, svg);
      this.layers = el("g", {}, svg);
      this.view = {x0: -2, x1: 2, y0: -2, y1: 2};
    }
    layer(cls) { return el("g", {class: cls}, this.layers); }
    fit(points) {
      const b = bounds(points.map(([n, e]) => [e, -n]));
      this.view = b;
      this.size = Math.max(b.x1 - b.x0, b.y1 - b.y0);
      this.svg.setAttribute("viewBox", `${b.x0} ${b.y0} ${b.x1 - b.x0} ${b.y1 - b.y0}`);
    }
    grid() {
      const g = this.grid_g, v = this.view;
      while (g.firstChild) g.removeChild(g.firstChild);
      const step = niceStep(Math.max(v.x1 - v.x0, v.y1 - v.y0), 8);
      const font = this.size / 50;
      const every = Math.max(1, Math.ceil((4.5 * font) / step));  // labels that do not run together
      const label = (x, y, value, anchor) => {
        const t = el("text", {x, y, "font-size": font, "text-anchor": anchor}, g);
        t.textContent = `${+value.toFixed(6)}`;
      };
      for (let i = Math.ceil(v.x0 / step); i * step <= v.x1; i++) {
        const x = i * step;
        el("line", {x1: x, x2: x, y1: v.y0, y2: v.y1, class: i === 0 ? "axis" : ""}, g);
        if (i % every === 0 && x > v.x0 + 2 * font) label(x, v.y1 - font * 0.4, x, "middle");
      }
      for (let i = Math.ceil(v.y0 / step); i * step <= v.y1; i++) {
        const y = i * step;
        el("line", {y1: y, y2: y, x1: v.x0, x2: v.x1, class: i === 0 ? "axis" : ""}, g);
        if (i % every === 0 && y < v.y1 - 1.8 * font && y > v.y0 + font) label(v.x0 + font * 0.3, y - font * 0.3, -y, "start");
      }
      const corner = el("text", {x: v.x1 - font * 0.4, y: v.y0 + font * 1.2, "font-size": font, "text-anchor": "end"}, g);
      corner.textContent = `grid ${+step.toFixed(6)} m · north ↑ east →`;
    }
  }

  /** Points [[x, y], …] as a polyline's `points` attribute. */
  function polyline(points) {
    let s = "";
    for (const [x, y] of points) if (x !== null && y !== null) s += `${x},${y} `;
    return s;
  }

  /** Dots at points [[x, y], …] as one path (zero-length segments drawn with round caps). */
  function dots(points) {
    let s = "";
    for (const [x, y] of points) if (x !== null && y !== null) s += `M${x} ${y}h0`;
    return s;
  }

  /**
   * Connect to the server's events and mirror its model; `render(mirror)` runs once per animation
   * frame after news (bursts share one). The mirror holds `series`, `values`, `seq`, `connected`,
   * the latencies of the steps drawn (`latencies`, bounded), `renders` and `drawnSeq`, the `seq` the
   * page last drew (the mirror may hold newer news than the page shows until the next render: a
   * test of what is drawn waits for `drawnSeq === seq`). Each render dispatches a "live-rendered"
   * event on document.
   */
  function start(render, {onConnection = () => {}} = {}) {
    const mirror = {series: {}, values: {}, seq: -1, connected: false, renders: 0, drawnSeq: null,
                    latencies: [], pendingArrivals: []};
    let scheduled = false;
    const draw = () => {
      if (!scheduled) return;  // drawn already (by the frame or by the timer, whichever came first)
      scheduled = false;
      render(mirror);
      mirror.drawnSeq = mirror.seq;
      mirror.renders += 1;
      const now = Date.now() / 1000;
      for (const t of mirror.pendingArrivals) mirror.latencies.push(now - t);
      if (mirror.latencies.length > 5000) mirror.latencies.splice(0, mirror.latencies.length - 5000);
      mirror.pendingArrivals = [];
      document.dispatchEvent(new CustomEvent("live-rendered", {detail: {seq: mirror.seq}}));
    };
    const schedule = () => {
      if (scheduled) return;
      scheduled = true;
      // a hidden or covered page gets no animation frames: a timer draws it then (a background tab's
      // timers are slowed, never stopped)
      if (document.visibilityState !== "hidden") requestAnimationFrame(draw);
      setTimeout(draw, document.visibilityState === "hidden" ? 50 : 250);
    };
    const apply = (msg) => {
      if (msg.reset) {
        mirror.series = msg.series || {};
        mirror.values = msg.values || {};
      } else {
        for (const [k, pts] of Object.entries(msg.series || {})) mirror.series[k] = pts;
        for (const [k, pts] of Object.entries(msg.append || {})) {
          const s = mirror.series[k] || (mirror.series[k] = []);
          for (const p of pts) s.push(p);
        }
        Object.assign(mirror.values, msg.values || {});
        const arrivals = (msg.transient || {}).arrivals;
        if (arrivals) for (const t of arrivals) mirror.pendingArrivals.push(t);
      }
      mirror.seq = msg.seq;
      schedule();
    };
    const source = new EventSource("events");
    source.onmessage = (e) => apply(JSON.parse(e.data));
    source.onopen = () => { mirror.connected = true; onConnection(true); schedule(); };
    source.onerror = () => { mirror.connected = false; onConnection(false); schedule(); };
    window.liveMirror = mirror;
    return mirror;
  }

  /** Resolve once `test()` is true, tested now and after each render (for tests and scripts). */
  function when(test) {
    return new Promise((resolve) => {
      const check = () => {
        let v;
        try { v = test(); } catch (e) { v = false; }
        if (v) { document.removeEventListener("live-rendered", check); resolve(v); }
      };
      document.addEventListener("live-rendered", check);
      check();
    });
  }

  return {SVG, el, text, fmt, niceStep, bounds, Plan, polyline, dots, start, when};
})();
