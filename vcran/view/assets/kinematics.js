"use strict";
// Leg kinematics, line for line as vcran/core/motion.py computes them (docs/contract.md §4): turn in place to face
// the point, drive a straight line with a trapezoidal (or triangular) speed profile, turn to the goal
// heading if there is one. Same operations in the same order, so the page draws what the telemetry says.

const TAU = 2 * Math.PI;

// An angle in (-pi, pi]; one already in range is returned unchanged. JavaScript's % is C's fmod.
function wrap(angle) {
  if (-Math.PI < angle && angle <= Math.PI) return angle;
  let a = (angle + Math.PI) % TAU;
  if (a <= 0) a += TAU;
  return a - Math.PI;
}

function copysign(magnitude, sign) {
  return (sign < 0 || Object.is(sign, -0)) ? -Math.abs(magnitude) : Math.abs(magnitude);
}

function turnTime(angle, rate) {
  return rate > 0 && angle !== 0 ? Math.abs(angle) / rate : 0;
}

// Peak speed, acceleration time, deceleration time and total time of a straight drive.
function profile(distance, speed, accel, decel) {
  if (distance <= 0) return [0, 0, 0, 0];
  const invA = accel > 0 ? 1 / accel : 0;
  const invD = decel > 0 ? 1 / decel : 0;
  const ramps = 0.5 * speed * speed * (invA + invD);
  let peak, cruise;
  if (ramps <= distance) {
    peak = speed;
    cruise = (distance - ramps) / speed;
  } else {
    peak = Math.sqrt(distance / (0.5 * (invA + invD)));
    cruise = 0;
  }
  const tAcc = peak * invA, tDec = peak * invD;
  return [peak, tAcc, tDec, tAcc + cruise + tDec];
}

// Distance covered d seconds into a drive.
function along(d, leg) {
  let s;
  if (d < leg.tAcc) {
    s = 0.5 * leg.peak * d * d / leg.tAcc;
  } else if (d <= leg.tDrive - leg.tDec) {
    s = 0.5 * leg.peak * leg.tAcc + leg.peak * (d - leg.tAcc);
  } else {
    const rest = leg.tDrive - d;
    s = leg.distance - 0.5 * leg.peak * rest * rest / leg.tDec;
  }
  return Math.min(Math.max(s, 0), leg.distance);
}

// One leg: motion.Leg.__init__. goal is null when the leg ends facing its direction of travel.
function makeLeg(t0, x0, y0, theta0, x1, y1, goal, speed, accel, decel, turnRate) {
  const leg = { t0, x0, y0, theta0, x1, y1 };
  const dx = x1 - x0, dy = y1 - y0;
  leg.distance = Math.hypot(dx, dy);
  leg.heading = wrap(leg.distance > 0 ? Math.atan2(dy, dx) : theta0);
  leg.ux = Math.cos(leg.heading);
  leg.uy = Math.sin(leg.heading);
  const turn1 = leg.distance > 0 ? wrap(leg.heading - theta0) : 0;
  leg.rate1 = copysign(turnRate, turn1);
  leg.tTurn1 = turnTime(turn1, turnRate);
  [leg.peak, leg.tAcc, leg.tDec, leg.tDrive] = profile(leg.distance, speed, accel, decel);
  const turn2 = goal !== null ? wrap(goal - leg.heading) : 0;
  leg.rate2 = copysign(turnRate, turn2);
  const tTurn2 = turnTime(turn2, turnRate);
  leg.endTheta = goal !== null ? wrap(goal) : leg.heading;
  leg.tEnd = t0 + (leg.tTurn1 + leg.tDrive + tTurn2);
  return leg;
}

// x, y, theta at t, clamped to the leg: motion.Leg.pose_at.
function legPose(leg, t) {
  if (t >= leg.tEnd) return [leg.x1, leg.y1, leg.endTheta];
  let tau = t - leg.t0;
  if (tau < 0) tau = 0;
  if (tau < leg.tTurn1) return [leg.x0, leg.y0, wrap(leg.theta0 + leg.rate1 * tau)];
  const d = tau - leg.tTurn1;
  if (d < leg.tDrive) {
    const s = along(d, leg);
    return [leg.x0 + leg.ux * s, leg.y0 + leg.uy * s, leg.heading];
  }
  return [leg.x1, leg.y1, wrap(leg.heading + leg.rate2 * (d - leg.tDrive))];
}
