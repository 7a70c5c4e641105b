"use strict";
// The time controls: a slider over the whole run, play/pause at a chosen speed, and the incidents
// strip below it, one row per kind of incident, each mark a click away (the nearest one is jumped to).

const SPEEDS = [0.5, 1, 2, 5, 10, 30, 60, 120, 300, 600];

class Timeline {
  constructor(elements, data, onSeek, onIncident) {
    this.el = elements;
    this.data = data;
    this.onSeek = onSeek;
    this.onIncident = onIncident;
    this.t = 0;
    this.playing = false;
    this.speed = 10;
    this.follow = false;  // a live page: playing goes on past the end as the run grows
    this.strip = document.createElement("canvas");
    this.kindsOf(data);
    for (const s of SPEEDS) {
      const o = document.createElement("option");
      o.value = String(s); o.textContent = `${s}×`;
      elements.speed.appendChild(o);
    }
    elements.speed.value = String(this.speed);
    elements.speed.addEventListener("change", () => { this.speed = Number(elements.speed.value); });
    elements.slider.max = String(data.end);
    elements.slider.step = "any";
    elements.slider.addEventListener("input", () => this.onSeek(Number(elements.slider.value)));
    elements.play.addEventListener("click", () => this.toggle());
    elements.strip.addEventListener("click", (e) => this.click(e.offsetX, e.offsetY));
    elements.end.textContent = formatTime(data.end);
    this.resize();
  }

  kindsOf(data) {
    const present = data.col["incidents.kind"];
    this.kinds = data.incidentKinds.filter((k, n) => present.includes(n));
    this.rowOf = new Map(this.kinds.map((k, r) => [data.incidentKinds.indexOf(k), r]));
  }

  // The run's data grew (a live page).
  setData(data) {
    this.data = data;
    this.kindsOf(data);
    this.el.slider.max = String(data.end);
    this.el.end.textContent = formatTime(data.end);
    this.resize();
  }

  toggle() {
    this.playing = !this.playing;
    if (this.playing && this.t >= this.data.end) this.onSeek(0);
    this.el.play.textContent = this.playing ? "❚❚ pause" : "▶ play";
    this.el.play.setAttribute("aria-pressed", String(this.playing));
    if (this.playing) {
      let last = performance.now();
      const step = (now) => {
        if (!this.playing) return;
        const next = Math.min(this.data.end, this.t + (now - last) / 1000 * this.speed);  // a live run: waits at its end
        last = now;
        this.onSeek(next);
        if (next >= this.data.end && !this.follow) { this.toggle(); return; }
        requestAnimationFrame(step);
      };
      requestAnimationFrame(step);
    }
  }

  rowHeight() { return this.kinds.length ? Math.min(14, Math.max(8, 70 / this.kinds.length)) : 0; }

  resize() {
    const canvas = this.el.strip, dpr = window.devicePixelRatio || 1;
    const h = Math.max(18, this.kinds.length * this.rowHeight() + 4);
    canvas.style.height = `${h}px`;
    const w = Math.max(1, canvas.clientWidth);
    this.w = w; this.h = h; this.dpr = dpr;
    for (const c of [canvas, this.strip]) { c.width = Math.round(w * dpr); c.height = Math.round(h * dpr); }
    this.drawMarks();
  }

  x(t) { return this.data.end > 0 ? t / this.data.end * (this.w - 1) : 0; }

  drawMarks() {
    const ctx = this.strip.getContext("2d"), c = this.data.col, rh = this.rowHeight();
    ctx.setTransform(this.dpr, 0, 0, this.dpr, 0, 0);
    ctx.fillStyle = "#fafafa"; ctx.fillRect(0, 0, this.w, this.h);
    if (!this.kinds.length) {
      ctx.fillStyle = "#888"; ctx.font = "11px sans-serif"; ctx.textBaseline = "middle";
      ctx.fillText("no incidents", 4, this.h / 2);
      return;
    }
    const times = c["incidents.t"], kinds = c["incidents.kind"];
    for (let k = 0; k < times.length; k++) {
      const row = this.rowOf.get(kinds[k]);
      ctx.fillStyle = this.data.incidentKinds[kinds[k]].colour;
      ctx.fillRect(Math.round(this.x(times[k])) - 1, 2 + row * rh, 2, rh - 2);
    }
  }

  setTime(t) {
    this.t = t;
    this.el.slider.value = String(t);
    this.el.time.textContent = formatTime(t);
    const ctx = this.el.strip.getContext("2d");
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.drawImage(this.strip, 0, 0);
    ctx.setTransform(this.dpr, 0, 0, this.dpr, 0, 0);
    ctx.fillStyle = "#000";
    ctx.fillRect(Math.round(this.x(t)) - 0.5, 0, 1, this.h);
  }

  // The incident nearest to a click on the strip (within 6 pixels, in the clicked row if it has one).
  click(px, py) {
    const c = this.data.col, times = c["incidents.t"], kinds = c["incidents.kind"];
    const row = Math.floor((py - 2) / this.rowHeight());
    let best = -1, bestD = 6;
    const t = px / Math.max(1, this.w - 1) * this.data.end;
    const from = upperBound(times, t - 6 / this.w * this.data.end);
    for (let k = Math.max(0, from - 1); k < times.length && this.x(times[k]) <= px + 6; k++) {
      if (this.rowOf.get(kinds[k]) !== row && this.kinds.length > 1) continue;
      const d = Math.abs(this.x(times[k]) - px);
      if (d <= bestD) { best = k; bestD = d; }
    }
    if (best >= 0) this.onIncident(best); else this.onSeek(Math.min(this.data.end, Math.max(0, t)));
  }
}
