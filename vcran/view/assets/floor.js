"use strict";
// The floor seen from above on a canvas: motion areas, the roadmap, stations with their parts, the
// highlighted path of a job, and every robot's footprint at the cursor, filled with its task's colour.
// World metres map to canvas pixels as px = ox + x * scale, py = oy - y * scale (y up); drag pans,
// the wheel zooms. The static part (areas, roadmap, station outlines) is drawn once per pan or zoom.

const FLOOR_BACKGROUND = "#ffffff";
const MIN_ROBOT_PX = 4;  // a robot smaller than this on screen is drawn as a dot this wide

class Floor {
  constructor(canvas, data, fleet) {
    this.canvas = canvas;
    this.data = data;
    this.fleet = fleet;
    this.ctx = canvas.getContext("2d");
    this.staticLayer = document.createElement("canvas");
    this.scale = 1; this.ox = 0; this.oy = 0;
    this.drawn = [];
    this.dirty = true;
    this.onChange = () => {};
    this.resize();
    this.fit();
    this.listen();
  }

  // The run's data grew (a live page): the same view of the floor, the static layer redrawn.
  setData(data, fleet) {
    const first = !this.data.geometry && data.geometry;
    this.data = data;
    this.fleet = fleet;
    this.dirty = true;
    if (first) this.fit();
  }

  resize() {
    const dpr = window.devicePixelRatio || 1;
    const w = Math.max(1, this.canvas.clientWidth), h = Math.max(1, this.canvas.clientHeight);
    this.width = w; this.height = h; this.dpr = dpr;
    for (const c of [this.canvas, this.staticLayer]) { c.width = Math.round(w * dpr); c.height = Math.round(h * dpr); }
    this.dirty = true;
  }

  fit() {
    const [x0, y0, x1, y1] = this.fleet.bounds();
    const margin = 1.5;  // metres: room for footprints at the edge
    const w = x1 - x0 + 2 * margin, h = y1 - y0 + 2 * margin;
    this.scale = Math.min(this.width / w, this.height / h);
    this.ox = this.width / 2 - (x0 + x1) / 2 * this.scale;
    this.oy = this.height / 2 + (y0 + y1) / 2 * this.scale;
    this.dirty = true;
  }

  toPixel(x, y) { return [this.ox + x * this.scale, this.oy - y * this.scale]; }
  toWorld(px, py) { return [(px - this.ox) / this.scale, (this.oy - py) / this.scale]; }

  listen() {
    let drag = null;
    this.canvas.addEventListener("mousedown", (e) => { drag = [e.offsetX, e.offsetY, this.ox, this.oy, false]; });
    window.addEventListener("mouseup", () => { if (drag && drag[4]) this.onChange(); drag = null; });
    this.canvas.addEventListener("mousemove", (e) => {
      if (!drag) return;
      const dx = e.offsetX - drag[0], dy = e.offsetY - drag[1];
      if (Math.abs(dx) + Math.abs(dy) > 2) drag[4] = true;
      if (!drag[4]) return;
      this.ox = drag[2] + dx; this.oy = drag[3] + dy;
      this.dirty = true;
      this.onChange();
    });
    this.canvas.addEventListener("wheel", (e) => {
      e.preventDefault();
      const f = Math.exp(-e.deltaY * 0.0015);
      this.ox = e.offsetX - (e.offsetX - this.ox) * f;
      this.oy = e.offsetY - (e.offsetY - this.oy) * f;
      this.scale *= f;
      this.dirty = true;
      this.onChange();
    }, { passive: false });
    this.wasDrag = () => drag !== null && drag[4];
  }

  drawStatic() {
    const ctx = this.staticLayer.getContext("2d");
    ctx.setTransform(this.dpr, 0, 0, this.dpr, 0, 0);
    ctx.fillStyle = FLOOR_BACKGROUND;
    ctx.fillRect(0, 0, this.width, this.height);
    if (!this.data.geometry) {
      ctx.fillStyle = "#888"; ctx.font = "14px sans-serif"; ctx.textAlign = "center";
      ctx.fillText("no fleet to draw: this folder has no trace (see the note above)", this.width / 2, this.height / 2);
    }
    ctx.lineJoin = "round";
    for (const area of this.data.areas) {
      this.polygon(ctx, area.points);
      ctx.fillStyle = "#fff4d6"; ctx.fill();
      ctx.strokeStyle = "#c9a227"; ctx.lineWidth = 1; ctx.stroke();
    }
    const road = this.data.roadmap;
    if (road) {
      ctx.strokeStyle = "#9aa7b8"; ctx.lineWidth = 2;
      for (const [a, b] of road.edges) {
        const p = this.toPixel(...road.nodes[a]), q = this.toPixel(...road.nodes[b]);
        ctx.beginPath(); ctx.moveTo(p[0], p[1]); ctx.lineTo(q[0], q[1]); ctx.stroke();
      }
      ctx.fillStyle = "#6b7a90";
      for (const n of road.nodes) { const p = this.toPixel(n[0], n[1]); ctx.fillRect(p[0] - 2, p[1] - 2, 4, 4); }
    }
    for (const s of this.data.stations) {
      if (s.area.length) {
        this.polygon(ctx, s.area);
      } else {
        const p = this.toPixel(s.x, s.y);
        ctx.beginPath(); ctx.arc(p[0], p[1], Math.max(2, s.reach * this.scale), 0, TAU);
      }
      ctx.fillStyle = s.charger ? "#e2f0d9" : "#f3eee4"; ctx.fill();
      ctx.setLineDash(s.area.length ? [] : [4, 3]);
      ctx.strokeStyle = "#6b5b3e"; ctx.lineWidth = 1; ctx.stroke();
      ctx.setLineDash([]);
    }
    this.dirty = false;
  }

  polygon(ctx, points) {
    ctx.beginPath();
    points.forEach(([x, y], k) => { const p = this.toPixel(x, y); if (k) ctx.lineTo(p[0], p[1]); else ctx.moveTo(p[0], p[1]); });
    ctx.closePath();
  }

  // Draw the floor at t. selection: {robots: Set of indices, paths: [[[x, y, theta], ...], ...]}.
  draw(t, selection) {
    if (this.dirty) this.drawStatic();
    const ctx = this.ctx;
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.drawImage(this.staticLayer, 0, 0);
    ctx.setTransform(this.dpr, 0, 0, this.dpr, 0, 0);
    this.drawParts(ctx, t);
    for (const path of selection.paths) this.drawPath(ctx, path);
    this.drawRobots(ctx, t, selection.robots);
  }

  drawParts(ctx, t) {
    const stations = this.data.stations;
    if (!stations.length) return;
    const labelled = stations.length <= 60 || this.scale > 12;
    ctx.font = "11px sans-serif"; ctx.textAlign = "center"; ctx.textBaseline = "middle";
    stations.forEach((s, k) => {
      const p = this.toPixel(s.x, s.y);
      if (p[0] < -50 || p[1] < -50 || p[0] > this.width + 50 || p[1] > this.height + 50) return;
      const parts = stationParts(this.data, k, t);
      ctx.fillStyle = "#6b5b3e";
      ctx.fillRect(p[0] - 2, p[1] - 2, 4, 4);
      if (parts > 0) {
        ctx.fillStyle = "#6b5b3e";
        for (let n = 0; n < Math.min(parts, 5); n++) ctx.fillRect(p[0] - 9 + 4 * n, p[1] + 5, 3, 3);
      }
      if (labelled) {
        ctx.fillStyle = "#4a3f2b";
        ctx.fillText(`${s.id} (${parts})`, p[0], p[1] - Math.max(9, s.reach * this.scale + 7));
      }
    });
  }

  drawPath(ctx, points) {
    ctx.beginPath();
    points.forEach(([x, y], k) => { const p = this.toPixel(x, y); if (k) ctx.lineTo(p[0], p[1]); else ctx.moveTo(p[0], p[1]); });
    ctx.strokeStyle = "rgba(20, 20, 20, 0.55)"; ctx.lineWidth = 4; ctx.lineJoin = "round"; ctx.stroke();
  }

  drawRobots(ctx, t, selected) {
    const robots = this.data.robots, fleet = this.fleet;
    const labelled = robots.length <= 30 || this.scale > 25;
    const dim = selected.size > 0;
    this.drawn = [];
    if (!this.data.geometry) return;  // no trace: nowhere to draw the robots (a vcran manage folder)
    ctx.font = "bold 11px sans-serif"; ctx.textAlign = "center"; ctx.textBaseline = "bottom";
    for (let i = 0; i < robots.length; i++) {
      const [x, y, theta] = fleet.pose(i, t);
      const task = stepValue(this.data.col, "current", i, t, -1);
      const fill = taskColour(task);
      const [px, py] = this.toPixel(x, y);
      const on = selected.has(i);
      this.drawn.push({ robot: robots[i].id, index: i, x, y, theta, px, py, fill, task, selected: on });
      ctx.globalAlpha = dim && !on ? 0.3 : 1;
      this.drawRobot(ctx, robots[i].footprint, x, y, theta, fill, on);
      if (labelled || on) {
        ctx.fillStyle = "#222";
        ctx.fillText(robots[i].id, px, py - Math.max(8, this.radius(robots[i].footprint) * this.scale + 3));
      }
    }
    ctx.globalAlpha = 1;
  }

  radius(footprint) {
    let r = 0;
    for (const [a, b] of footprint) r = Math.max(r, Math.hypot(a, b));
    return r;
  }

  drawRobot(ctx, footprint, x, y, theta, fill, on) {
    const c = Math.cos(theta), s = Math.sin(theta);
    const [px, py] = this.toPixel(x, y);
    const size = this.radius(footprint) * this.scale;
    if (size * 2 < MIN_ROBOT_PX || !footprint.length) {
      ctx.beginPath(); ctx.arc(px, py, MIN_ROBOT_PX / 2 + (on ? 2 : 0), 0, TAU);
      ctx.fillStyle = fill; ctx.fill();
      if (on) { ctx.strokeStyle = "#000"; ctx.lineWidth = 2; ctx.stroke(); }
      return;
    }
    ctx.beginPath();
    footprint.forEach(([fx, fy], k) => {
      const p = this.toPixel(x + c * fx - s * fy, y + s * fx + c * fy);
      if (k) ctx.lineTo(p[0], p[1]); else ctx.moveTo(p[0], p[1]);
    });
    ctx.closePath();
    ctx.fillStyle = fill; ctx.fill();
    ctx.strokeStyle = on ? "#000" : "#333"; ctx.lineWidth = on ? 3 : 1; ctx.stroke();
    // heading: a line from the reference point towards the front
    const front = Math.max(...footprint.map(([fx]) => fx), 0.2);
    const tip = this.toPixel(x + c * front, y + s * front);
    ctx.beginPath(); ctx.moveTo(px, py); ctx.lineTo(tip[0], tip[1]);
    ctx.strokeStyle = "#222"; ctx.lineWidth = 1.5; ctx.stroke();
    ctx.beginPath(); ctx.arc(px, py, 2, 0, TAU); ctx.fillStyle = "#222"; ctx.fill();
  }

  // The robot under (px, py) at the last draw, or -1.
  hit(px, py) {
    let best = -1, bestD = 12;
    for (const d of this.drawn) {
      const r = Math.max(this.radius(this.data.robots[d.index].footprint) * this.scale, 6);
      const dist = Math.hypot(d.px - px, d.py - py);
      if (dist <= r && dist < bestD + r) { best = d.index; bestD = dist - r; }
    }
    return best;
  }
}
