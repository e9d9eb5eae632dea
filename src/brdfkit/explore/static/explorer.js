// brdfkit explorer: the front end shared by the web page (page.js) and the notebook widget
// (widget.js). Rendering happens in Python (one source of truth for every BRDF); this module
// draws the arrays it receives and sends the state back. It imports nothing, so that the
// notebook widget can ship it as one ES module.
//
// transport: { send(object), onMessage(callback(header, buffers: ArrayBuffer-views)),
//              upload?(File) -> Promise<name> }

const PALETTE = ["#e6194b", "#3cb44b", "#4363d8", "#f58231", "#911eb4", "#42d4f4", "#f032e6", "#9a6324"];
const LUMA = [0.2126, 0.7152, 0.0722];
const DEFAULT_VIEW = { theta_i: 45, phi_i: 0, theta_h: 20, theta_d: 30, phi_d: 90, resolution: 256, irradiance: Math.PI, lit: false, mesh: "bundled:shaderball", azimuth: 30, elevation: 25 };
const ELEVATION = [-30, 89];  // the orbiting camera's range, degrees (views.ELEVATION_RANGE)
const DEFAULT_DISPLAY = { exposure: 0, gamma: "srgb", channel: "rgb", log: false, cosine: true };
const ANGLE_SLIDERS = [
  ["theta_i", "θi", 0, 89.9], ["phi_i", "φi", -180, 180],
  ["theta_h", "θh", 0, 90], ["theta_d", "θd", 0, 90], ["phi_d", "φd", 0, 180],
];

// ------------------------------------------------------------------------------ small helpers
function el(tag, props = {}, children = []) {
  const node = document.createElement(tag);
  for (const [k, v] of Object.entries(props)) {
    if (k === "dataset") Object.assign(node.dataset, v);
    else if (k.startsWith("on")) node.addEventListener(k.slice(2), v);
    else node[k] = v;
  }
  for (const c of [].concat(children)) node.append(c);
  return node;
}

export function srgbEncode(x) {
  return x <= 0.0031308 ? 12.92 * Math.max(x, 0) : 1.055 * Math.pow(x, 1 / 2.4) - 0.055;
}
function srgbDecode(v) {
  return v <= 0.04045 ? v / 12.92 : Math.pow((v + 0.055) / 1.055, 2.4);
}

// A typed view of one array described in a frame header (float16: its bits, see halfFloats).
function typedArray(spec, buffer) {
  const kinds = { float16: Uint16Array, float32: Float32Array, float64: Float64Array, int32: Int32Array, uint8: Uint8Array };
  const Kind = kinds[spec.dtype];
  const count = spec.shape.reduce((a, b) => a * b, 1);
  return new Kind(buffer.buffer, buffer.byteOffset, count);
}

// IEEE 754 half floats: the value of each of the 65536 bit patterns (a table built once).
let HALF = null;
function halfFloats() {
  if (HALF) return HALF;
  HALF = new Float32Array(65536);
  for (let h = 0; h < 65536; h++) {
    const e = (h >> 10) & 31, m = h & 1023;
    const v = e === 0 ? m * 2 ** -24 : e === 31 ? (m ? NaN : Infinity) : (1 + m / 1024) * 2 ** (e - 15);
    HALF[h] = h & 0x8000 ? -v : v;
  }
  return HALF;
}

// The linear image (size·size·C, 0 off the disc) of a disc's values: those of its pixels
// only, in row order (float16 bits in a Uint16Array, or floats); the disc is its mask's bits,
// each row's packed most significant first ((size, ⌈size/8⌉) bytes, as NumPy's packbits). The
// image is a scratch buffer, valid until the next call.
let scratch = new Float32Array(0);
function discImage(values, size, C, disc) {
  const n = size * size * C, rowBytes = disc.length / size;
  if (scratch.length < n) scratch = new Float32Array(n);
  const out = scratch.subarray(0, n).fill(0), half = values instanceof Uint16Array ? halfFloats() : null;
  for (let row = 0, k = 0; row < size; row++) for (let col = 0; col < size; col++) {
    if (!(disc[row * rowBytes + (col >> 3)] & (128 >> (col & 7)))) continue;
    const p = (row * size + col) * C;
    if (half) for (let c = 0; c < C; c++) out[p + c] = half[values[k++]];
    else for (let c = 0; c < C; c++) out[p + c] = values[k++];
  }
  return out;
}

// Channel selection: values (n*C) → n grey values. "rgb" on a plot is luminance.
export function channelOf(data, channels, channel) {
  const n = data.length / channels;
  const out = new Float64Array(n);
  for (let i = 0; i < n; i++) {
    if (channels === 1) out[i] = data[i];
    else if (channel === "r") out[i] = data[i * channels];
    else if (channel === "g") out[i] = data[i * channels + 1];
    else if (channel === "b") out[i] = data[i * channels + 2];
    else out[i] = LUMA[0] * data[i * channels] + LUMA[1] * data[i * channels + 1] + LUMA[2] * data[i * channels + 2];
  }
  return out;
}

function encodeDisplay(v, display) {
  const x = Math.min(Math.max(v, 0), 1);
  const g = display.gamma === "srgb" ? srgbEncode(x) : Math.pow(x, 1 / Number(display.gamma));
  return Math.round(g * 255);
}

// The 8-bit display encoding as a table: thresholds[k] is the least linear value shown as k
// (found by bisection on encodeDisplay itself), and a coarse index into them, so that a pixel
// costs a table read and a comparison or two instead of a power — the same levels as
// encodeDisplay.
const LUT_BINS = 4096;
const encoders = new Map();
function encoder(display) {
  const key = String(display.gamma);
  if (encoders.has(key)) return encoders.get(key);
  const thresholds = new Float64Array(257);
  thresholds[256] = Infinity;
  for (let k = 1; k < 256; k++) {
    let lo = 0, hi = 1;
    for (let i = 0; i < 60; i++) { const mid = (lo + hi) / 2; if (encodeDisplay(mid, display) >= k) hi = mid; else lo = mid; }
    thresholds[k] = hi;
  }
  const start = new Uint8Array(LUT_BINS + 1);
  for (let b = 0, k = 0; b <= LUT_BINS; b++) { while (k < 255 && thresholds[k + 1] <= b / LUT_BINS) k++; start[b] = k; }
  const encode = (x) => {
    if (!(x > 0)) return 0;
    if (x >= 1) return 255;
    let k = start[(x * LUT_BINS) | 0];
    while (x >= thresholds[k + 1]) k++;
    return k;
  };
  encoders.set(key, encode);
  return encode;
}

// Linear (R, R, C) image → RGBA pixels with exposure, channel and display encoding; with a
// disc, data holds the values of the disc's pixels only (discImage), the others are black.
export function toPixels(data, size, channels, display, disc = null) {
  if (disc) data = discImage(data, size, channels, disc);
  const out = new Uint8ClampedArray(size * size * 4);
  const scale = Math.pow(2, display.exposure), encode = encoder(display);
  const k = { r: 0, g: 1, b: 2 }[display.channel];
  for (let p = 0; p < size * size; p++) {
    let r, g, b;
    if (channels === 1) r = g = b = data[p];
    else if (display.channel === "rgb") { r = data[3 * p]; g = data[3 * p + 1]; b = data[3 * p + 2]; }
    else r = g = b = k === undefined ? LUMA[0] * data[3 * p] + LUMA[1] * data[3 * p + 1] + LUMA[2] * data[3 * p + 2] : data[3 * p + k];
    out[4 * p] = encode(r * scale);
    out[4 * p + 1] = encode(g * scale);
    out[4 * p + 2] = encode(b * scale);
    out[4 * p + 3] = 255;
  }
  return out;
}

// Text written only when it differs (an unchanged page needs no new layout).
function setText(node, text) { if (node.textContent !== text) node.textContent = text; }

function getPath(obj, path) { return path.reduce((o, k) => (o === undefined ? undefined : o[k]), obj); }
function setPath(obj, path, value) { getPath(obj, path.slice(0, -1))[path[path.length - 1]] = value; }

function hexOf(rgb) {
  return "#" + rgb.map((v) => Math.round(srgbEncode(Math.min(Math.max(v, 0), 1)) * 255).toString(16).padStart(2, "0")).join("");
}
function rgbOf(hex) {
  return [1, 3, 5].map((i) => Number(srgbDecode(parseInt(hex.slice(i, i + 2), 16) / 255).toFixed(6)));
}

function sliderToValue(t, s) {
  return s.log ? s.lo * Math.pow(s.hi / s.lo, t) : s.lo + (s.hi - s.lo) * t;
}
function valueToSlider(v, s) {
  const t = s.log ? Math.log(Math.max(v, s.lo) / s.lo) / Math.log(s.hi / s.lo) : (v - s.lo) / (s.hi - s.lo);
  return Math.min(Math.max(t, 0), 1);
}
function tidy(v) { return Number(v.toPrecision(6)); }

function parseText(text) {
  const t = text.trim();
  if (t === "" || t === "None" || t === "null") return null;
  if (t === "True" || t === "true") return true;
  if (t === "False" || t === "false") return false;
  if (!Number.isNaN(Number(t))) return Number(t);
  if (t.startsWith("[")) { try { return JSON.parse(t); } catch (e) { /* a string then */ } }
  return t.replace(/^['"]|['"]$/g, "");
}
function showText(v) { return v === null || v === undefined ? "None" : Array.isArray(v) ? JSON.stringify(v) : String(v); }

export function encodeState(s) {
  const bytes = new TextEncoder().encode(JSON.stringify(s));
  let bin = "";
  for (const b of bytes) bin += String.fromCharCode(b);
  return btoa(bin).replace(/\+/g, "-").replace(/\//g, "_").replace(/=+$/, "");
}
export function decodeState(text) {
  const bin = atob(text.replace(/-/g, "+").replace(/_/g, "/"));
  return JSON.parse(new TextDecoder().decode(Uint8Array.from(bin, (c) => c.charCodeAt(0))));
}

// ------------------------------------------------------------------------------ plotting
function clear(canvas) {
  const ctx = canvas.getContext("2d");
  ctx.fillStyle = "#fff";
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  return ctx;
}

// A Cartesian plot of several series {x (radians), y, color, band?}; x shown in degrees.
function linePlot(canvas, series, { log = false, xmin = 0, xmax = 90, title = "" } = {}) {
  const ctx = clear(canvas);
  const W = canvas.width, H = canvas.height, L = 46, R = 8, T = 18, B = 26;
  let ymax = 0;
  for (const s of series) for (let i = 0; i < s.y.length; i++) ymax = Math.max(ymax, s.y[i] + (s.band ? s.band[i] : 0));
  if (!(ymax > 0)) ymax = 1;
  const ymin = log ? ymax * 1e-4 : 0;
  const fy = (y) => {
    const v = log ? (Math.log10(Math.max(y, ymin)) - Math.log10(ymin)) / (Math.log10(ymax) - Math.log10(ymin)) : y / ymax;
    return T + (H - T - B) * (1 - v);
  };
  const fx = (x) => L + ((x * 180) / Math.PI - xmin) / (xmax - xmin) * (W - L - R);
  ctx.strokeStyle = "#999"; ctx.fillStyle = "#333"; ctx.font = "11px sans-serif";
  ctx.strokeRect(L, T, W - L - R, H - T - B);
  ctx.fillText(title, L, 12);
  for (const d of [xmin, (xmin + xmax) / 2, xmax]) ctx.fillText(`${d}°`, fx((d * Math.PI) / 180) - 8, H - 8);
  ctx.fillText(log ? ymax.toExponential(1) : ymax.toPrecision(3), 2, T + 8);
  ctx.fillText(log ? ymin.toExponential(0) : "0", 2, H - B);
  for (const s of series) {
    if (s.band) {
      ctx.fillStyle = s.color + "44";
      ctx.beginPath();
      for (let i = 0; i < s.x.length; i++) ctx.lineTo(fx(s.x[i]), fy(s.y[i] + s.band[i]));
      for (let i = s.x.length - 1; i >= 0; i--) ctx.lineTo(fx(s.x[i]), fy(s.y[i] - s.band[i]));
      ctx.fill();
    }
    ctx.strokeStyle = s.color; ctx.lineWidth = 1.5;
    ctx.beginPath();
    for (let i = 0; i < s.x.length; i++) ctx.lineTo(fx(s.x[i]), fy(s.y[i]));
    ctx.stroke();
  }
}

// The polar plot in the plane of incidence: r(θv) with θv = 0 up, the light at −θi.
function polarPlot(canvas, series, thetaI, log) {
  const ctx = clear(canvas);
  const W = canvas.width, H = canvas.height, cx = W / 2, cy = H - 14, rad = Math.min(W / 2, H) - 18;
  let rmax = 0;
  for (const s of series) for (const y of s.y) rmax = Math.max(rmax, log ? Math.log10(1 + y) : y);
  if (!(rmax > 0)) rmax = 1;
  ctx.strokeStyle = "#ccc";
  for (const f of [0.25, 0.5, 0.75, 1]) { ctx.beginPath(); ctx.arc(cx, cy, rad * f, Math.PI, 2 * Math.PI); ctx.stroke(); }
  ctx.beginPath(); ctx.moveTo(cx - rad, cy); ctx.lineTo(cx + rad, cy); ctx.stroke();
  const ti = (thetaI * Math.PI) / 180;
  ctx.strokeStyle = "#e0a000"; ctx.lineWidth = 2;
  ctx.beginPath(); ctx.moveTo(cx, cy); ctx.lineTo(cx - rad * Math.sin(ti), cy - rad * Math.cos(ti)); ctx.stroke();
  for (const s of series) {
    ctx.strokeStyle = s.color; ctx.lineWidth = 1.5; ctx.beginPath();
    for (let i = 0; i < s.x.length; i++) {
      const r = ((log ? Math.log10(1 + s.y[i]) : s.y[i]) / rmax) * rad;
      ctx.lineTo(cx + r * Math.sin(s.x[i]), cy - r * Math.cos(s.x[i]));
    }
    ctx.stroke();
  }
  ctx.fillStyle = "#333"; ctx.font = "11px sans-serif";
  ctx.fillText(`max ${rmax.toPrecision(3)}${log ? " (log₁₀(1+·))" : ""}`, 4, 12);
}

// The 3D lobe r(wo)·wo as a shaded surface, rotated by yaw/pitch, orthographic: each cell of
// every `step`-th grid line a quad lit from the viewer's upper left (|n·l|, both sides), drawn
// far to near.
function lobePlot(canvas, meshes, wi, rot, step = 2) {
  const ctx = clear(canvas);
  const W = canvas.width, H = canvas.height;
  let rmax = 0;
  for (const m of meshes) for (const r of m.r) rmax = Math.max(rmax, r);
  if (!(rmax > 0)) rmax = 1;
  const s = (0.42 * Math.min(W, H)) / rmax;
  const cy = Math.cos(rot.yaw), sy = Math.sin(rot.yaw), cp = Math.cos(rot.pitch), sp = Math.sin(rot.pitch);
  const turn = (x, y, z) => {
    const x1 = cy * x - sy * y, y1 = sy * x + cy * y;  // yaw about the normal
    return [x1, cp * y1 - sp * z, sp * y1 + cp * z];  // pitch: (right, depth, up)
  };
  const project = (x, y, z) => { const [a, d, u] = turn(x, y, z); return [W / 2 + s * a, H * 0.7 - s * u, d]; };
  const line = (pts, color, width = 1) => {
    ctx.strokeStyle = color; ctx.lineWidth = width; ctx.beginPath();
    for (const p of pts) ctx.lineTo(p[0], p[1]);
    ctx.stroke();
  };
  line([project(-rmax, 0, 0), project(rmax, 0, 0)], "#ccc");
  line([project(0, -rmax, 0), project(0, rmax, 0)], "#ccc");
  const light = [-0.4, -0.6, 0.7], norm = Math.hypot(...light);
  const quads = [];
  for (const m of meshes) {
    const [T, P] = m.shape;
    const rgb = [1, 3, 5].map((i) => parseInt(m.color.slice(i, i + 2), 16));
    const at = (t, p) => {
      const th = (t / (T - 1)) * (Math.PI / 2), ph = (p / (P - 1)) * 2 * Math.PI, r = m.r[t * P + p];
      return turn(r * Math.sin(th) * Math.cos(ph), r * Math.sin(th) * Math.sin(ph), r * Math.cos(th));
    };
    for (let t = 0; t < T - 1; t += step) for (let p = 0; p < P - 1; p += step) {
      const t2 = Math.min(t + step, T - 1), p2 = Math.min(p + step, P - 1);
      const c = [at(t, p), at(t, p2), at(t2, p2), at(t2, p)];
      const e1 = c[2].map((v, k) => v - c[0][k]), e2 = c[3].map((v, k) => v - c[1][k]);
      const n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
      const length = Math.hypot(...n);
      const shade = length > 0 ? 0.3 + 0.7 * Math.abs(n[0] * light[0] + n[1] * light[1] + n[2] * light[2]) / (length * norm) : 0.3;
      const depth = (c[0][1] + c[1][1] + c[2][1] + c[3][1]) / 4;
      quads.push({ depth, fill: `rgb(${rgb.map((v) => Math.round(v * shade)).join(",")})`, pts: c.map(([a, , u]) => [W / 2 + s * a, H * 0.7 - s * u]) });
    }
  }
  quads.sort((a, b) => b.depth - a.depth);
  for (const q of quads) {
    ctx.fillStyle = q.fill; ctx.strokeStyle = q.fill; ctx.lineWidth = 0.5;
    ctx.beginPath();
    for (const p of q.pts) ctx.lineTo(p[0], p[1]);
    ctx.closePath(); ctx.fill(); ctx.stroke();
  }
  line([project(0, 0, 0), project(0, 0, rmax)], "#999");
  line([project(0, 0, 0), project(wi[0] * rmax, wi[1] * rmax, wi[2] * rmax)], "#e0a000", 2);
}

// A perceptual-ish colour map (dark purple → orange → yellow) for the θh × θd slice.
const STOPS = [[0, 0, 4], [81, 18, 124], [183, 55, 121], [252, 137, 97], [252, 253, 191]];
function colormap(t) {
  const x = Math.min(Math.max(t, 0), 1) * (STOPS.length - 1), i = Math.min(Math.floor(x), STOPS.length - 2), f = x - i;
  return STOPS[i].map((c, k) => Math.round(c + (STOPS[i + 1][k] - c) * f));
}
// The θh × θd slice's pixels: log colour scale over four decades below the largest value, black
// where the value is 0; (θd up).
function slicePixels(v, n) {
  let vmax = 0;
  for (const x of v) vmax = Math.max(vmax, x);
  const vmin = vmax * 1e-4, px = new Uint8ClampedArray(n * n * 4), scale = 1 / Math.log(vmax / vmin);
  for (let row = 0; row < n; row++) for (let col = 0; col < n; col++) {
    const value = v[row * n + col], out = ((n - 1 - row) * n + col) * 4;
    const c = value > 0 ? colormap(Math.log(value / vmin) * scale) : [0, 0, 0];
    px[out] = c[0]; px[out + 1] = c[1]; px[out + 2] = c[2]; px[out + 3] = 255;
  }
  return px;
}

// Whether any of a view's inputs differ from those it was last drawn from (kept by name):
// typed arrays by value, anything else by identity. A view whose inputs are unchanged is not
// drawn again: the light's slider moves the spheres, the polar plot, the θv curve and the lobe.
function sameValue(a, b) {
  if (a === b) return true;
  if (!ArrayBuffer.isView(a) || !ArrayBuffer.isView(b)) return a === b;
  if (a.length !== b.length || a.constructor !== b.constructor) return false;
  for (let i = 0; i < a.length; i++) if (a[i] !== b[i] && !(a[i] !== a[i] && b[i] !== b[i])) return false;
  return true;
}
function inputsChanged(memory, name, inputs) {
  const last = memory.get(name);
  if (last && last.length === inputs.length && inputs.every((v, i) => sameValue(v, last[i]))) return false;
  memory.set(name, inputs);
  return true;
}

// ------------------------------------------------------------------------------ the explorer
export function createExplorer(root, transport, config = {}) {
  const state = {
    entries: [],
    view: { ...DEFAULT_VIEW },
    display: { ...DEFAULT_DISPLAY },
    rotation: { yaw: -0.6, pitch: 1.1 },
  };
  let nextId = 1, seq = 0, inFlight = 0, pending = false, frame = null, albedo = null;
  const listeners = [];
  const api = { state, plotted: {}, env: {}, lit: {}, sent: { seq: 0, time: 0 }, shown: { seq: 0, time: 0 }, moving: false, drawMs: 0, frame: () => frame, onFrame: (f) => listeners.push(f) };
  root.classList.add("brdfkit-explorer");

  // ---- layout
  const side = el("div", { className: "bx-side" });
  const mainPane = el("div", { className: "bx-main" });
  root.append(side, mainPane);
  const entryList = el("div", { className: "bx-entries" });
  const addSpec = el("input", { type: "text", className: "bx-add-spec", placeholder: "add a BRDF: ggx(alpha=0.1)  (Enter)" });
  addSpec.addEventListener("keydown", (e) => {
    if (e.key === "Enter" && addSpec.value.trim()) { addEntry({ spec: addSpec.value.trim() }); addSpec.value = ""; }
  });
  const fileSelect = el("select", { className: "bx-add-file" });
  const refreshFiles = (files) => {
    fileSelect.replaceChildren(el("option", { value: "", textContent: "add a measured file…" }), ...files.map((f) => el("option", { value: f, textContent: f })));
  };
  refreshFiles(config.files || []);
  fileSelect.addEventListener("change", () => { if (fileSelect.value) addEntry({ file: fileSelect.value }); fileSelect.value = ""; });
  side.append(el("h3", { textContent: "BRDFs" }), entryList, addSpec, fileSelect);
  if (transport.upload) {
    const picker = el("input", { type: "file", className: "bx-upload", accept: ".binary,.bsdf,.brdf,.json,.obj,.ply,.stl,.gltf,.glb" });
    picker.addEventListener("change", async () => { for (const f of picker.files) await uploadFile(f); picker.value = ""; });
    side.append(el("label", { className: "bx-upload-label", textContent: "upload (or drop) MERL/RGL/Cornell, fit.json or a mesh (OBJ/PLY/STL/glTF): " }, [picker]));
    root.addEventListener("dragover", (e) => e.preventDefault());
    root.addEventListener("drop", async (e) => { e.preventDefault(); for (const f of e.dataTransfer.files) await uploadFile(f); });
  }
  const status = el("div", { className: "bx-status" });

  // global sliders
  const globals = el("div", { className: "bx-globals" });
  const inputs = {};
  const slider = (key, label, lo, hi, step, target, onchange) => {
    const range = el("input", { type: "range", min: lo, max: hi, step, value: target[key], className: `bx-${key}` });
    const out = el("span", { className: "bx-value", textContent: String(target[key]) });
    range.addEventListener("input", () => { target[key] = Number(range.value); out.textContent = range.value; onchange(); });
    if (onchange === moved) draggable(range);
    inputs[key] = { range, out };
    globals.append(el("label", { className: "bx-row" }, [el("span", { textContent: label }), range, out]));
  };
  for (const [key, label, lo, hi] of ANGLE_SLIDERS) slider(key, label, lo, hi, 0.1, state.view, moved);
  slider("exposure", "exposure", -10, 10, 0.1, state.display, redraw);
  const select = (key, label, options, target, onchange) => {
    const s = el("select", { className: `bx-${key}` }, options.map(([v, t]) => el("option", { value: v, textContent: t })));
    s.value = String(target[key]);
    s.addEventListener("change", () => { target[key] = isNaN(Number(s.value)) ? s.value : Number(s.value); onchange(); });
    inputs[key] = { select: s };
    globals.append(el("label", { className: "bx-row" }, [el("span", { textContent: label }), s]));
  };
  select("gamma", "display", [["srgb", "sRGB"], ["2.2", "γ 2.2"], ["1", "linear"]], state.display, redraw);
  select("channel", "channel", [["rgb", "RGB (plots: luminance)"], ["r", "R"], ["g", "G"], ["b", "B"], ["lum", "luminance"]], state.display, redraw);
  select("resolution", "sphere", [["128", "128²"], ["256", "256²"], ["512", "512²"]], state.view, changed);
  const check = (key, label) => {
    const c = el("input", { type: "checkbox", checked: state.display[key], className: `bx-${key}` });
    c.addEventListener("change", () => { state.display[key] = c.checked; redraw(); });
    inputs[key] = { check: c };
    globals.append(el("label", { className: "bx-row" }, [c, el("span", { textContent: label })]));
  };
  if (config.envmap) {
    const c = el("input", { type: "checkbox", checked: !!state.view.envmap, className: "bx-envmap" });
    c.addEventListener("change", () => { state.view.envmap = c.checked; changed(); });
    inputs.envmap = { check: c };
    globals.append(el("label", { className: "bx-row" }, [c, el("span", { textContent: `environment map (${config.envmap})` })]));
  }
  {
    const c = el("input", { type: "checkbox", checked: !!state.view.lit, className: "bx-lit" });
    c.addEventListener("change", () => { state.view.lit = c.checked; changed(); });
    inputs.lit = { check: c };
    globals.append(el("label", { className: "bx-row" }, [c, el("span", { textContent: "lit object (environment map, shadows)" })]));
  }
  const meshSelect = el("select", { className: "bx-mesh" });
  const refreshMeshes = (meshes) => {
    meshSelect.replaceChildren(...meshes.map((m) => el("option", { value: m, textContent: m })));
    meshSelect.value = state.view.mesh || meshes[0] || "";
  };
  if (config.meshes && config.meshes.length && !config.meshes.includes(state.view.mesh)) state.view.mesh = config.meshes[0];
  refreshMeshes(config.meshes || []);
  meshSelect.addEventListener("change", () => { state.view.mesh = meshSelect.value; changed(); });
  inputs.mesh = { select: meshSelect };
  globals.append(el("label", { className: "bx-row" }, [el("span", { textContent: "mesh" }), meshSelect]));
  check("log", "log-scale plots");
  check("cosine", "multiply by cos θ (lobe, polar, θv)");
  const exports = el("div", { className: "bx-exports" }, [
    el("button", { textContent: "copy URL", className: "bx-copy-url", onclick: () => navigator.clipboard && navigator.clipboard.writeText(location.href) }),
    el("button", { textContent: "spec", className: "bx-export-spec", onclick: () => download("brdfs.txt", state.entries.map(specText).join("\n") + "\n", "text/plain") }),
    el("button", { textContent: "JSON", className: "bx-export-json", onclick: () => download("explorer.json", JSON.stringify(persistent(), null, 2), "application/json") }),
  ]);
  side.append(el("h3", { textContent: "view" }), globals, el("h3", { textContent: "export" }), exports, status);

  // views
  const panel = (name, title, w, h) => {
    const canvas = el("canvas", { width: w, height: h, className: `bx-canvas bx-${name}` });
    const png = el("button", { textContent: "PNG", className: "bx-png", onclick: () => canvas.toBlob((b) => download(`${name}.png`, b)) });
    const box = el("div", { className: `bx-panel bx-panel-${name}` }, [el("div", { className: "bx-title" }, [el("span", { textContent: title }), png]), canvas]);
    return { box, canvas };
  };
  // A panel of several canvases (one per BRDF); its PNG puts them side by side.
  const group = (name, title) => {
    const body = el("div", { className: `bx-${name}` });
    const png = el("button", { textContent: "PNG", className: "bx-png", onclick: () => {
      const parts = Array.from(body.querySelectorAll("canvas"));
      const out = el("canvas", { width: parts.reduce((w, c) => w + c.width, 0) || 1, height: Math.max(1, ...parts.map((c) => c.height)) });
      let x = 0;
      for (const c of parts) { out.getContext("2d").drawImage(c, x, 0); x += c.width; }
      out.toBlob((b) => download(`${name}.png`, b));
    } });
    const box = el("div", { className: `bx-panel bx-panel-${name}` }, [el("div", { className: "bx-title" }, [el("span", { textContent: title }), png]), body]);
    return { box, body };
  };
  const sphereGroup = group("spheres", "lit spheres, directional light (drag to move it); last: |first − second|");
  const envGroup = group("envs", "lit spheres, environment map (refined progressively)");
  const litGroup = group("lits", "lit objects, environment map with shadows (drag to orbit; refined progressively); last: |first − second|");
  const spheres = sphereGroup.body, envPanel = envGroup.body, litPanel = litGroup.body;
  const envs = new Map();  // id → {canvas, caption, data, size, C}
  const lits = new Map();  // id → {canvas, caption, data, size, C, header}
  const sliceGroup = group("slices", "θh × θd slices (log)");
  const slices = sliceGroup.body, sliceTitle = sliceGroup.box.querySelector(".bx-title span");
  const polar = panel("polar", "plane of incidence (polar)", 360, 200);
  const lobe = panel("lobe", "3D lobe, shaded surface (drag to rotate)", 360, 300);
  const curves = {
    theta_v: panel("theta_v", "θv curve (plane of incidence)", 360, 180),
    theta_h: panel("theta_h", "θh curve (at θd, φd)", 360, 180),
    theta_d: panel("theta_d", "θd curve (at θh, φd)", 360, 180),
    albedo: panel("albedo", "directional albedo ± 2σ (Monte Carlo)", 360, 180),
  };
  const checksBox = el("div", { className: "bx-panel bx-checks" }, [el("div", { className: "bx-title", textContent: "physics checks" })]);
  const checksBody = el("div", { className: "bx-checks-body", textContent: "select a BRDF's “check” button" });
  checksBox.append(checksBody);
  mainPane.append(sphereGroup.box, envGroup.box, litGroup.box, polar.box, lobe.box, ...Object.values(curves).map((c) => c.box), sliceGroup.box, checksBox);

  let drag = null;
  lobe.canvas.addEventListener("pointerdown", (e) => { drag = { x: e.clientX, y: e.clientY }; lobe.canvas.setPointerCapture(e.pointerId); });
  lobe.canvas.addEventListener("pointermove", (e) => {
    if (!drag) return;
    state.rotation.yaw += (e.clientX - drag.x) * 0.01;
    state.rotation.pitch = Math.min(Math.max(state.rotation.pitch + (e.clientY - drag.y) * 0.01, 0), Math.PI / 2);
    drag = { x: e.clientX, y: e.clientY };
    redraw();
  });
  lobe.canvas.addEventListener("pointerup", () => { drag = null; });

  // ---- entries
  function visibleIds() {
    const solo = state.entries.some((e) => e.solo);
    return new Set(state.entries.filter((e) => (solo ? e.solo : e.visible)).map((e) => e.id));
  }
  function specText(e) { return e.info && e.info.spec ? e.info.spec : e.source.spec || e.source.file || ""; }

  function addEntry(source, extra = {}) {
    const id = extra.id || `b${nextId++}`;
    const entry = { id, source, visible: true, solo: false, color: PALETTE[(state.entries.length) % PALETTE.length], ...extra, info: null, signature: "" };
    state.entries.push(entry);
    entry.dom = entryDom(entry);
    entryList.append(entry.dom.box);
    changed();
    return entry;
  }
  function removeEntry(entry) {
    state.entries.splice(state.entries.indexOf(entry), 1);
    entry.dom.box.remove();
    changed();
  }
  function entryDom(entry) {
    const color = el("input", { type: "color", value: entry.color, className: "bx-color" });
    color.addEventListener("input", () => { entry.color = color.value; redraw(); saveUrl(); });
    const visible = el("input", { type: "checkbox", checked: entry.visible, className: "bx-visible", title: "visible" });
    visible.addEventListener("change", () => { entry.visible = visible.checked; changed(); });
    const solo = el("button", { textContent: "solo", className: "bx-solo" });
    solo.addEventListener("click", () => { entry.solo = !entry.solo; solo.classList.toggle("on", entry.solo); changed(); });
    solo.classList.toggle("on", entry.solo);
    const checkButton = el("button", { textContent: "check", className: "bx-check", onclick: () => requestChecks(entry) });
    const remove = el("button", { textContent: "×", className: "bx-remove", onclick: () => removeEntry(entry) });
    const spec = el("textarea", { className: "bx-spec", rows: 2, value: entry.source.spec || entry.source.file || "" });
    spec.readOnly = !!entry.source.file;
    spec.addEventListener("keydown", (e) => {
      if (e.key === "Enter" && !e.shiftKey) { e.preventDefault(); entry.source = { spec: spec.value }; entry.signature = ""; changed(); }
    });
    const error = el("div", { className: "bx-error" });
    const controls = el("div", { className: "bx-controls" });
    const box = el("div", { className: "bx-entry", dataset: { id: entry.id } }, [
      el("div", { className: "bx-entry-head" }, [color, visible, solo, checkButton, remove]), spec, error, controls,
    ]);
    return { box, spec, error, controls };
  }

  function buildControls(entry) {
    const { controls } = entry.dom;
    controls.replaceChildren();
    const tree = entry.source.tree;
    for (const c of entry.info.controls || []) {
      const value = getPath(tree, c.path);
      const key = c.path.join(".");
      const set = (v, moving = false) => { setPath(entry.source.tree, c.path, v); if (moving) moved(); else changed(); };
      const label = el("span", { className: "bx-param-name", textContent: `${c.model}.${c.name}`, title: (c.slider && c.slider.hint) || "" });
      let widget;
      if (c.kind === "number") {
        const range = el("input", { type: "range", min: 0, max: 1000, step: 1, value: Math.round(valueToSlider(value, c.slider) * 1000) });
        const box = el("input", { type: "number", value: tidy(value), step: "any", className: "bx-number" });
        range.addEventListener("input", () => { const v = tidy(sliderToValue(range.value / 1000, c.slider)); box.value = v; set(v, true); });
        draggable(range);
        box.addEventListener("change", () => { range.value = Math.round(valueToSlider(Number(box.value), c.slider) * 1000); set(Number(box.value)); });
        widget = [range, box];
      } else if (c.kind === "rgb") {
        const pick = el("input", { type: "color", value: hexOf(value) });
        const text = el("input", { type: "text", value: JSON.stringify(value), className: "bx-text" });
        pick.addEventListener("input", () => { const v = rgbOf(pick.value); text.value = JSON.stringify(v); set(v); });
        text.addEventListener("change", () => { const v = parseText(text.value); if (Array.isArray(v)) pick.value = hexOf(v); set(v); });
        widget = [pick, text];
      } else if (c.kind === "choice") {
        const menu = el("select", { className: "bx-choice" }, c.options.map((o) => el("option", { value: o, textContent: o })));
        menu.value = value;
        menu.addEventListener("change", () => set(menu.value));
        widget = [menu];
      } else if (c.kind === "bool") {
        const box = el("input", { type: "checkbox", checked: !!value });
        box.addEventListener("change", () => set(box.checked));
        widget = [box];
      } else {
        const text = el("input", { type: "text", value: showText(value), className: "bx-text" });
        text.addEventListener("change", () => set(parseText(text.value)));
        widget = [text];
      }
      controls.append(el("label", { className: "bx-param", dataset: { path: key } }, [label, ...widget]));
    }
  }

  // ---- messages
  function wireState() {
    const ids = visibleIds();
    return {
      entries: state.entries.map((e) => ({ id: e.id, visible: ids.has(e.id), source: e.source })),
      view: { ...state.view, preview: api.moving },
    };
  }
  // While a slider or the light is dragged (held, after its first step) the page asks for
  // previews (the sphere at half resolution: a quarter of the pixels to render, send and
  // draw); the full image follows once it rests: released, or held still for REST_MS. A single
  // step (a click, a key) asks for the full image at once.
  const REST_MS = 300;
  let restTimer = 0, held = false, stepped = false;
  function moved() {
    api.moving = held && stepped;
    stepped = held;
    clearTimeout(restTimer);
    if (api.moving) restTimer = setTimeout(rested, REST_MS);
    changed();
  }
  function grabbed() { held = true; stepped = false; }
  function released() { held = false; stepped = false; rested(); }
  function rested() {
    clearTimeout(restTimer);
    if (!api.moving) return;
    api.moving = false;
    changed();
  }
  function draggable(range) {
    range.addEventListener("pointerdown", grabbed);
    for (const name of ["pointerup", "change"]) range.addEventListener(name, released);
  }
  function changed() {
    saveUrl();
    if (inFlight) { pending = true; return; }
    inFlight = ++seq;
    api.sent = { seq, time: performance.now() };
    transport.send({ type: "render", seq, state: wireState() });
  }
  function requestChecks(entry) {
    checksBody.textContent = `checking ${specText(entry).slice(0, 80)}…`;
    transport.send({ type: "checks", seq: ++seq, entry: { id: entry.id, visible: true, source: entry.source } });
  }

  transport.onMessage((header, buffers) => {
    const arrays = (header.arrays || []).map((spec, i) => typedArray(spec, buffers[i]));
    for (const [id, name] of header.held || []) {  // views as in the previous frame
      const index = frame.header.views[id][name];
      header.views[id][name] = arrays.length;
      header.arrays.push(frame.header.arrays[index]);
      arrays.push(frame.arrays[index]);
    }
    if (header.type === "frame") {
      if (header.seq === inFlight) inFlight = 0;
      frame = { header, arrays };
      const start = performance.now();
      applyEntries(header.entries);
      redraw();
      api.shown = { seq: header.seq, time: performance.now(), preview: header.preview };
      api.drawMs = api.shown.time - start;
      setText(status, "");
      for (const f of listeners) f(header);
      if (pending && !inFlight) { pending = false; changed(); }
    } else if (header.type === "albedo") {
      albedo = { header, arrays };
      if (frame) drawAlbedo(shownEntries());
    } else if (header.type === "env") {
      showEnv(header, arrays[0]);
    } else if (header.type === "lit") {
      showLit(header, arrays[0]);
    } else if (header.type === "checks") {
      showChecks(header);
    } else if (header.type === "error") {
      status.textContent = header.message;
      if (header.seq === inFlight || header.seq === 0) inFlight = 0;
      if (pending && !inFlight) { pending = false; changed(); }
    }
  });

  function applyEntries(infos) {
    for (const info of infos) {
      const entry = state.entries.find((e) => e.id === info.id);
      if (!entry) continue;
      setText(entry.dom.error, info.error || "");
      if (info.error && !info.label) continue;
      entry.info = info;
      const text = info.spec || info.file;
      if (document.activeElement !== entry.dom.spec && entry.dom.spec.value !== text) entry.dom.spec.value = text;
      if (info.tree && !entry.source.file) {
        const signature = JSON.stringify((info.controls || []).map((c) => c.path));
        const fresh = !entry.source.tree || signature !== entry.signature;
        entry.source = { tree: entry.source.tree && !fresh ? entry.source.tree : info.tree };
        if (fresh) { entry.signature = signature; buildControls(entry); }
      }
    }
    saveUrl();
  }

  let envSeq = 0;
  function showEnv(header, data) {
    if (header.seq < envSeq) return;  // a pass of a cancelled render
    envSeq = header.seq;
    let item = envs.get(header.id);
    if (!item) {
      const canvas = el("canvas", { className: "bx-env", title: "environment-lit sphere, refined progressively" });
      canvas.dataset.id = header.id;
      const caption = el("div", { className: "bx-caption" });
      item = { canvas, caption, box: el("div", { className: "bx-env-box" }, [canvas, caption]) };
      envs.set(header.id, item);
    }
    const size = header.arrays[0].shape[0];
    Object.assign(item, { data, size, C: header.arrays[0].shape[2], header });
    api.env[header.id] = { seq: header.seq, samples: header.samples, seconds: header.seconds, noise: header.noise, time: performance.now() };
    const noise = header.noise === null ? "" : ` · noise ${(100 * header.noise).toFixed(1)} %`;
    const what = header.samples ? `${header.samples} spp` : "exact diffuse term (0 spp)";
    item.caption.textContent = `${what}${noise} · ${header.seconds.toFixed(2)} s`;
    drawEnvs();
  }
  // A progressive view's canvas painted with its linear image under the display, unless it
  // shows that very image under that display already (a frame of the spheres redraws them).
  const painted = new WeakMap();  // canvas → what it shows
  function paintImage(canvas, data, size, C) {
    const d = state.display, shows = [data, size, d.exposure, d.gamma, d.channel], last = painted.get(canvas);
    if (last && shows.every((v, i) => v === last[i])) return;
    painted.set(canvas, shows);
    if (canvas.width !== size) { canvas.width = size; canvas.height = size; }
    canvas.getContext("2d").putImageData(new ImageData(toPixels(data, size, C, d), size, size), 0, 0);
  }
  function drawEnvs() {
    const ids = visibleIds();
    const shown = state.view.envmap ? state.entries.filter((e) => ids.has(e.id) && envs.has(e.id)) : [];
    for (const e of shown) {
      const item = envs.get(e.id);
      item.canvas.style.borderColor = e.color;
      paintImage(item.canvas, item.data, item.size, item.C);
    }
    const boxes = shown.map((e) => envs.get(e.id).box);
    const current = Array.from(envPanel.children);
    if (current.length !== boxes.length || current.some((c, i) => c !== boxes[i])) envPanel.replaceChildren(...boxes);
    envGroup.box.hidden = !shown.length;
  }

  // ---- the lit object: one canvas per BRDF (and the difference of the first two); a drag on
  // any of them orbits the camera
  let litSeq = 0, orbit = null;
  function litCanvas(id, title) {
    const canvas = el("canvas", { className: "bx-lit-image", title });
    canvas.dataset.id = id;
    canvas.addEventListener("pointerdown", (e) => { orbit = { x: e.clientX, y: e.clientY }; canvas.setPointerCapture(e.pointerId); });
    canvas.addEventListener("pointermove", (e) => {
      if (!orbit) return;
      const v = state.view;
      v.azimuth = tidy(((((v.azimuth - (e.clientX - orbit.x) * 0.5) % 360) + 540) % 360) - 180);
      v.elevation = tidy(Math.min(Math.max(v.elevation + (e.clientY - orbit.y) * 0.5, ELEVATION[0]), ELEVATION[1]));
      orbit = { x: e.clientX, y: e.clientY };
      api.orbited = performance.now();
      changed();
    });
    canvas.addEventListener("pointerup", () => { orbit = null; });
    return canvas;
  }
  function showLit(header, data) {
    if (header.seq < litSeq) return;  // a pass of a cancelled view
    litSeq = header.seq;
    let item = lits.get(header.id);
    if (!item) {
      const canvas = litCanvas(header.id, "lit object: drag to orbit");
      const caption = el("div", { className: "bx-caption" });
      item = { canvas, caption, box: el("div", { className: "bx-lit-box" }, [canvas, caption]) };
      lits.set(header.id, item);
    }
    const size = header.arrays[0].shape[0];
    Object.assign(item, { data, size, C: header.arrays[0].shape[2], header });
    api.lit[header.id] = { seq: header.seq, samples: header.samples, seconds: header.seconds, noise: header.noise, mesh: header.mesh, azimuth: header.azimuth, elevation: header.elevation, time: performance.now() };
    item.caption.textContent = `${header.samples} spp · noise ${(100 * header.noise).toFixed(1)} % · ${header.seconds.toFixed(2)} s`;
    drawLits();
  }
  let litDifference = null;
  function drawLits() {
    const ids = visibleIds();
    const shown = state.view.lit ? state.entries.filter((e) => ids.has(e.id) && lits.has(e.id)) : [];
    for (const e of shown) {
      const item = lits.get(e.id);
      item.canvas.style.borderColor = e.color;
      paintImage(item.canvas, item.data, item.size, item.C);
    }
    const boxes = shown.map((e) => lits.get(e.id).box);
    if (shown.length >= 2) {
      const [a, b] = shown.map((e) => lits.get(e.id));
      if (a.size === b.size) {
        if (!litDifference) litDifference = { canvas: litCanvas("difference", "|first − second|: drag to orbit") };
        const d = litDifference, C = Math.max(a.C, b.C);
        if (d.a !== a.data || d.b !== b.data) {  // a new pass of either
          const n = a.size * a.size;
          Object.assign(d, { a: a.data, b: b.data, data: new Float32Array(n * C) });
          for (let p = 0; p < n; p++) for (let k = 0; k < C; k++) d.data[p * C + k] = Math.abs(a.data[p * a.C + (a.C === 1 ? 0 : k)] - b.data[p * b.C + (b.C === 1 ? 0 : k)]);
        }
        paintImage(d.canvas, d.data, a.size, C);
        boxes.push(d.canvas);
      }
    }
    const current = Array.from(litPanel.children);
    if (current.length !== boxes.length || current.some((c, i) => c !== boxes[i])) litPanel.replaceChildren(...boxes);
    litGroup.box.hidden = !shown.length;
  }

  function showChecks(header) {
    const r = header.report;
    const rows = r.checks.map((c) => el("tr", { className: c.contradicts_claim ? "bad" : c.passed ? "ok" : "" }, [
      el("td", { textContent: c.name }), el("td", { textContent: c.verdict }),
      el("td", { textContent: c.value === null ? "—" : Number(c.value).toPrecision(3) }),
      el("td", { textContent: c.tolerance === null ? "—" : Number(c.tolerance).toPrecision(3) }),
    ]));
    checksBody.replaceChildren(
      el("div", { textContent: `${r.model.slice(0, 120)}: ${r.consistent ? "every measurement agrees with its claims" : "a measurement CONTRADICTS a claim"}` }),
      el("table", {}, [el("tr", {}, ["check", "verdict", "value", "tolerance"].map((t) => el("th", { textContent: t }))), ...rows]),
    );
  }

  // ---- drawing
  const drawn = new Map();  // view name → the inputs it was last drawn from (inputsChanged)
  function shownEntries() {
    const ids = visibleIds();
    return state.entries.filter((e) => frame.header.views[e.id] && ids.has(e.id));
  }
  function redraw() {
    saveUrl();
    if (!frame) return;
    drawEnvs();
    drawLits();
    const { header, arrays } = frame;
    const d = state.display, v = state.view;
    const shown = shownEntries();
    const channels = (e) => (e.info ? e.info.channels : 1);
    const arr = (e, name) => arrays[header.views[e.id][name]];
    const colors = shown.map((e) => `${e.id}:${e.color}`).join(" ");
    const changedFor = (name, ...inputs) => inputsChanged(drawn, name, [colors, d.channel, d.log, ...inputs]);
    api.plotted = {};

    // lit spheres (+ the difference of the first two, computed by the server in float64)
    let R = v.resolution;  // a preview's sphere has half the pixels
    const image = (e, name) => {
      const spec = header.arrays[header.views[e.id][name]], disc = arr(e, "disc");
      R = header.arrays[header.views[e.id].disc].shape[0];
      return { values: arr(e, name), disc, C: spec.shape[1] };
    };
    const paint = (name, sphere) => changedFor(name, sphere.values, sphere.disc, d.exposure, d.gamma)
      ? toPixels(sphere.values, R, sphere.C, d, sphere.disc) : null;
    const canvases = shown.map((e) => sphereCanvas(e.id, e.color, paint(`sphere ${e.id}`, image(e, "sphere")), R));
    if (shown.length >= 2 && header.views[shown[0].id].difference !== undefined) {
      const pixels = paint("sphere difference", image(shown[0], "difference"));
      canvases.push(sphereCanvas("difference", "#000", pixels, R, "|first − second|"));
    }
    const current = Array.from(spheres.children);
    if (current.length !== canvases.length || current.some((c, i) => c !== canvases[i])) spheres.replaceChildren(...canvases);

    // curves (api.plotted holds every curve's values, drawn or not)
    const curve = (name, cosine) => shown.map((e) => {
      const x = arrays[header.axes[name]];
      let y = channelOf(arr(e, name), channels(e), d.channel);
      if (cosine) y = y.map((value, i) => value * Math.max(Math.cos(x[i]), 0));
      api.plotted[name] = api.plotted[name] || {};
      api.plotted[name][e.id] = { x: Array.from(x), y: Array.from(y) };
      return { x, y, color: e.color };
    });
    const ys = (series) => series.map((s) => s.y);
    const tv = curve("theta_v", d.cosine);
    if (changedFor("theta_v", ...ys(tv), d.cosine, v.theta_i)) {
      polarPlot(polar.canvas, tv, v.theta_i, d.log);
      linePlot(curves.theta_v.canvas, tv, { log: d.log, xmin: -90, xmax: 90, title: d.cosine ? "f·cos θv" : "f" });
    }
    const th = curve("theta_h", false), td = curve("theta_d", false);
    if (changedFor("theta_h", ...ys(th), v.theta_d, v.phi_d)) {
      linePlot(curves.theta_h.canvas, th, { log: d.log, title: `f at θd = ${v.theta_d}°, φd = ${v.phi_d}°` });
    }
    if (changedFor("theta_d", ...ys(td), v.theta_h, v.phi_d)) {
      linePlot(curves.theta_d.canvas, td, { log: d.log, title: `f at θh = ${v.theta_h}°, φd = ${v.phi_d}°` });
    }
    drawAlbedo(shown);

    // 3D lobe
    const lobes = shown.map((e) => arr(e, "lobe"));
    // every second grid line (a quarter of the quads); a preview's every fourth
    const step = header.preview ? 4 : 2;
    if (changedFor("lobe", ...lobes, step, d.cosine, v.theta_i, v.phi_i, state.rotation.yaw, state.rotation.pitch)) {
      const wi = [Math.sin(rad(v.theta_i)) * Math.cos(rad(v.phi_i)), Math.sin(rad(v.theta_i)) * Math.sin(rad(v.phi_i)), Math.cos(rad(v.theta_i))];
      const meshes = shown.map((e) => {
        const spec = header.arrays[header.views[e.id].lobe];
        const [T, P] = spec.shape;
        let r = channelOf(arr(e, "lobe"), channels(e), d.channel);
        if (d.cosine) r = r.map((value, i) => value * Math.cos((Math.floor(i / P) / (T - 1)) * (Math.PI / 2)));
        if (d.log) r = r.map((value) => Math.log10(1 + value));
        return { r, shape: [T, P], color: e.color };
      });
      lobePlot(lobe.canvas, meshes, wi, state.rotation, step);
    }

    // θh × θd slices (log colour scale)
    setText(sliceTitle, `θh × θd slices at φd = ${v.phi_d}° (log colour scale)`);
    const sliceCanvases = shown.map((e) => {
      const n = header.arrays[header.views[e.id].slice].shape[0];
      let canvas = slicesDrawn.get(e.id);
      if (!canvas) {
        canvas = el("canvas", { className: "bx-slice" });
        canvas.dataset.id = e.id;
        slicesDrawn.set(e.id, canvas);
      }
      canvas.title = e.info.label;
      canvas.style.borderColor = e.color;
      const values = arr(e, "slice");
      if (changedFor(`slice ${e.id}`, values, n) || canvas.width !== n) {
        canvas.width = n; canvas.height = n;
        const px = slicePixels(channelOf(values, channels(e), d.channel), n);
        canvas.getContext("2d").putImageData(new ImageData(px, n, n), 0, 0);
      }
      return canvas;
    });
    const currentSlices = Array.from(slices.children);
    if (currentSlices.length !== sliceCanvases.length || currentSlices.some((c, i) => c !== sliceCanvases[i])) slices.replaceChildren(...sliceCanvases);
  }
  const slicesDrawn = new Map();  // id → its slice's canvas
  function drawAlbedo(shown) {
    if (!albedo) return;
    const d = state.display, views = albedo.header.views;
    const series = shown.filter((e) => views[e.id]).map((e) => ({ e, v: views[e.id] }));
    const inputs = series.flatMap(({ e, v }) => [e.id, e.color, albedo.arrays[v.albedo], albedo.arrays[v.albedo_err]]);
    if (!inputsChanged(drawn, "albedo", [d.channel, ...inputs])) return;
    const ax = albedo.arrays[albedo.header.axes.albedo];
    linePlot(curves.albedo.canvas, series.map(({ e, v }) => {
      const channels = e.info ? e.info.channels : 1;
      const mean = channelOf(albedo.arrays[v.albedo], channels, d.channel);
      const err = channelOf(albedo.arrays[v.albedo_err], channels, d.channel).map((s) => 2 * s);
      return { x: ax, y: mean, band: err, color: e.color };
    }), { xmin: 0, xmax: 90, title: "ρ(θo)" });
  }
  const rad = (deg) => (deg * Math.PI) / 180;

  // Sphere canvases persist across frames (a drag keeps its pointer capture).
  const sphereCanvases = new Map();
  function sphereCanvas(id, color, pixels, R, title) {
    let canvas = sphereCanvases.get(id);
    if (!canvas) {
      canvas = el("canvas", { className: "bx-sphere", title: title || "drag to move the light" });
      canvas.dataset.id = id;
      sphereCanvases.set(id, canvas);
      const move = (e) => {
        const rect = canvas.getBoundingClientRect();
        let x = ((e.clientX - rect.left) / rect.width) * 2 - 1, y = 1 - ((e.clientY - rect.top) / rect.height) * 2;
        const r = Math.hypot(x, y);
        if (r > 0.9999) { x *= 0.9999 / r; y *= 0.9999 / r; }
        // the point's normal is the light direction: world (√(1−x²−y²), x, y) = local (x, y, z)
        const z = Math.sqrt(Math.max(1 - x * x - y * y, 0));
        state.view.theta_i = Math.min(tidy((Math.acos(z) * 180) / Math.PI), 89.9);
        state.view.phi_i = tidy((Math.atan2(y, x) * 180) / Math.PI);
        for (const k of ["theta_i", "phi_i"]) { inputs[k].range.value = state.view[k]; inputs[k].out.textContent = state.view[k]; }
        moved();
      };
      canvas.addEventListener("pointerdown", (e) => { canvas.setPointerCapture(e.pointerId); canvas.dataset.dragging = "1"; grabbed(); move(e); });
      canvas.addEventListener("pointermove", (e) => { if (canvas.dataset.dragging) move(e); });
      canvas.addEventListener("pointerup", () => { delete canvas.dataset.dragging; released(); });
    }
    if (canvas.width !== R) { canvas.width = R; canvas.height = R; }
    canvas.style.borderColor = color;
    if (pixels) canvas.getContext("2d").putImageData(new ImageData(pixels, R, R), 0, 0);
    return canvas;
  }

  // ---- state in the URL, exports
  function persistent() {
    return {
      entries: state.entries.map((e) => ({ id: e.id, source: e.source, visible: e.visible, solo: e.solo, color: e.color })),
      view: state.view, display: state.display, rotation: state.rotation,
    };
  }
  let urlTimer = 0;
  function saveUrl() {
    if (!config.url) return;
    clearTimeout(urlTimer);
    urlTimer = setTimeout(() => history.replaceState(null, "", "#s=" + encodeState(persistent())), 150);
  }
  function download(name, data, type) {
    const blob = data instanceof Blob ? data : new Blob([data], { type });
    const a = el("a", { href: URL.createObjectURL(blob), download: name });
    a.click();
    setTimeout(() => URL.revokeObjectURL(a.href), 1000);
  }
  async function uploadFile(file) {
    const limit = config.max_upload;
    if (limit && file.size > limit) {  // the server refuses it too (413)
      status.textContent = `'${file.name}' holds ${file.size} bytes; an upload holds at most ${limit / 1048576} MiB (${limit} bytes)`;
      return;
    }
    status.textContent = `uploading ${file.name}…`;
    try {
      const reply = await transport.upload(file);
      if (reply.spec) addEntry({ spec: reply.spec });
      else if (reply.mesh) {
        config.meshes = [...(config.meshes || []), reply.mesh];
        state.view.mesh = reply.mesh;
        refreshMeshes(config.meshes);
        state.view.lit = true;
        inputs.lit.check.checked = true;
        changed();
      } else {
        config.files = [...(config.files || []), reply.name];
        refreshFiles(config.files);
        addEntry({ file: reply.name });
      }
      status.textContent = "";
    } catch (err) {
      status.textContent = String(err.message || err);
    }
  }

  // ---- start: from a saved state, else the initial specs and files
  function restore(saved) {
    Object.assign(state.view, saved.view || {});
    Object.assign(state.display, saved.display || {});
    Object.assign(state.rotation, saved.rotation || {});
    for (const [k, v] of Object.entries({ ...state.view, ...state.display })) {
      const input = inputs[k];
      if (!input) continue;
      if (input.range) { input.range.value = v; input.out.textContent = v; }
      if (input.select) input.select.value = String(v);
      if (input.check) input.check.checked = v;
    }
    for (const e of saved.entries || []) {
      nextId = Math.max(nextId, Number(String(e.id).replace(/\D/g, "")) + 1 || nextId);
      addEntry(e.source, { id: e.id, visible: e.visible !== false, solo: !!e.solo, color: e.color || PALETTE[0] });
    }
  }
  api.addEntry = addEntry;
  api.envImage = (id) => Array.from(envs.get(id).data);
  api.litImage = (id) => Array.from(lits.get(id).data);
  api.restore = restore;
  api.persistent = persistent;
  if (config.saved) restore(config.saved);
  else for (const item of config.initial || ["lambertian(albedo=0.5) + ggx(alpha=0.2)"]) {
    addEntry((config.files || []).includes(item) ? { file: item } : { spec: item });
  }
  if (!state.entries.length) changed();
  return api;
}
