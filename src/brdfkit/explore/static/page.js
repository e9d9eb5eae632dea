// The web page's transport: one WebSocket to the local server (same origin, token in the path),
// uploads by POST. The page's state lives in its URL (#s=…), so that the URL restores it.
import { createExplorer, decodeState } from "./explorer.js";
import { materialPicker } from "./materials.js";

function transport(base) {
  const url = base.replace(/^http/, "ws") + "ws";
  let socket = null, handler = () => {};
  const queue = [];
  const open = () => {
    socket = new WebSocket(url);
    socket.binaryType = "arraybuffer";
    socket.onopen = () => { while (queue.length) socket.send(queue.shift()); };
    socket.onmessage = (event) => {
      const view = new DataView(event.data);
      const length = view.getUint32(0, true);
      const header = JSON.parse(new TextDecoder().decode(new Uint8Array(event.data, 4, length)));
      const start = Math.ceil((4 + length) / 8) * 8;
      const buffers = (header.arrays || []).map((spec, i) => {
        const size = { float32: 4, float64: 8, int32: 4, uint8: 1 }[spec.dtype] * spec.shape.reduce((a, b) => a * b, 1);
        return new Uint8Array(event.data, start + header.offsets[i], size);
      });
      handler(header, buffers);
    };
    socket.onclose = () => { document.body.classList.add("bx-disconnected"); };
  };
  open();
  return {
    send(message) {
      const text = JSON.stringify(message);
      if (socket.readyState === WebSocket.OPEN) socket.send(text); else queue.push(text);
    },
    onMessage(callback) { handler = callback; },
    async upload(file) {
      const response = await fetch(base + "upload?name=" + encodeURIComponent(file.name), { method: "POST", body: file });
      const reply = await response.json();
      if (!response.ok) throw new Error(reply.error || response.statusText);
      return reply;  // {name} of a measured file, or {spec} of a fit.json
    },
  };
}

const base = location.origin + location.pathname.replace(/[^/]*$/, "");
const config = await (await fetch(base + "config")).json();
const saved = location.hash.startsWith("#s=") ? decodeState(location.hash.slice(3)) : null;
window.explorer = createExplorer(document.getElementById("explorer"), transport(base), { ...config, saved, url: true });
materialPicker(document.getElementById("explorer"), config.materials);
