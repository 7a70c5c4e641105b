"use strict";
// The run's data as the page embeds it (vcran/view/pack.py): base64 of a zlib stream holding a uint32
// length, the JSON meta part, then typed columns at 8-byte-aligned offsets. Decoded with the browser's
// own DecompressionStream: nothing is fetched.

const DTYPES = {
  f64: Float64Array, f32: Float32Array, i32: Int32Array, u32: Uint32Array,
  i16: Int16Array, u16: Uint16Array, u8: Uint8Array,
};

async function inflate(base64) {
  const text = atob(base64);
  const bytes = new Uint8Array(text.length);
  for (let i = 0; i < text.length; i++) bytes[i] = text.charCodeAt(i);
  if (typeof DecompressionStream === "undefined") {
    throw new Error("this browser has no DecompressionStream (Chromium 80+, Firefox 113+, Safari 16.4+ do)");
  }
  const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream("deflate"));
  return new Response(stream).arrayBuffer();
}

// The meta object with its columns as typed arrays: data.col["legs.t"] is a Float64Array, and so on.
async function decodeData(base64) {
  const buffer = await inflate(base64);
  const n = new DataView(buffer).getUint32(0, true);
  const meta = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, n)));
  const base = Math.ceil((4 + n) / 8) * 8;
  meta.col = {};
  for (const [name, [code, offset, length]] of Object.entries(meta.columns)) {
    meta.col[name] = new DTYPES[code](buffer, base + offset, length);
  }
  return meta;
}

// A series of steps per owner (model.Steps): the index of the last step of `owner` at or before `t`,
// or -1 before its first. Binary search: the same cost at any instant of any run.
function stepIndex(col, name, owner, t) {
  const off = col[name + ".offsets"], times = col[name + ".t"];
  let lo = off[owner], hi = off[owner + 1];
  const first = lo;
  while (lo < hi) {
    const mid = (lo + hi) >>> 1;
    if (times[mid] <= t) lo = mid + 1; else hi = mid;
  }
  return lo - 1 >= first ? lo - 1 : -1;
}

function stepValue(col, name, owner, t, initial) {
  const k = stepIndex(col, name, owner, t);
  return k < 0 ? initial : col[name + ".value"][k];
}

// The first index of sorted `times` whose value is above `t`.
function upperBound(times, t, lo = 0, hi = times.length) {
  while (lo < hi) {
    const mid = (lo + hi) >>> 1;
    if (times[mid] <= t) lo = mid + 1; else hi = mid;
  }
  return lo;
}
