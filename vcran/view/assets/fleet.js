"use strict";
// Every robot's pose at any instant, from the leg log (vcran/view/poses.py states the rule): a robot's
// last row at or before t decides. A leg: its pose at t. An abandon (R14): the pose the row gives. A
// halt: where the robot was at the halt's instant (the same rule one row earlier). No row: its start.

const LEG = 0, HALT = 1, ABANDON = 2;

class Fleet {
  constructor(data) {
    this.data = data;
    const c = data.col;
    this.c = c;
    this.off = c["legs.offsets"];
    this.legs = new Array(c["legs.t"].length);  // Leg objects, made on first use
    this.t0 = new Map();  // row -> t0 of a leg resumed after a hold (else t0 is the row's t)
    const resumed = c["legs.resumed"], resumedT0 = c["legs.resumedT0"];
    for (let k = 0; k < resumed.length; k++) this.t0.set(resumed[k], resumedT0[k]);
    this.rest = new Float64Array(3 * c["legs.t"].length).fill(NaN);  // a halt's pose, made on first use
    this.starts = data.robots.map((r) => [r.pose[0], r.pose[1], wrap(r.pose[2])]);
  }

  get size() { return this.starts.length; }

  leg(k) {
    let leg = this.legs[k];
    if (leg === undefined) {
      const c = this.c, lim = this.data.limits[c["legs.limits"][k]];
      const t0 = this.t0.has(k) ? this.t0.get(k) : c["legs.t"][k];
      const goal = c["legs.theta"][k];
      leg = makeLeg(t0, c["legs.x0"][k], c["legs.y0"][k], c["legs.theta0"][k], c["legs.x"][k], c["legs.y"][k],
        Number.isNaN(goal) ? null : goal, lim[0], lim[1], lim[2], lim[3]);
      this.legs[k] = leg;
    }
    return leg;
  }

  // The index of robot i's last row at or before t, or -1.
  lastRow(i, t) {
    const first = this.off[i];
    const k = upperBound(this.c["legs.t"], t, first, this.off[i + 1]) - 1;
    return k >= first ? k : -1;
  }

  // [x, y, theta] of robot i at t.
  pose(i, t) {
    return this.poseAfter(i, this.lastRow(i, t), t);
  }

  // The pose at t given that row k (of robot i; -1: none) is the last that happened.
  poseAfter(i, k, t) {
    if (k < 0) return this.starts[i];
    const c = this.c, kind = c["legs.kind"][k];
    if (kind === LEG) return legPose(this.leg(k), t);
    if (kind === ABANDON) return [c["legs.x0"][k], c["legs.y0"][k], c["legs.theta0"][k]];
    if (Number.isNaN(this.rest[3 * k])) {
      const before = this.poseAfter(i, k > this.off[i] ? k - 1 : -1, c["legs.t"][k]);
      this.rest.set(before, 3 * k);
    }
    return [this.rest[3 * k], this.rest[3 * k + 1], this.rest[3 * k + 2]];
  }

  // The path robot i drove from a to b, as points: it moves along a straight line (or turns in place)
  // between any two consecutive rows and leg ends, so the poses there are the path's corners.
  path(i, a, b) {
    const c = this.c, times = [a];
    for (let k = Math.max(this.lastRow(i, a), this.off[i]); k < this.off[i + 1]; k++) {
      const t = c["legs.t"][k];
      if (t > b) break;
      if (t > a) times.push(t);
      if (c["legs.kind"][k] === LEG) {
        const end = this.leg(k).tEnd;
        if (end > a && end < b) times.push(end);
      }
    }
    times.push(b);
    times.sort((p, q) => p - q);
    return times.map((t) => this.pose(i, t));
  }

  // Smallest box holding every start, leg end and the stations: what the floor fits to at first.
  bounds() {
    const c = this.c;
    let x0 = Infinity, y0 = Infinity, x1 = -Infinity, y1 = -Infinity;
    const add = (x, y) => {
      if (Number.isNaN(x) || Number.isNaN(y)) return;
      if (x < x0) x0 = x; if (x > x1) x1 = x; if (y < y0) y0 = y; if (y > y1) y1 = y;
    };
    for (const [x, y] of this.starts) add(x, y);
    const xs = c["legs.x"], ys = c["legs.y"];
    for (let k = 0; k < xs.length; k++) add(xs[k], ys[k]);
    for (const s of this.data.stations) {
      add(s.x - s.reach, s.y - s.reach); add(s.x + s.reach, s.y + s.reach);
      for (const [x, y] of s.area) add(x, y);
    }
    for (const a of this.data.areas) for (const [x, y] of a.points) add(x, y);
    if (this.data.roadmap) for (const [x, y] of this.data.roadmap.nodes) add(x, y);
    return x0 <= x1 ? [x0, y0, x1, y1] : [-5, -5, 5, 5];
  }
}
